//! `lipmap map suggest|check`: suggest a session's whole landmark map from the labels made so
//! far (for batch use and scripting, as the TUI's `O`), and check a session's map against
//! anatomy.

use crate::cli::progress::print_warnings;
use crate::io::landmark_map_toml::write_landmark_map;
use crate::landmarks::PointNo;
use crate::session::MapRole;
use crate::workflow::map::{check_session_map, label_role, mesh_file_of, suggest_session_map};
use crate::workflow::{read_session, session_path};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug)]
pub enum MapCommand {
    /// Suggest a vertex for every unlabelled landmark from the session's labels (at least 4
    /// visible in the frame): one vertex per landmark, left/right and order checked, with a
    /// confidence each; what fails is left out and listed.
    Suggest(SuggestArgs),
    /// Check the session's map: shared vertices, left/right crossings, contours out of
    /// order, implausible eye/mouth proportions.
    Check(CheckArgs),
}

#[derive(clap::Args, Debug)]
pub struct SuggestArgs {
    /// Session (`NAME` for sessions/NAME.lipmap.json, or a `.lipmap.json` path).
    pub session: String,
    /// Match the head to this frame's tracked landmarks (the speaker's face) instead of the
    /// head's own face drawn from the front (the default when dlib's shape predictor is
    /// installed; without it, the first frame with the most visible landmarks).
    #[arg(long)]
    pub frame: Option<usize>,
    /// dlib's shape predictor, read on the head's own face (default:
    /// /usr/share/dlib/shape_predictor_68_face_landmarks.dat, Debian `libdlib-data`).
    #[arg(long, value_name = "FILE")]
    pub predictor: Option<PathBuf>,
    /// Session clip (default: the first).
    #[arg(long)]
    pub clip: Option<String>,
    /// Where to write the map (eos TOML: 1-based iBUG ids, 0-based vertices).
    #[arg(long, value_name = "MAP.toml")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Session (`NAME` or a `.lipmap.json` path).
    pub session: String,
}

/// Runs a `map` subcommand; `Ok(false)` when `check` found problems.
pub fn run(cmd: &MapCommand, out: &mut dyn Write) -> Result<bool> {
    match cmd {
        MapCommand::Suggest(a) => {
            let read = read_session(&session_path(&a.session))?;
            print_warnings(&read.notices);
            let role = label_role(&read.session);
            let s = suggest_session_map(
                &read.session,
                role,
                a.clip.as_deref(),
                a.frame,
                a.predictor.as_deref(),
            )?;
            writeln!(out, "matched to {}", s.from)?;
            writeln!(out, "{} labels; {}", s.labels.len(), s.proposal.summary())?;
            writeln!(out, "landmark  vertex  px off  confidence")?;
            for x in &s.proposal.accepted {
                writeln!(
                    out,
                    "{:>8}  {:>6}  {:>6.2}  {:>10.2}",
                    PointNo(x.landmark),
                    x.vertex,
                    x.distance_px,
                    x.confidence
                )?;
            }
            for (l, why) in &s.proposal.left {
                writeln!(out, "left {}: {why}", PointNo(*l))?;
            }
            writeln!(out, "{}", s.check.summary())?;
            write_landmark_map(&a.out, &s.map, &crate::reference::current().names)?;
            writeln!(
                out,
                "wrote {} ({} landmarks, the {} map); use it with: {}",
                a.out.display(),
                s.map.len(),
                role.name(),
                match role {
                    MapRole::Model =>
                        format!("lipmap import {} --mapping {}", a.session, a.out.display()),
                    MapRole::Head => {
                        format!("lipmap import {} --head-mapping {}", a.session, a.out.display())
                    }
                },
            )?;
            Ok(true)
        }
        MapCommand::Check(a) => {
            let read = read_session(&session_path(&a.session))?;
            print_warnings(&read.notices);
            let session = &read.session;
            let mut roles = vec![MapRole::Model];
            if session.head_has_own_map() {
                roles.push(MapRole::Head);
            }
            let mut plausible = true;
            for role in roles {
                let mesh = mesh_file_of(session, role)
                    .map_or_else(|| "no mesh".to_string(), |p| p.display().to_string());
                let Some(check) = check_session_map(session, role)? else {
                    writeln!(out, "{} map (on {mesh}): none yet", role.name())?;
                    continue;
                };
                for p in &check.problems {
                    writeln!(out, "{} map: {p}", role.name())?;
                }
                writeln!(out, "{} map (on {mesh}): {}", role.name(), check.summary())?;
                plausible &= check.is_plausible();
            }
            if !plausible {
                writeln!(
                    out,
                    "fix the labels in the TUI (view 2), or label 4-6 good ones and run `lipmap map suggest {} --out MAP.toml`",
                    a.session
                )?;
            }
            Ok(plausible)
        }
    }
}
