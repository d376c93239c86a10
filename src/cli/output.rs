//! How commands print tables: aligned text (default), CSV blocks, or one JSON document —
//! the `--format`/`--json` choice every tabular command shares.

use crate::eval::Table;
use anyhow::Result;
use std::io::Write;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum TableFormat {
    #[default]
    Text,
    Csv,
    Json,
}

/// `--format` / `--json` flags for tabular output.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct FormatArgs {
    /// Output format for tables.
    #[arg(long, value_enum, default_value_t = TableFormat::Text)]
    pub format: TableFormat,
    /// Same as --format json.
    #[arg(long)]
    pub json: bool,
}

impl FormatArgs {
    pub fn format(&self) -> TableFormat {
        if self.json { TableFormat::Json } else { self.format }
    }
}

/// Writes tables in `format`: text tables separated by blank lines; CSV blocks each headed
/// by a `# title` line; JSON as `{title: [records...]}` in order.
pub fn write_tables(tables: &[&Table], format: TableFormat, out: &mut dyn Write) -> Result<()> {
    let mut out = out;
    match format {
        TableFormat::Text => {
            for (i, t) in tables.iter().enumerate() {
                if i > 0 {
                    writeln!(out)?;
                }
                t.write_text(&mut out)?;
            }
        }
        TableFormat::Csv => {
            for (i, t) in tables.iter().enumerate() {
                if i > 0 {
                    writeln!(out)?;
                }
                writeln!(out, "# {}", t.title)?;
                t.write_csv(&mut out)?;
            }
        }
        TableFormat::Json => {
            let mut doc = serde_json::Map::new();
            for t in tables {
                doc.insert(t.title.clone(), t.to_json_records());
            }
            serde_json::to_writer_pretty(&mut out, &serde_json::Value::Object(doc))?;
            writeln!(out)?;
        }
    }
    Ok(())
}
