//! The plain-text CSV tables of `data/` (`#` comment lines, a fixed header, one row a line):
//! their data rows with line numbers. What a row means is its own table's parser's.

/// A table's data rows, each trimmed, with its 1-based line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CsvRows<'t> {
    pub rows: Vec<(usize, &'t str)>,
    /// The last row's line (the header's when there is none), for errors about the table as
    /// a whole.
    pub last_line: usize,
}

/// The data rows of `text` after checking the header is `header` (e.g. `index,group,name`);
/// blank and `#` lines are skipped.
///
/// # Errors
/// `(line, message)`: no header at all, or another header.
///
/// ```
/// let t = lipmap::table_text::csv_rows("# note\na,b\n1,2\n\n3,4\n", "a,b").unwrap();
/// assert_eq!((t.rows, t.last_line), (vec![(3, "1,2"), (5, "3,4")], 5));
/// assert_eq!(lipmap::table_text::csv_rows("x,y\n", "a,b").unwrap_err().0, 1);
/// ```
pub fn csv_rows<'t>(text: &'t str, header: &str) -> Result<CsvRows<'t>, (usize, String)> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (header_line, found) = lines.next().ok_or((1, "empty file".to_string()))?;
    if !found.split(',').map(str::trim).eq(header.split(',')) {
        return Err((header_line, format!("expected the header `{header}`, got `{found}`")));
    }
    let rows: Vec<(usize, &str)> = lines.collect();
    let last_line = rows.last().map_or(header_line, |&(l, _)| l);
    Ok(CsvRows { rows, last_line })
}
