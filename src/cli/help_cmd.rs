//! `lipmap help [COMMAND... | TERM]`: a command's options (as `--help` prints them), or what a
//! term lipmap prints means (the glossary, `docs/glossary.md`); `lipmap help terms` lists the
//! terms.

use crate::glossary;
use anyhow::{Result, bail};
use clap::CommandFactory;
use std::io::Write;

#[derive(clap::Args, Debug)]
pub struct HelpArgs {
    /// A command (`fit`, `saqp cv`), a term as lipmap prints it (`reprojection RMS`,
    /// `omega_m`, `bridged`), or `terms` for the list of terms.
    pub topic: Vec<String>,
}

/// Prints the help asked for.
///
/// # Errors
/// A topic that is neither a command nor a term, naming where the terms are listed.
pub fn run(a: &HelpArgs, out: &mut dyn Write) -> Result<()> {
    let mut cmd = super::Cli::command();
    if a.topic.is_empty() {
        write!(out, "{}", cmd.render_long_help())?;
        return Ok(());
    }
    let words: Vec<&str> = a.topic.iter().map(String::as_str).collect();
    if words == ["terms"] {
        writeln!(out, "Terms lipmap prints (`lipmap help TERM` explains one; docs/glossary.md):")?;
        for e in glossary::entries() {
            writeln!(out, "  {:<32} {}", e.term, e.unit)?;
        }
        return Ok(());
    }
    // A command path: `help saqp cv` is `saqp cv --help`.
    if cmd.find_subcommand(words[0]).is_some() {
        // Built first, so each subcommand's usage names its whole path (`lipmap saqp cv`).
        cmd.build();
        let mut at = cmd;
        for w in &words {
            let Some(sub) = at.find_subcommand(w).cloned() else {
                bail!("`{}` has no command `{w}`", at.get_bin_name().unwrap_or(at.get_name()))
            };
            at = sub;
        }
        write!(out, "{}", at.render_long_help())?;
        return Ok(());
    }
    let term = words.join(" ");
    match glossary::lookup(&term) {
        Some(e) => write!(out, "{}", e.to_text())?,
        None => bail!(
            "no command or term `{term}`; `lipmap help terms` lists the terms, `lipmap --help` \
             the commands"
        ),
    }
    Ok(())
}
