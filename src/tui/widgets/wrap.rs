//! Word wrapping for text the screen lays out itself (the status line, side panels): the
//! rows a text takes must be known before drawing, so the layout and the drawing agree.
//! Widths are terminal columns, as ratatui counts them.

use ratatui::text::{Line, Span};

/// A space [`wrap_words`] never breaks at: it keeps a value with its unit (`1.28 px`) or its
/// name (`roll 13°`) on one row. It draws as a space.
pub const NBSP: char = '\u{a0}';

/// Terminal columns `s` takes.
fn cols(s: &str) -> usize {
    Span::raw(s).width()
}

/// `text` broken into rows of at most `width` columns, at spaces where it can be, inside a
/// word longer than a row where it cannot. An empty text is one empty row.
pub fn wrap_words(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut rows = Vec::new();
    let mut row = String::new();
    for word in text.split(' ') {
        let gap = usize::from(!row.is_empty());
        if cols(&row) + gap + cols(word) <= width {
            if gap == 1 {
                row.push(' ');
            }
            row.push_str(word);
            continue;
        }
        if !row.is_empty() {
            rows.push(std::mem::take(&mut row));
        }
        // A word wider than a row is cut into rows of its own.
        for c in word.chars() {
            if cols(&row) + cols(c.encode_utf8(&mut [0; 4])) > width {
                rows.push(std::mem::take(&mut row));
            }
            row.push(c);
        }
    }
    rows.push(row);
    rows
}

/// Lines of one style each, wrapped to `width` columns, their style kept (a line's first
/// span's style is the whole wrapped line's).
pub fn wrap_lines(lines: Vec<Line<'static>>, width: usize) -> Vec<Line<'static>> {
    let mut out = Vec::new();
    for line in lines {
        let style = line.spans.first().map_or(line.style, |s| line.style.patch(s.style));
        let text: String = line.spans.iter().map(|s| s.content.as_ref()).collect();
        if cols(&text) <= width {
            out.push(line);
            continue;
        }
        out.extend(
            wrap_words(&text, width).into_iter().map(|r| Line::from(Span::styled(r, style))),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_break_at_spaces_and_never_exceed_the_width() {
        let text = "suggested 59 landmarks (lowest confidence 0.31), left 9: 4 anatomy, 5 not visible; e.g. 61 not tracked as visible in this frame; u undoes";
        for width in [10, 25, 58, 80, 160] {
            let rows = wrap_words(text, width);
            assert!(rows.iter().all(|r| cols(r) <= width), "{width}: {rows:?}");
            assert_eq!(rows.join(" "), text, "{width}: nothing lost");
        }
        assert_eq!(wrap_words(text, 160).len(), 1);
        assert_eq!(wrap_words("a bb ccc", 4), ["a bb", "ccc"]);
        assert_eq!(wrap_words("abcdefgh", 3), ["abc", "def", "gh"]);
        assert_eq!(wrap_words("", 5), [""]);
        assert_eq!(wrap_words("yaw -12° pitch", 8), ["yaw -12°", "pitch"], "° is one column");
        let pose = format!("pitch{NBSP}-12° roll{NBSP}13°");
        assert_eq!(wrap_words(&pose, 12), ["pitch\u{a0}-12°", "roll\u{a0}13°"]);
    }

    #[test]
    fn wrapped_lines_keep_their_style() {
        use ratatui::style::{Color, Stylize};
        let lines =
            vec![Line::from("yaw -12° pitch -10° roll -11°").fg(Color::Red), Line::from("ok")];
        let out = wrap_lines(lines, 20);
        assert_eq!(out.len(), 3);
        assert_eq!(out[0].to_string(), "yaw -12° pitch -10°");
        assert_eq!(out[1].to_string(), "roll -11°");
        assert_eq!(out[1].style.fg.or(out[1].spans[0].style.fg), Some(Color::Red));
    }
}
