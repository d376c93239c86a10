//! `lipmap profile SESSION`: set a clip's side-view protrusion setup once (crop, reference
//! line, facing, threshold, nose length) or let lipmap propose it, correct single frames'
//! upper-lip points, store both in the session, and print P per front frame with each
//! point's source (the values `eval` compares with the head's P).

use crate::cli::output::{FormatArgs, write_tables};
use crate::eval::{Cell, Table};
use crate::landmarks::PointSource;
use crate::math::Point2;
use crate::measure::profile::{Facing, NoseLength, ProfileSetup, Rect, ReferenceLine, Threshold};
use crate::workflow::{self, PROFILE_SETUP_KEY, open_for_edit, select_clips};
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

pub fn run(a: &ProfileArgs, out: &mut dyn Write) -> Result<()> {
    let workflow::EditSession { path, lock: _lock, mut session } = open_for_edit(&a.session)?;
    let clips = select_clips(&session, a.clip.as_deref())?;
    let editing = !a.correct.is_empty() || !a.uncorrect.is_empty();
    if editing {
        check_corrections(&session, &clips, a)?;
    }
    let mut tables = Vec::new();
    for c in clips {
        if session.clips[c].side.is_none() {
            eprintln!("lipmap: clip `{}` has no side view; skipped", session.clips[c].name);
            continue;
        }
        if a.reset {
            session.clips[c].extensions.remove(PROFILE_SETUP_KEY);
        }
        let mut setup = workflow::profile_setup(&session, c)?;
        apply_overrides(&mut setup, a)?;
        workflow::check_setup_in_frame(&session, c, &setup)?;
        session.clips[c].extensions.insert(PROFILE_SETUP_KEY.into(), serde_json::to_value(&setup)?);
        if editing {
            let n_side = session.open_side_frames(c, 1)?.map_or(0, |f| f.len());
            for &f in &a.uncorrect {
                if session.clear_profile_correction(c, f)?.is_none() {
                    eprintln!("lipmap: side-view frame {f} had no correction");
                }
            }
            for &(f, p) in &a.correct {
                if f >= n_side {
                    bail!("--correct: side-view frame {f} does not exist ({n_side} frames)");
                }
                session.set_profile_correction(c, f, p)?;
            }
        }
        let n = workflow::clip_length(&session, c)?;
        let Some((_, points)) = workflow::side_view_points(&session, c, n)? else { continue };
        let p: Vec<Option<f64>> = points.iter().map(workflow::SidePoint::p).collect();
        let p = if a.min_max { crate::measure::min_max_normalise(&p).unwrap_or(p) } else { p };
        let name = session.clips[c].name.clone();
        let failed = p.iter().filter(|v| v.is_none()).count();
        let corrected = session.clips[c].profile_corrections.len();
        let mut t = Table::new(
            format!("side-view protrusion: {name}"),
            ["frame", "side frame", "x", "y", "P", "source"].map(String::from).to_vec(),
        );
        let mut reasons = std::collections::BTreeMap::<String, usize>::new();
        for (f, (v, sp)) in p.iter().zip(&points).enumerate() {
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
        t.notes.push(format!("{corrected} side-view frames corrected by hand"));
        t.notes.push(format!(
            "crop {},{},{},{}; line {:.1},{:.1} to {:.1},{:.1}; facing {:?}; {failed} of {n} frames without a value",
            setup.crop.x,
            setup.crop.y,
            setup.crop.width,
            setup.crop.height,
            setup.reference_line.a.x,
            setup.reference_line.a.y,
            setup.reference_line.b.x,
            setup.reference_line.b.y,
            setup.facing
        ));
        tables.push(t);
    }
    session.save(&path)?;
    write_tables(&tables.iter().collect::<Vec<_>>(), a.output.format(), out)
}

/// Refuses corrections that could land on the wrong clip or contradict each other, before
/// anything is changed.
fn check_corrections(
    session: &crate::session::Session,
    clips: &[usize],
    a: &ProfileArgs,
) -> Result<()> {
    let with_side = clips.iter().filter(|&&c| session.clips[c].side.is_some()).count();
    if with_side == 0 {
        bail!("--correct/--uncorrect: no selected clip has a side view");
    }
    if with_side > 1 {
        bail!("--correct/--uncorrect: {with_side} clips have a side view; choose one with --clip");
    }
    if let Some(&(f, _)) = a.correct.iter().find(|(f, _)| a.uncorrect.contains(f)) {
        bail!("side-view frame {f} is both corrected and uncorrected");
    }
    Ok(())
}

fn apply_overrides(setup: &mut ProfileSetup, a: &ProfileArgs) -> Result<()> {
    if let Some(c) = &a.crop {
        if c.len() != 4 || c[2] == 0 || c[3] == 0 {
            bail!("--crop needs a positive width and height, got {c:?}");
        }
        setup.crop = Rect::new(c[0], c[1], c[2], c[3]);
    }
    if let Some(l) = &a.line {
        if l.len() != 4 {
            bail!("--line needs x1,y1,x2,y2, got {l:?}");
        }
        let (p, q) = (Point2::new(l[0], l[1]), Point2::new(l[2], l[3]));
        if (p - q).norm() < 1e-9 {
            bail!("--line needs two distinct points, got {l:?}");
        }
        setup.reference_line = ReferenceLine { a: p, b: q };
    }
    if let Some(f) = a.facing {
        setup.facing = match f {
            FacingArg::Left => Facing::Left,
            FacingArg::Right => Facing::Right,
        };
    }
    if let Some(t) = a.threshold {
        setup.threshold = Threshold::Manual(t);
    }
    if let Some(n) = a.nose_px {
        if !(n.is_finite() && n > 0.0) {
            bail!("--nose-px must be a positive length, got {n}");
        }
        setup.nose = NoseLength::Px(n);
    }
    Ok(())
}
