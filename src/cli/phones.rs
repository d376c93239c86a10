//! `lipmap phones FILE`: print a parsed phone alignment as `start,end,phone` CSV (or JSON),
//! so a user can check what lipmap understood from an aligner's output.

use crate::io::alignment_format::{self, AlignmentFormat, TierChoice};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// Print the phones of a TextGrid, HTK/Festival label file or phones CSV.
#[derive(clap::Args, Debug)]
pub struct PhonesArgs {
    /// The alignment file.
    pub file: PathBuf,
    /// TextGrid tier: a name, or a 1-based number (default: the tier named phones/phonemes).
    #[arg(long)]
    pub tier: Option<String>,
    /// Print JSON instead of CSV.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &PhonesArgs, out: &mut dyn Write) -> Result<()> {
    let tier = args.tier.as_deref().map(tier_choice);
    let alignment = alignment_format::read_alignment(&args.file, tier.as_ref())?;
    if args.json {
        serde_json::to_writer_pretty(&mut *out, &alignment.phones)?;
        writeln!(out)?;
    } else {
        out.write_all(
            alignment_format::format_alignment(&alignment, AlignmentFormat::PhonesCsv).as_bytes(),
        )?;
    }
    Ok(())
}

/// `--tier 2` is the second tier (1-based, as Praat numbers them); anything else is a name.
pub fn tier_choice(s: &str) -> TierChoice {
    match s.parse::<usize>() {
        Ok(n) => TierChoice::Index(n),
        _ => TierChoice::Name(s.to_string()),
    }
}
