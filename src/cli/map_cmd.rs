//! `lipmap map suggest|check`: suggest a session's whole landmark map from the labels made so
//! far (for batch use and scripting, as the TUI's `O`), and check a session's map against
//! anatomy.

use crate::cli::progress::print_warnings;
use crate::io::landmark_map_toml::write_landmark_map;
use crate::landmarks::PointNo;
use crate::session::MapRole;
use crate::workflow::map::{check_session_map, label_role_or, mesh_file_of, suggest_session_map};
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
    /// Which map to suggest when the head is another mesh than the model: the model's (what
    /// `fit` uses) or the head's own (what `transfer` and `indices` use). Default: the model's
    /// while it maps nothing, else the head's.
    #[arg(long, value_enum)]
    pub map: Option<MapChoice>,
}

/// A session's map, as `--map` names it.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapChoice {
    Model,
    Head,
}

impl From<MapChoice> for MapRole {
    fn from(c: MapChoice) -> Self {
        match c {
            MapChoice::Model => MapRole::Model,
            MapChoice::Head => MapRole::Head,
        }
    }
}

/// Why `map suggest` made nothing, naming the map; too few labels says where they are made
/// (the TUI's head view, `m` switching to the other map) and which other map has some.
fn suggest_failure(
    e: crate::workflow::Error,
    role: MapRole,
    mesh: &str,
    session: &crate::session::Session,
    name: &str,
) -> anyhow::Error {
    use crate::fit::suggest::SuggestError;
    let too_few =
        matches!(&e, crate::workflow::Error::Suggest { error: SuggestError::TooFewLabels(_), .. });
    let mut msg = format!("the {} map{mesh}: {e}", role.name());
    if too_few {
        msg.push_str(&format!(" (label them in the terminal UI: `lipmap tui {name}`, view 2"));
        let other = match role {
            MapRole::Model => MapRole::Head,
            MapRole::Head => MapRole::Model,
        };
        let labelled =
            |r: MapRole| session.map_of(r).resolve().ok().flatten().map_or(0, |m| m.len());
        if session.head_has_own_map() && labelled(other) > 0 {
            msg.push_str(&format!(
                "; the {} map has {} labels: --map {}",
                other.name(),
                labelled(other),
                other.name()
            ));
        }
        msg.push(')');
    }
    anyhow::anyhow!(msg)
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
            let session = &read.session;
            let role = label_role_or(session, a.map.map(MapRole::from));
            let mesh = mesh_file_of(session, role)
                .and_then(|p| p.file_name())
                .map_or_else(String::new, |n| format!(" on {}", n.to_string_lossy()));
            let s = suggest_session_map(
                session,
                role,
                a.clip.as_deref(),
                a.frame,
                a.predictor.as_deref(),
            )
            .map_err(|e| suggest_failure(e, role, &mesh, session, &a.session))?;
            writeln!(out, "the {} map{mesh}: matched to {}", role.name(), s.from)?;
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
