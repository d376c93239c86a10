//! The head view: turning and zooming the head, and labelling landmarks on its mesh (by the
//! 3D cursor, or from suggestions the current frame makes), loading and saving the map.

use crate::fit::OrthoPose;
use crate::fit::map_suggest::LeftOut;
use crate::fit::suggest::SuggestHead;
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

/// The head's vertices and the camera to see them through for suggestions: the current
/// frame's fitted shape and pose when it has a fit, else the mesh (or the model's mean)
/// with the pose left to be estimated from the labels.
type SuggestionBasis = (Vec<crate::math::Point3>, Vec<[u32; 3]>, Option<OrthoPose>);

fn suggestion_basis(app: &App) -> Option<SuggestionBasis> {
    // The head's skin, eyes and teeth hide what is behind them; helper shells do not.
    let occluders = app.head.occluders.as_deref().map(Vec::as_slice);
    let faces = |mesh: &crate::model::Mesh| -> Vec<[u32; 3]> {
        crate::fit::suggest::surface_triangles(&mesh.triangles(), occluders)
    };
    // A fit is of the model: its shape is the labelled mesh only while the model is labelled.
    let fit = app
        .fits
        .by_frame
        .get(&app.frame())
        .filter(|f| f.is_usable() && app.head.label_role == crate::session::MapRole::Model);
    if let (Some(model), Some(fit)) = (&app.model, fit) {
        let shape = crate::fit::fitted_shape(model, fit);
        let tris = match &app.mesh {
            Some(m) if model.triangles.is_empty() => faces(m),
            _ => model.triangles.clone(),
        };
        return Some((model.to_mesh(&shape).vertices, tris, Some(crate::fit::pose_of(fit))));
    }
    match (&app.mesh, &app.model) {
        (Some(mesh), _) => Some((mesh.vertices.clone(), faces(mesh), None)),
        (None, Some(model)) => Some((model.mean_mesh().vertices, model.triangles.clone(), None)),
        (None, None) => None,
    }
}

/// What a suggestion is made from: the head and camera of [`suggestion_basis`], the current
/// frame's landmarks, the labels so far and the frame's height in pixels.
struct SuggestionInputs {
    vertices: Vec<crate::math::Point3>,
    triangles: Vec<[u32; 3]>,
    pose: Option<OrthoPose>,
    frame: crate::landmarks::FrameLandmarks,
    map: LandmarkMap,
    image_height: f64,
}

/// [`SuggestionInputs`] for the current frame; None (the status saying why) while labels
/// cannot be set, or when there is no head or no frame.
fn suggestion_inputs(app: &mut App) -> Option<SuggestionInputs> {
    if !labelling(app) {
        return None;
    }
    let Some((vertices, triangles, pose)) = suggestion_basis(app) else {
        app.status = "no head to label".into();
        return None;
    };
    let frame = app.track.frames.get(app.frame_pos)?.clone();
    let map = app.map.clone().unwrap_or_default();
    let image_height = f64::from(app.frame_dims().1);
    Some(SuggestionInputs { vertices, triangles, pose, frame, map, image_height })
}

/// Puts the cursor on the vertex the current frame suggests for the landmark.
pub fn suggest_label(app: &mut App) {
    let Some(s) = suggestion_inputs(app) else { return };
    let l = app.head.view.label;
    let how = if s.pose.is_some() { "fitted pose" } else { "pose from the labels" };
    // A vertex another landmark holds is not offered again: one vertex per landmark.
    let mut eligible = match app.head.label_candidates.as_deref() {
        Some(e) => e.clone(),
        None => vec![true; s.vertices.len()],
    };
    for (_, v) in s.map.pairs().filter(|(other, _)| *other != l) {
        if let Some(e) = eligible.get_mut(v) {
            *e = false;
        }
    }
    let head =
        SuggestHead { vertices: &s.vertices, triangles: &s.triangles, eligible: Some(&eligible) };
    match crate::fit::suggest::suggest_label(&head, &s.map, &s.frame, s.image_height, s.pose, l) {
        Ok(s) => {
            if let Some(mesh) = &app.mesh {
                let rot = head::view_rotation(&app.head.view, &app.head.framing);
                let pts = head::project(mesh, &rot, &app.head.framing);
                if let Some(p) = pts.get(s.vertex) {
                    app.head.view.cursor = (p.0, -p.1);
                }
            }
            app.head.view.suggested = Some((l, s.vertex));
            app.status = format!(
                "suggested vertex {} for {} ({:.1} px off the tracked point, {how}): \
                 Enter assigns",
                s.vertex,
                PointNo(l),
                s.distance_px
            );
        }
        Err(e) => app.status = format!("no suggestion: {e}"),
    }
}

/// Labels every unmapped landmark with its suggested vertex, as one undoable edit.
pub fn suggest_all_labels(app: &mut App) {
    let Some(s) = suggestion_inputs(app) else { return };
    let head = SuggestHead {
        vertices: &s.vertices,
        triangles: &s.triangles,
        eligible: app.head.label_candidates.as_deref().map(Vec::as_slice),
    };
    match crate::fit::map_suggest::suggest_map(&head, &s.map, &s.frame, s.image_height, s.pose) {
        Ok(proposal) => {
            let list: Vec<(usize, Option<usize>)> =
                proposal.accepted.iter().map(|s| (s.landmark, Some(s.vertex))).collect();
            relabel(app, list);
            let first_left = proposal
                .left
                .iter()
                .find(|(_, why)| !matches!(why, LeftOut::NotVisible))
                .map_or(String::new(), |(l, why)| format!("; e.g. {} {why}", PointNo(*l)));
            app.status = format!("{}{first_left}; u undoes", proposal.summary());
        }
        Err(e) => app.status = format!("no suggestions: {e}"),
    }
}
