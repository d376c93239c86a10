//! The head view: turning and zooming the head, and labelling landmarks on its mesh (by the
//! 3D cursor, or from suggestions the current frame makes), loading and saving the map.

use super::edits::relabel;
use super::global::request_save;
use crate::fit::OrthoPose;
use crate::fit::map_suggest::LeftOut;
use crate::fit::suggest::SuggestHead;
use crate::landmarks::N_LANDMARKS;
use crate::tui::action::Action;
use crate::tui::app::{App, Effect, HeadView};
use crate::tui::views::head;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    use Action as A;
    // A transferred head is looked at, turned and zoomed; labels go on the model.
    let looking = matches!(
        action,
        A::ZoomIn
            | A::ZoomOut
            | A::ZoomReset
            | A::Rotate { .. }
            | A::ResetView
            | A::LoadMap
            | A::SaveMap
    );
    if app.heads.shown.is_some() && !looking {
        app.status = "labels are set on the model: t until the model is shown".into();
        return;
    }
    match action {
        A::ZoomIn | A::ZoomOut | A::ZoomReset => {
            app.head.zoom = match action {
                A::ZoomIn => (app.head.zoom * 1.5).min(20.0),
                A::ZoomOut => (app.head.zoom / 1.5).max(0.2),
                _ => 1.0,
            };
        }
        A::Rotate { yaw, pitch } => {
            app.head.yaw = (app.head.yaw + f64::from(yaw)).rem_euclid(360.0);
            app.head.pitch = (app.head.pitch + f64::from(pitch)).clamp(-90.0, 90.0);
        }
        A::ResetView => {
            let (label, wireframe) = (app.head.label, app.head.wireframe);
            app.head = HeadView { label, wireframe, ..Default::default() };
        }
        A::MoveCursor { dx, dy } => {
            app.head.suggested = None;
            let k = 0.01 / app.head.zoom;
            let (x, y) = app.head.cursor;
            app.head.cursor = (
                (x + f64::from(dx) * k).clamp(-1.5, 1.5),
                (y + f64::from(dy) * k).clamp(-1.5, 1.5),
            );
        }
        A::NextLabel => set_label_target(app, (app.head.label + 1) % N_LANDMARKS),
        A::PrevLabel => set_label_target(app, (app.head.label + N_LANDMARKS - 1) % N_LANDMARKS),
        A::ConfirmLabel => confirm_label(app),
        A::ClearLabel => {
            relabel(app, vec![(app.head.label, None)]);
        }
        A::SuggestLabel => suggest_label(app),
        A::SuggestAllLabels => suggest_all_labels(app),
        A::ToggleWireframe => app.head.wireframe = !app.head.wireframe,
        // The session then records the map file it now refers to.
        A::LoadMap => app.effects.push(Effect::LoadMap),
        A::SaveMap => {
            app.effects.push(Effect::SaveMap);
            request_save(app);
        }
        _ => {}
    }
}

/// Makes `landmark` the one being labelled (dropping a suggestion for another).
pub(super) fn set_label_target(app: &mut App, landmark: usize) {
    app.head.label = landmark;
    app.head.suggested = None;
}

/// Assigns the suggested vertex, or the one under the cursor, then moves to the next landmark.
fn confirm_label(app: &mut App) {
    let l = app.head.label;
    let picked = match app.head.suggested {
        Some((sl, v)) if sl == l => Some(v),
        _ => app.mesh.as_ref().and_then(|m| {
            let eligible = app.label_candidates.as_deref().map(Vec::as_slice);
            head::pick_vertex(m, &app.head_framing, &app.head, eligible)
        }),
    };
    match picked {
        Some(v) => {
            relabel(app, vec![(l, Some(v))]);
            app.status = format!("landmark {l} → vertex {v}");
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
    let occluders = app.occluders.as_deref().map(Vec::as_slice);
    let faces = |mesh: &crate::model::Mesh| -> Vec<[u32; 3]> {
        crate::fit::suggest::surface_triangles(&mesh.triangles(), occluders)
    };
    let fit = app.fit.fits.get(&app.frame()).filter(|f| f.is_usable());
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

fn suggest_label(app: &mut App) {
    let Some((vertices, tris, pose)) = suggestion_basis(app) else {
        app.status = "no head to label".into();
        return;
    };
    let Some(frame) = app.track.frames.get(app.frame_pos) else { return };
    let map = app.map.clone().unwrap_or_default();
    let l = app.head.label;
    let how = if pose.is_some() { "fitted pose" } else { "pose from the labels" };
    let h = f64::from(app.frame_dims().1);
    // A vertex another landmark holds is not offered again: one vertex per landmark.
    let mut eligible = match app.label_candidates.as_deref() {
        Some(e) => e.clone(),
        None => vec![true; vertices.len()],
    };
    for (_, v) in map.pairs().filter(|(other, _)| *other != l) {
        if let Some(e) = eligible.get_mut(v) {
            *e = false;
        }
    }
    let head = SuggestHead { vertices: &vertices, triangles: &tris, eligible: Some(&eligible) };
    match crate::fit::suggest::suggest_label(&head, &map, frame, h, pose, l) {
        Ok(s) => {
            if let Some(mesh) = &app.mesh {
                let rot = head::rotation(app.head.yaw, app.head.pitch);
                let pts = head::project(mesh, &rot, &app.head_framing);
                if let Some(p) = pts.get(s.vertex) {
                    app.head.cursor = (p.0, -p.1);
                }
            }
            app.head.suggested = Some((l, s.vertex));
            app.status = format!(
                "suggested vertex {} for {l} ({:.1} px off the tracked point, {how}): \
                 Enter assigns",
                s.vertex, s.distance_px
            );
        }
        Err(e) => app.status = format!("no suggestion: {e}"),
    }
}

fn suggest_all_labels(app: &mut App) {
    let Some((vertices, tris, pose)) = suggestion_basis(app) else {
        app.status = "no head to label".into();
        return;
    };
    let Some(frame) = app.track.frames.get(app.frame_pos) else { return };
    let map = app.map.clone().unwrap_or_default();
    let h = f64::from(app.frame_dims().1);
    let head = SuggestHead {
        vertices: &vertices,
        triangles: &tris,
        eligible: app.label_candidates.as_deref().map(Vec::as_slice),
    };
    match crate::fit::map_suggest::suggest_map(&head, &map, frame, h, pose) {
        Ok(proposal) => {
            let list: Vec<(usize, Option<usize>)> =
                proposal.accepted.iter().map(|s| (s.landmark, Some(s.vertex))).collect();
            relabel(app, list);
            let first_left = proposal
                .left
                .iter()
                .find(|(_, why)| !matches!(why, LeftOut::NotVisible))
                .map_or(String::new(), |(l, why)| format!("; e.g. {} {why}", l + 1));
            app.status = format!("{}{first_left}; u undoes", proposal.summary());
        }
        Err(e) => app.status = format!("no suggestions: {e}"),
    }
}
