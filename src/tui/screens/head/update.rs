//! The head view: turning and zooming the head, and labelling landmarks on its mesh (by the
//! 3D cursor, or from suggestions made as `lipmap map suggest` makes them), loading and
//! saving the map.

use crate::fit::map_suggest::LeftOut;
use crate::landmarks::{N_LANDMARKS, PointNo};
use crate::model::LandmarkMap;
use crate::tui::action::Action;
use crate::tui::app::history::relabel;
use crate::tui::app::{App, Effect};
use crate::tui::screens::head::HeadView;
use crate::tui::screens::head::view as head;

/// Whether labels may be set now: not while a transferred head is shown (labels go on the
/// model; a transferred head is only looked at, turned and zoomed). Says so when not.
fn labelling(app: &mut App) -> bool {
    if app.head.heads.shown.is_some() {
        app.status = "labels are set on the model: t until the model is shown".into();
        return false;
    }
    true
}

/// Asks the run loop to save and reopen the session labelling the other mesh's map, when
/// there are two (the head is another mesh than the model); says so when there is one.
pub fn switch_labelled_mesh(app: &mut App) -> Option<Action> {
    use crate::session::MapRole;
    if !app.head.head_has_own_map {
        app.status = "one map to label: the head is the model's own mesh".into();
        return None;
    }
    let other = match app.head.label_role {
        MapRole::Model => MapRole::Head,
        MapRole::Head => MapRole::Model,
    };
    app.switch_map = Some(other);
    app.status = format!("saving, then labelling the {} map…", other.name());
    crate::tui::global::leave_to_reopen(app)
}

pub(crate) fn zoom_in(app: &mut App) {
    app.head.view.zoom = (app.head.view.zoom * 1.5).min(20.0);
}

pub(crate) fn zoom_out(app: &mut App) {
    app.head.view.zoom = (app.head.view.zoom / 1.5).max(0.2);
}

pub(crate) fn zoom_reset(app: &mut App) {
    app.head.view.zoom = 1.0;
}

/// Turns the head by `yaw, pitch` degrees (pitch stops at straight up and down).
pub fn rotate(app: &mut App, yaw: i32, pitch: i32) {
    app.head.view.yaw = (app.head.view.yaw + f64::from(yaw)).rem_euclid(360.0);
    app.head.view.pitch = (app.head.view.pitch + f64::from(pitch)).clamp(-90.0, 90.0);
}

/// Back to the face, framed from the front unzoomed (on the labels made so far when there
/// are enough, else on the face found on the mesh), keeping the landmark being labelled and
/// the drawing.
pub fn reset_view(app: &mut App) {
    let (label, wireframe) = (app.head.view.label, app.head.view.wireframe);
    app.head.view = HeadView { label, wireframe, ..Default::default() };
    app.frame_head();
}

/// Moves the 2D cursor by `dx, dy` hundredths of the head's radius (finer when zoomed).
pub fn move_cursor(app: &mut App, dx: i32, dy: i32) {
    if !labelling(app) {
        return;
    }
    app.head.view.suggested = None;
    let k = 0.01 / app.head.view.zoom;
    let (x, y) = app.head.view.cursor;
    app.head.view.cursor =
        ((x + f64::from(dx) * k).clamp(-1.5, 1.5), (y + f64::from(dy) * k).clamp(-1.5, 1.5));
}

pub fn next_label(app: &mut App) {
    if labelling(app) {
        set_label_target(app, (app.head.view.label + 1) % N_LANDMARKS);
    }
}

pub fn prev_label(app: &mut App) {
    if labelling(app) {
        set_label_target(app, (app.head.view.label + N_LANDMARKS - 1) % N_LANDMARKS);
    }
}

pub fn clear_label(app: &mut App) {
    if labelling(app) {
        relabel(app, vec![(app.head.view.label, None)]);
    }
}

pub fn toggle_wireframe(app: &mut App) {
    if labelling(app) {
        app.head.view.wireframe = !app.head.view.wireframe;
    }
}

/// Asks for the session's map file; `MapLoaded` brings it.
pub fn load_map(app: &mut App) {
    app.effects.push(Effect::LoadMap);
}

/// Writes the map file, then saves: the session then records the map file it refers to.
pub fn save_map(app: &mut App) -> Option<Action> {
    app.effects.push(Effect::SaveMap);
    Some(Action::Save)
}

/// The session's map file replaces the labels, as one undoable edit.
pub fn map_loaded(app: &mut App, map: LandmarkMap, path: String) {
    let mut labels: Vec<(usize, Option<usize>)> =
        map.to_vertex.iter().map(|(&l, &v)| (l, Some(v))).collect();
    if let Some(old) = &app.map {
        labels
            .extend(old.to_vertex.keys().filter(|l| map.vertex(**l).is_none()).map(|&l| (l, None)));
    }
    let n = relabel(app, labels);
    app.status = format!("{} landmarks from {path} ({n} labels changed; u undoes)", map.len());
}

/// Makes `landmark` the one being labelled (dropping a suggestion for another).
pub fn set_label_target(app: &mut App, landmark: usize) {
    app.head.view.label = landmark;
    app.head.view.suggested = None;
}

/// Assigns the suggested vertex, or the one under the cursor, then moves to the next landmark.
pub fn confirm_label(app: &mut App) {
    if !labelling(app) {
        return;
    }
    let l = app.head.view.label;
    let picked = match app.head.view.suggested {
        Some((sl, v)) if sl == l => Some(v),
        _ => app.mesh.as_ref().and_then(|m| {
            let eligible = app.head.label_candidates.as_deref().map(Vec::as_slice);
            head::pick_vertex(m, &app.head.triangles, &app.head.framing, &app.head.view, eligible)
        }),
    };
    match picked {
        Some(v) => {
            relabel(app, vec![(l, Some(v))]);
            app.status = format!("landmark {} → vertex {v}", PointNo(l));
            set_label_target(app, (l + 1) % N_LANDMARKS);
        }
        None => app.status = "no visible vertex under the cursor".into(),
    }
}

/// Asks the suggestions' job (the use case of `lipmap map suggest`) for a vertex for the
/// landmark being labelled, from the other labels; the reply puts the cursor on it.
pub fn suggest_label(app: &mut App) {
    if !labelling(app) {
        return;
    }
    let l = app.head.view.label;
    let mut labels = app.map.clone().unwrap_or_default();
    labels.to_vertex.remove(&l);
    app.status = format!("suggesting a vertex for {}…", PointNo(l));
    app.effects.push(Effect::SuggestMap { labels, landmark: Some(l) });
}

/// Asks the suggestions' job for every unlabelled landmark; the reply labels them as one
/// undoable edit.
pub fn suggest_all_labels(app: &mut App) {
    if !labelling(app) {
        return;
    }
    let labels = app.map.clone().unwrap_or_default();
    app.status = "suggesting the unlabelled landmarks…".into();
    app.effects.push(Effect::SuggestMap { labels, landmark: None });
}

/// The suggestions' reply: for `o` the cursor on the landmark's suggested vertex (Enter
/// assigns it), for `O` every suggested landmark still unlabelled labelled as one edit; the
/// status says what they were matched to, or the one line why there are none.
pub fn map_suggested(
    app: &mut App,
    landmark: Option<usize>,
    suggested: Result<Box<crate::workflow::map::SuggestedMap>, String>,
) {
    let s = match suggested {
        Ok(s) => s,
        Err(e) => {
            app.status = format!("no suggestions: {e}");
            return;
        }
    };
    if !labelling(app) {
        return;
    }
    let from = &s.from;
    match landmark {
        Some(l) => match s.proposal.accepted.iter().find(|x| x.landmark == l) {
            Some(x) => {
                if let Some(mesh) = &app.mesh {
                    let rot = head::view_rotation(&app.head.view, &app.head.framing);
                    let pts = head::project(mesh, &rot, &app.head.framing);
                    if let Some(p) = pts.get(x.vertex) {
                        app.head.view.cursor = (p.0, -p.1);
                    }
                }
                app.head.view.label = l;
                app.head.view.suggested = Some((l, x.vertex));
                app.status = format!(
                    "suggested vertex {} for {} (confidence {:.2}, matched to {from}): Enter \
                     assigns",
                    x.vertex,
                    PointNo(l),
                    x.confidence
                );
            }
            None => {
                let why = s.proposal.left.iter().find(|(k, _)| *k == l);
                app.status = match why {
                    Some((_, why)) => format!("no suggestion for {}: {why}", PointNo(l)),
                    None => format!("no suggestion for {}", PointNo(l)),
                };
            }
        },
        None => {
            // Labels set while the job worked stay as the user set them.
            let labelled = |l: usize| app.map.as_ref().is_some_and(|m| m.vertex(l).is_some());
            let list: Vec<(usize, Option<usize>)> = s
                .proposal
                .accepted
                .iter()
                .filter(|x| !labelled(x.landmark))
                .map(|x| (x.landmark, Some(x.vertex)))
                .collect();
            relabel(app, list);
            let first_left = s
                .proposal
                .left
                .iter()
                .find(|(_, why)| !matches!(why, LeftOut::NotVisible))
                .map_or(String::new(), |(l, why)| format!("; e.g. {} {why}", PointNo(*l)));
            app.status =
                format!("{}{first_left} (matched to {from}); u undoes", s.proposal.summary());
        }
    }
}
