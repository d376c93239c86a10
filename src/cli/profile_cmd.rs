//! `lipmap profile SESSION`: set a clip's side-view protrusion setup once (crop, reference
//! line, facing, threshold, nose length) or let lipmap propose it, store it in the session,
//! and print P per front frame (the values `eval` compares with the head's P).

use crate::cli::eval_cmd::select_clips;
use crate::cli::new::open_for_edit;
use crate::cli::output::{FormatArgs, write_tables};
use crate::eval::{Cell, Table};
use crate::math::Point2;
use crate::measure::profile::{Facing, NoseLength, ProfileSetup, Rect, ReferenceLine, Threshold};
use crate::workflow::{self, PROFILE_SETUP_KEY};
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
    #[command(flatten)]
    pub output: FormatArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FacingArg {
    Left,
    Right,
}

pub fn run(a: &ProfileArgs, out: &mut dyn Write) -> Result<()> {
    let (path, _lock, mut session) = open_for_edit(&a.session)?;
    let clips = select_clips(&session, a.clip.as_deref())?;
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
        session.clips[c].extensions.insert(PROFILE_SETUP_KEY.into(), serde_json::to_value(&setup)?);
        let n = workflow::clip_length(&session, c)?;
        let Some(p) = workflow::side_view_protrusion(&session, c, n)? else { continue };
        let p = if a.min_max { crate::measure::min_max_normalise(&p).unwrap_or(p) } else { p };
        let name = session.clips[c].name.clone();
        let failed = p.iter().filter(|v| v.is_none()).count();
        let mut t =
            Table::new(format!("side-view protrusion: {name}"), vec!["frame".into(), "P".into()]);
        for (f, v) in p.iter().enumerate() {
            t.push_row(vec![Cell::Int(f as i64), Cell::num(*v)]);
        }
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
