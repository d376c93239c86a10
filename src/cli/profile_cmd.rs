//! `lipmap profile SESSION`: set a clip's side-view protrusion setup once (crop, reference
//! line, facing, threshold, nose length) or let lipmap propose it, correct single frames'
//! upper-lip points, store both in the session, and print P per front frame with each
//! point's source (the values `eval` compares with the head's P).

use crate::cli::output::{FormatArgs, write_tables};
use crate::cli::progress::print_warnings;
use crate::eval::{Cell, Table};
use crate::landmarks::PointSource;
use crate::math::Point2;
use crate::measure::profile::Facing;
use crate::workflow::profile_edit::{
    ClipProfile, ProfileCorrections, ProfileOverrides, all_failed_reason, edit_profiles,
};
use crate::workflow::{self, open_for_edit, select_clips};
use anyhow::{Result, bail};
use std::io::Write;

/// Set up and run the side-view lip-protrusion measure of a session's clips.
#[derive(clap::Args, Debug)]
pub struct ProfileArgs {
    /// Session file or name.
    pub session: String,
    /// Only this clip.
    #[arg(long)]
    pub clip: Option<String>,
    /// Mouth crop in side-view pixels: x,y,width,height.
    #[arg(long, value_delimiter = ',')]
    pub crop: Option<Vec<u32>>,
    /// Reference line parallel to the frontal plane: x1,y1,x2,y2 (side-view pixels).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub line: Option<Vec<f64>>,
    /// Which way the face looks in the side view.
    #[arg(long, value_enum)]
    pub facing: Option<FacingArg>,
    /// Fixed gray-level threshold instead of Otsu's.
    #[arg(long)]
    pub threshold: Option<u8>,
    /// Nose-root to nose-tip length in pixels (default: found on the profile).
    #[arg(long)]
    pub nose_px: Option<f64>,
    /// Forget the stored setup and propose a new one from the first side frame.
    #[arg(long)]
    pub reset: bool,
    /// Min–max normalise each clip's P to [0, 1] in the printed table.
    #[arg(long)]
    pub min_max: bool,
    /// Set side-view frame FRAME's upper-lip point to (X, Y) side-view pixels, overriding the
    /// automatic one (repeatable; needs --clip when several clips have a side view).
    #[arg(long, value_name = "FRAME:X,Y", value_parser = parse_correction)]
    pub correct: Vec<(usize, Point2)>,
    /// Drop the correction of side-view frame FRAME (repeatable).
    #[arg(long, value_name = "FRAME")]
    pub uncorrect: Vec<usize>,
    #[command(flatten)]
    pub output: FormatArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FacingArg {
    Left,
    Right,
}

/// Parses `FRAME:X,Y` (side-view frame, image px).
fn parse_correction(s: &str) -> Result<(usize, Point2), String> {
    let bad = || format!("expected FRAME:X,Y (e.g. 12:431.5,318), got `{s}`");
    let (frame, xy) = s.split_once(':').ok_or_else(bad)?;
    let (x, y) = xy.split_once(',').ok_or_else(bad)?;
    let frame: usize = frame.trim().parse().map_err(|_| bad())?;
    let (x, y): (f64, f64) =
        (x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?);
    if !(x.is_finite() && y.is_finite()) {
        return Err(format!("the point of `{s}` is not finite"));
    }
    Ok((frame, Point2::new(x, y)))
}

/// Runs `profile`: the edit (`workflow::profile_edit`), the session saved, one table per clip.
///
/// # Errors
/// Bad overrides or corrections, session errors, and every front frame without a P value
/// (one line with the reasons).
pub fn run(a: &ProfileArgs, out: &mut dyn Write) -> Result<()> {
    let mut opened = open_for_edit(&a.session)?;
    print_warnings(&opened.notices);
    let session = &mut opened.session;
    let clips = select_clips(session, a.clip.as_deref())?;
    let overrides = overrides_of(a)?;
    let corrections =
        ProfileCorrections { correct: a.correct.clone(), uncorrect: a.uncorrect.clone() };
    let edit = edit_profiles(session, &clips, &overrides, &corrections)?;
    print_warnings(&edit.warnings);
    let tables: Vec<Table> = edit.clips.iter().map(|c| clip_table(c, a.min_max)).collect();
    opened.save()?;
    write_tables(&tables.iter().collect::<Vec<_>>(), a.output.format(), out)?;
    if let Some(reason) = all_failed_reason(&edit) {
        bail!("{reason}");
    }
    Ok(())
}

/// The table of one clip's side-view points.
fn clip_table(c: &ClipProfile, min_max: bool) -> Table {
    let p: Vec<Option<f64>> = c.points.iter().map(workflow::SidePoint::p).collect();
    let p = if min_max { crate::measure::min_max_normalise(&p).unwrap_or(p) } else { p };
    let failed = p.iter().filter(|v| v.is_none()).count();
    let mut t = Table::new(
        format!("side-view protrusion: {}", c.name),
        ["frame", "side frame", "x", "y", "P", "source"].map(String::from).to_vec(),
    )
    .keyed("profile")
    .for_item(&c.name);
    let mut reasons = std::collections::BTreeMap::<String, usize>::new();
    for (f, (v, sp)) in p.iter().zip(&c.points).enumerate() {
        let xy = sp.point.as_ref().and_then(|q| q.upper_lip_px);
        let source = match &sp.point {
            None => "none".to_string(),
            Some(q) => match &q.failed {
                Some(why) => {
                    *reasons.entry(why.clone()).or_default() += 1;
                    "failed".to_string()
                }
                None if q.source == PointSource::Corrected => "corrected".to_string(),
                None => "automatic".to_string(),
            },
        };
        t.push_row(vec![
            Cell::Int(f as i64),
            sp.side_frame.map_or(Cell::Empty, |k| Cell::Int(k as i64)),
            Cell::num(xy.map(|q| q.x)),
            Cell::num(xy.map(|q| q.y)),
            Cell::num(*v),
            Cell::Text(source),
        ]);
    }
    for (why, count) in reasons {
        t.notes.push(format!("{count} frames failed: {why}"));
    }
    t.notes.push(format!("{} side-view frames corrected by hand", c.corrected));
    let s = &c.setup;
    t.notes.push(format!(
        "crop {},{},{},{}; line {:.1},{:.1} to {:.1},{:.1}; facing {:?}; {failed} of {} frames without a value",
        s.crop.x,
        s.crop.y,
        s.crop.width,
        s.crop.height,
        s.reference_line.a.x,
        s.reference_line.a.y,
        s.reference_line.b.x,
        s.reference_line.b.y,
        s.facing,
        p.len()
    ));
    t
}

/// The override flags as the use case takes them (shapes checked here, values there).
fn overrides_of(a: &ProfileArgs) -> Result<ProfileOverrides> {
    let crop = match &a.crop {
        None => None,
        Some(c) if c.len() == 4 => Some([c[0], c[1], c[2], c[3]]),
        Some(c) => bail!("--crop needs x,y,width,height, got {c:?}"),
    };
    let line = match &a.line {
        None => None,
        Some(l) if l.len() == 4 => Some((Point2::new(l[0], l[1]), Point2::new(l[2], l[3]))),
        Some(l) => bail!("--line needs x1,y1,x2,y2, got {l:?}"),
    };
    Ok(ProfileOverrides {
        reset: a.reset,
        crop,
        line,
        facing: a.facing.map(|f| match f {
            FacingArg::Left => Facing::Left,
            FacingArg::Right => Facing::Right,
        }),
        threshold: a.threshold,
        nose_px: a.nose_px,
    })
}
