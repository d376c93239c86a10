//! `update` driven by action sequences, no terminal: edits, undo/redo, interpolation,
//! propagation, mouse drags, navigation, fits, labelling, quitting with unsaved edits.

use lipmap::landmarks::PointSource;
use lipmap::tui::app::{App, Effect};
use lipmap::tui::fixtures::{GLITCH_FRAME, synthetic_app};
use lipmap::tui::key_to_action;
use lipmap::tui::overlays::Overlay;
use lipmap::tui::screens::View;
use lipmap::tui::screens::frames::Scope;
use lipmap::tui::screens::image_mapping;
use lipmap::tui::{Action, Keymap, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

fn app() -> App {
    let mut a = synthetic_app(20, 160, 120, false);
    a.term_size = (80, 24);
    a
}

fn run(app: &mut App, actions: impl IntoIterator<Item = Action>) {
    for a in actions {
        let mut next = Some(a);
        while let Some(a) = next {
            next = update(app, a);
        }
    }
}

fn point(app: &App, frame: usize, i: usize) -> lipmap::landmarks::LandmarkPoint {
    app.track.get(frame).unwrap().points[i]
}

#[test]
fn nudge_undo_redo() {
    let mut a = app();
    let before = point(&a, 0, 62);
    let step = image_mapping(&a, a.term_size).unwrap().nudge_px();
    run(&mut a, [Action::Nudge { dx: 1, dy: 0 }, Action::Nudge { dx: 0, dy: 10 }]);
    let p = point(&a, 0, 62);
    assert!((p.x - before.x - step).abs() < 1e-9);
    assert!((p.y - before.y - 10.0 * step).abs() < 1e-9);
    assert_eq!(p.source, PointSource::Corrected);
    assert_eq!(a.tracked.get(0).unwrap().points[62], before, "tracker's value kept");
    assert_eq!(a.save.unsaved(), 2);
    run(&mut a, [Action::Undo, Action::Undo]);
    assert_eq!(point(&a, 0, 62), before);
    run(&mut a, [Action::Undo]);
    assert_eq!(a.status, "nothing to undo");
    run(&mut a, [Action::Redo]);
    assert!((point(&a, 0, 62).x - before.x - step).abs() < 1e-9);
    // A new edit clears the redo stack.
    run(&mut a, [Action::NextPoint, Action::Nudge { dx: -1, dy: 0 }, Action::Redo]);
    assert_eq!(a.status, "nothing to redo");
}

#[test]
fn zoom_makes_steps_sub_pixel_and_is_kept_across_frames() {
    let mut a = app();
    let coarse = image_mapping(&a, a.term_size).unwrap().step_px();
    run(&mut a, [Action::ZoomIn, Action::ZoomIn, Action::ZoomIn, Action::ZoomIn]);
    let fine = image_mapping(&a, a.term_size).unwrap().step_px();
    assert!((coarse / fine - 16.0).abs() < 1e-9);
    assert!(fine < 1.0, "sub-pixel step when zoomed: {fine}");
    run(&mut a, [Action::NextFrame, Action::NextFrame]);
    assert_eq!(a.frames.image_view.zoom, 16.0);
    run(&mut a, [Action::ZoomReset]);
    assert_eq!(a.frames.image_view.zoom, 1.0);
}

#[test]
fn a_step_is_an_image_pixel_at_any_terminal_size_and_finer_zoomed_in() {
    // A 720×480 frame on 80×24 has a display pixel of over 10 image pixels: `L` still moves
    // the point by the 10 image pixels the help says.
    for size in [(80, 24), (160, 45)] {
        let mut a = synthetic_app(3, 720, 480, false);
        a.term_size = size;
        assert!(image_mapping(&a, size).unwrap().step_px() > 1.0, "{size:?}");
        let before = point(&a, 0, 62);
        run(&mut a, [Action::Nudge { dx: 10, dy: 0 }, Action::Nudge { dx: 0, dy: -1 }]);
        let p = point(&a, 0, 62);
        assert_eq!((p.x - before.x, p.y - before.y), (10.0, -1.0), "{size:?}");
        run(&mut a, [Action::ZoomIn, Action::ZoomIn, Action::ZoomIn, Action::ZoomIn]);
        let fine = image_mapping(&a, size).unwrap().nudge_px();
        assert!(fine < 1.0, "{size:?}: {fine}");
        run(&mut a, [Action::Nudge { dx: 10, dy: 0 }]);
        assert!((point(&a, 0, 62).x - p.x - 10.0 * fine).abs() < 1e-9);
    }
    let help = Action::Nudge { dx: 10, dy: 0 }.describe();
    assert!(help.starts_with("move point 10 image pixels"), "{help}");
}

#[test]
fn group_scope_moves_the_mouth_together() {
    let mut a = app();
    run(&mut a, [Action::CycleScope, Action::CycleScope]);
    assert_eq!(a.frames.scope, Scope::Mouth);
    let before: Vec<f64> = (0..68).map(|i| point(&a, 0, i).y).collect();
    run(&mut a, [Action::Nudge { dx: 0, dy: 1 }]);
    for (i, &y0) in before.iter().enumerate() {
        let moved = point(&a, 0, i).y != y0;
        assert_eq!(moved, (48..68).contains(&i), "point {i}");
    }
    run(&mut a, [Action::Undo]);
    assert!((0..68).all(|i| point(&a, 0, i).y == before[i]));
}

#[test]
fn interpolate_between_corrected_keyframes() {
    let mut a = app();
    run(&mut a, [Action::NextFrame, Action::Nudge { dx: 10, dy: 0 }]);
    for _ in 0..4 {
        run(&mut a, [Action::NextFrame]);
    }
    run(&mut a, [Action::Nudge { dx: -10, dy: 0 }, Action::InterpolateSelected]);
    assert_eq!(a.status, "interpolated over 3 frames");
    let (p1, p5) = (point(&a, 1, 62), point(&a, 5, 62));
    for f in 2..5 {
        let p = point(&a, f, 62);
        let t = (f - 1) as f64 / 4.0;
        assert!((p.x - (p1.x + t * (p5.x - p1.x))).abs() < 1e-9);
        assert_eq!(p.source, PointSource::Interpolated);
    }
    assert_eq!(point(&a, 6, 62).source, PointSource::Tracked);
    run(&mut a, [Action::Undo]);
    assert!((2..5).all(|f| point(&a, f, 62).source == PointSource::Tracked));
}

#[test]
fn propagate_through_the_prompt() {
    let mut a = app();
    let km = Keymap::default();
    run(&mut a, [Action::Nudge { dx: 0, dy: -10 }]);
    let off = point(&a, 0, 62).y - a.tracked.get(0).unwrap().points[62].y;
    // t, 3, Enter — through the keymap, as a user would type it.
    for code in [KeyCode::Char('t'), KeyCode::Char('3'), KeyCode::Enter] {
        let act = key_to_action(&a, &km, &KeyEvent::new(code, KeyModifiers::NONE)).unwrap();
        run(&mut a, [act]);
    }
    assert!(a.overlays.is_empty());
    for f in 1..=3 {
        let d = point(&a, f, 62).y - a.tracked.get(f).unwrap().points[62].y;
        assert!((d - off).abs() < 1e-9, "frame {f}");
    }
    assert_eq!(point(&a, 4, 62), a.tracked.get(4).unwrap().points[62]);
    run(&mut a, [Action::Undo]);
    assert!((1..=3).all(|f| point(&a, f, 62) == a.tracked.get(f).unwrap().points[62]));
}

/// Types `text` into a freshly opened prompt of `open` and submits it.
fn answer(app: &mut App, open: Action, text: &str) {
    run(app, [open]);
    run(app, text.chars().map(Action::PromptChar));
    run(app, [Action::PromptSubmit]);
}

#[test]
fn prompt_goto_point_and_bad_input() {
    let mut a = app();
    // People number points 1–68: 49 is the right mouth corner, index 48.
    answer(&mut a, Action::GotoPointPrompt, "49");
    assert_eq!(a.frames.selected, 48);
    answer(&mut a, Action::GotoPointPrompt, "68");
    assert_eq!(a.frames.selected, 67);
    for bad in ["69", "0", "99"] {
        answer(&mut a, Action::GotoPointPrompt, bad);
        assert_eq!(a.frames.selected, 67, "{bad}");
        assert_eq!(a.status, format!("`{bad}` is not a point number (1–68)"));
    }
    run(&mut a, [Action::GotoPointPrompt, Action::Cancel]);
    assert!(a.overlays.is_empty());
}

#[test]
fn copy_toggle_revert_and_review() {
    let mut a = app();
    run(&mut a, [Action::NextFrame, Action::CopyPointFromPrev]);
    assert_eq!(point(&a, 1, 62).y, point(&a, 0, 62).y);
    run(&mut a, [Action::ToggleVisible]);
    assert!(!point(&a, 1, 62).visible);
    run(&mut a, [Action::RevertPoint]);
    assert_eq!(point(&a, 1, 62), a.tracked.get(1).unwrap().points[62]);
    run(&mut a, [Action::CopyFrameFromPrev]);
    assert!((0..68).all(|i| point(&a, 1, i).x == point(&a, 0, i).x));
    run(&mut a, [Action::ToggleReviewed]);
    assert!(a.reviewed.contains(&1));
    run(&mut a, [Action::Undo]);
    assert!(!a.reviewed.contains(&1));
    run(&mut a, [Action::Redo, Action::FirstFrame, Action::NextUnreviewed]);
    assert_eq!(a.frame(), 2, "frame 1 is reviewed, so 2 is next");
}

#[test]
fn flagged_frame_navigation_finds_the_glitch() {
    let mut a = app();
    assert!(a.flags.iter().any(|f| f.frame == GLITCH_FRAME));
    run(&mut a, [Action::NextFlagged]);
    assert_eq!(a.frame(), GLITCH_FRAME);
    // Fixing the glitch clears its flag.
    answer(&mut a, Action::GotoPointPrompt, "49");
    let fixed = lipmap::tui::fixtures::face_points(GLITCH_FRAME, 160, 120)[48];
    let cur = point(&a, GLITCH_FRAME, 48);
    let edit =
        lipmap::landmarks::edit::place_point(&mut a.track, GLITCH_FRAME, 48, fixed.x, fixed.y);
    assert!(edit.is_ok() && cur.x != fixed.x);
    a.recompute_flags();
    assert!(a.flags_of(GLITCH_FRAME).is_none());
    run(&mut a, [Action::LastFrame, Action::NextFlagged]);
    assert!(a.status.contains("no flagged frame after"));
}

#[test]
fn mouse_click_selects_nearest_and_drag_is_one_undo_step() {
    let mut a = app();
    let m = image_mapping(&a, a.term_size).unwrap();
    let p48 = point(&a, 0, 48);
    let (col, row, _) = m.image_to_cell(p48.x, p48.y).unwrap();
    run(&mut a, [Action::MouseDown { col, row }]);
    assert_eq!(a.frames.selected, 48);
    run(
        &mut a,
        [
            Action::MouseDrag { col: col + 1, row },
            Action::MouseDrag { col: col + 2, row: row + 1 },
            Action::MouseDrag { col: col + 3, row: row + 1 },
            Action::MouseUp,
        ],
    );
    let moved = point(&a, 0, 48);
    let (tx, ty) = m.cell_to_image(col + 3, row + 1).unwrap();
    assert!((moved.x - tx).abs() < 1e-9 && (moved.y - ty).abs() < 1e-9);
    assert_eq!(a.undo.len(), 1);
    run(&mut a, [Action::Undo]);
    assert_eq!(point(&a, 0, 48), p48);
}

#[test]
fn frame_changes_request_uncached_images_only() {
    let mut a = synthetic_app(10, 32, 24, false);
    a.frames.cache.images.clear();
    a.frames.cache.order.clear();
    run(&mut a, [Action::NextFrame]);
    assert_eq!(a.effects, vec![Effect::LoadFrames(vec![1, 2, 3, 0])]);
    a.effects.clear();
    let img = std::sync::Arc::new(lipmap::tui::fixtures::face_image(1, 32, 24));
    run(&mut a, [Action::FrameLoaded { frame: 1, image: img }]);
    assert!(a.current_image().is_some());
    run(&mut a, [Action::FrameFailed { frame: 2, error: "broken".into() }, Action::NextFrame]);
    assert_eq!(a.effects, vec![Effect::LoadFrames(vec![3, 4])], "2 failed, 1 cached");
}

#[test]
fn fit_refits_only_edited_frames_and_drops_stale_replies() {
    let mut a = synthetic_app(10, 64, 48, true);
    run(&mut a, [Action::RunFit]);
    assert!(a.status.contains("no model"), "{}", a.status);
    let model = |n: usize| {
        Some(std::sync::Arc::new(lipmap::model::MorphableModel {
            shape: lipmap::model::PcaModel {
                mean: lipmap::math::DVector::zeros(3 * n),
                basis: lipmap::math::DMatrix::zeros(3 * n, 0),
                eigenvalues: lipmap::math::DVector::zeros(0),
            },
            expressions: None,
            triangles: vec![],
        }))
    };
    // A model too small for the map's vertices: refused once, before any frame is fitted.
    a.model = model(1);
    run(&mut a, [Action::RunFit]);
    assert!(a.status.contains("cannot fit") && a.effects.is_empty(), "{}", a.status);
    a.model = model(200);
    run(&mut a, [Action::NextFrame, Action::Nudge { dx: 1, dy: 0 }, Action::RunFit]);
    assert_eq!(a.effects.last(), Some(&Effect::Fit { generation: 1, frames: Some(vec![1]) }));
    run(&mut a, [Action::Nudge { dx: 1, dy: 0 }, Action::RunFit]);
    let mut fits = lipmap::tui::fixtures::synthetic_fits(&a.track);
    fits[1].reproj_rms_px = 42.0;
    run(&mut a, [Action::FitDone { generation: 1, fits: fits.clone() }]);
    assert_ne!(a.fits.by_frame[&1].reproj_rms_px, 42.0, "stale generation dropped");
    a.effects.clear();
    run(&mut a, [Action::FitDone { generation: 2, fits: fits.clone() }]);
    assert_eq!(a.fits.by_frame[&1].reproj_rms_px, 42.0);
    assert!(!a.fit.running);
    // Nothing edited since the request: the fits go to the session's cache, which is then
    // a change to save.
    assert_eq!(a.effects.first(), Some(&Effect::StoreFits { fits: fits.clone() }));
    let unsaved = a.save.unsaved();
    run(&mut a, [Action::FitsStored]);
    assert_eq!(a.save.unsaved(), unsaved + 1);
    run(&mut a, [Action::FitsNotStored { error: "read-only".into() }]);
    assert!(a.status.contains("fit cache not updated: read-only"), "{}", a.status);
    // Nothing edited since: no refit. A new label changes the map: every frame again.
    run(&mut a, [Action::RunFit]);
    assert!(a.status.contains("nothing changed"), "{}", a.status);
    assert_eq!(a.fit.generation, 2);
    a.head.view.label = 33;
    run(&mut a, [Action::ShowHead, Action::ConfirmLabel, Action::RunFit]);
    assert_eq!(
        a.effects.last(),
        Some(&Effect::Fit { generation: 3, frames: Some((0..10).collect()) })
    );
    // An edit while the fit runs: its fits are shown but not cached (they no longer match
    // the session's landmarks).
    a.effects.clear();
    run(&mut a, [Action::ShowFrames, Action::Nudge { dx: 1, dy: 0 }]);
    let fits = lipmap::tui::fixtures::synthetic_fits(&a.track);
    run(&mut a, [Action::FitDone { generation: 3, fits }]);
    assert!(!a.fit.running);
    assert!(!a.effects.iter().any(|e| matches!(e, Effect::StoreFits { .. })), "{:?}", a.effects);
}

/// A session whose head is another mesh than the model, with no model map: `f` says the model
/// map is what is missing and how to label it here, whichever map the head view labels.
#[test]
fn fit_without_a_model_map_names_the_model_map_and_how_to_label_it() {
    use lipmap::session::MapRole;
    let mut a = synthetic_app(4, 64, 48, false);
    a.model = Some(std::sync::Arc::new(lipmap::model::MorphableModel {
        shape: lipmap::model::PcaModel {
            mean: lipmap::math::DVector::zeros(3 * 200),
            basis: lipmap::math::DMatrix::zeros(3 * 200, 0),
            eigenvalues: lipmap::math::DVector::zeros(0),
        },
        expressions: None,
        triangles: vec![],
    }));
    a.head.head_has_own_map = true;
    // Labelling the head's own map (68 labels there), the model's empty.
    a.head.label_role = MapRole::Head;
    a.model_map = None;
    run(&mut a, [Action::RunFit]);
    assert!(a.effects.is_empty());
    assert!(a.status.starts_with("cannot fit: the session has no model map"), "{}", a.status);
    assert!(a.status.contains("press m in the head view (2)"), "{}", a.status);
    assert!(!a.status.contains("label the head"), "{}", a.status);
    // Labelling the model map itself.
    a.head.label_role = MapRole::Model;
    a.map = Some(lipmap::model::LandmarkMap::default());
    run(&mut a, [Action::RunFit]);
    assert!(a.status.contains("no model map") && a.status.contains("label it in the head view"));
    assert!(a.effects.is_empty());
}

#[test]
fn idle_autosaves_unless_dragging_saving_or_failed() {
    let mut a = app();
    run(&mut a, [Action::Idle]);
    assert!(a.effects.is_empty(), "nothing to save");
    run(&mut a, [Action::Nudge { dx: 1, dy: 0 }]);
    a.frames.dragging = true;
    run(&mut a, [Action::Idle]);
    assert!(a.effects.is_empty(), "never mid-drag");
    a.frames.dragging = false;
    run(&mut a, [Action::Idle]);
    assert_eq!(a.effects, vec![Effect::Save { generation: 1 }]);
    run(&mut a, [Action::Idle]);
    assert_eq!(a.effects.len(), 1, "one save in flight at a time");
    run(&mut a, [Action::SaveFailed { error: "disk full".into() }, Action::Idle]);
    assert_eq!(a.effects.len(), 1, "a failed save waits for the next edit");
    run(&mut a, [Action::Nudge { dx: 1, dy: 0 }, Action::Idle]);
    assert_eq!(a.effects.last(), Some(&Effect::Save { generation: 2 }));
}

#[test]
fn head_labelling_assigns_and_undoes() {
    let mut a = app();
    run(
        &mut a,
        [
            Action::ShowHead,
            Action::GotoLabelPrompt,
            Action::PromptChar('3'),
            Action::PromptChar('4'),
            Action::PromptSubmit,
        ],
    );
    assert_eq!(a.head.view.label, 33, "landmark 34 as people number it");
    run(&mut a, [Action::ConfirmLabel]);
    let v = a.map.as_ref().unwrap().vertex(33).expect("the cursor at the centre picks a vertex");
    // Facing the viewer, the picked vertex is on the front (+z) side of the head.
    assert!(a.mesh.as_ref().unwrap().vertices[v].z > 0.0);
    assert_eq!(a.head.view.label, 34);
    run(&mut a, [Action::Undo]);
    assert_eq!(a.map.as_ref().unwrap().vertex(33), None);
    run(&mut a, [Action::Rotate { yaw: 180, pitch: 0 }, Action::PrevLabel, Action::ConfirmLabel]);
    let back = a.map.as_ref().unwrap().vertex(33).unwrap();
    assert!(a.mesh.as_ref().unwrap().vertices[back].z < 0.0, "turned around, the back is in front");
}

/// The suggestions' reply as the job sends it: `accepted` suggested, `left` left out.
fn suggested(
    labels: &lipmap::model::LandmarkMap,
    accepted: &[(usize, usize)],
    left: &[usize],
) -> Result<Box<lipmap::workflow::map::SuggestedMap>, String> {
    use lipmap::fit::map_suggest::{LeftOut, MapProposal, MapSuggestion};
    let proposal = MapProposal {
        accepted: accepted
            .iter()
            .map(|&(landmark, vertex)| MapSuggestion {
                landmark,
                vertex,
                distance_px: 1.0,
                confidence: 0.9,
            })
            .collect(),
        left: left.iter().map(|&l| (l, LeftOut::NoVertex)).collect(),
    };
    let map = proposal.applied_to(labels);
    Ok(Box::new(lipmap::workflow::map::SuggestedMap {
        from: lipmap::workflow::map::SuggestedFrom::OwnFace,
        labels: labels.clone(),
        check: lipmap::model::check_map(&map, &[]),
        proposal,
        map,
    }))
}

#[test]
fn suggestions_are_asked_of_the_job_and_label_the_head_as_one_undo_step() {
    let mut a = app();
    a.map = None;
    let truth: Vec<(usize, usize)> = (0..12).map(|k| (30 + k, 100 + 7 * k)).collect();
    // `O` asks the job (the use case of `lipmap map suggest`) with the labels held.
    for &(l, v) in &truth[..4] {
        a.map.get_or_insert_with(Default::default).to_vertex.insert(l, v);
    }
    let held = a.map.clone().unwrap();
    run(&mut a, [Action::ShowHead]);
    a.take_effects();
    run(&mut a, [Action::SuggestAllLabels]);
    assert_eq!(a.take_effects(), vec![Effect::SuggestMap { labels: held.clone(), landmark: None }]);
    // A label set while the job worked stays as the user set it.
    a.map.as_mut().unwrap().to_vertex.insert(truth[6].0, 9999);
    let reply = suggested(&held, &truth[4..], &[60]);
    run(&mut a, [Action::MapSuggested { landmark: None, suggested: reply }]);
    let map = a.map.clone().unwrap();
    assert_eq!(map.len(), 12, "{}", a.status);
    assert_eq!(map.vertex(truth[6].0), Some(9999));
    assert!(a.status.contains("matched to the head's own face"), "{}", a.status);
    assert!(a.status.contains("e.g. 61"), "{}", a.status);
    run(&mut a, [Action::Undo]);
    assert_eq!(a.map.as_ref().unwrap().len(), 5, "one undo removes every suggestion");

    // `o` asks for the landmark being labelled without its own label; the reply puts the
    // cursor on it and Enter assigns it.
    a.head.view.label = truth[0].0;
    run(&mut a, [Action::SuggestLabel]);
    let mut without = a.map.clone().unwrap();
    without.to_vertex.remove(&truth[0].0);
    assert_eq!(
        a.take_effects(),
        vec![Effect::SuggestMap { labels: without.clone(), landmark: Some(truth[0].0) }]
    );
    let reply = suggested(&without, &[(truth[0].0, 4242)], &[]);
    run(&mut a, [Action::MapSuggested { landmark: Some(truth[0].0), suggested: reply }]);
    assert_eq!(a.head.view.suggested, Some((truth[0].0, 4242)), "{}", a.status);
    run(&mut a, [Action::ConfirmLabel]);
    assert_eq!(a.map.as_ref().unwrap().vertex(truth[0].0), Some(4242));
    // Why there is none, in the job's one line.
    run(
        &mut a,
        [Action::MapSuggested { landmark: None, suggested: Err("frame 0: too few".into()) }],
    );
    assert_eq!(a.status, "no suggestions: frame 0: too few");
}

#[test]
fn analysis_enter_opens_the_row_frame_in_sorted_order() {
    let mut a = synthetic_app(20, 64, 48, true);
    run(
        &mut a,
        [Action::ShowAnalysis, Action::SortNextColumn, Action::SortReverse, Action::OpenRow],
    );
    // Sorted by W descending: the last phoneme has the largest W.
    let last = a.analysis.data.tables[0].rows.last().unwrap().frame.unwrap();
    assert_eq!(a.view, View::Frames);
    assert_eq!(a.frame(), last);
}

#[test]
fn quit_saves_first_and_help_toggles() {
    let mut a = app();
    run(&mut a, [Action::ToggleHelp]);
    assert!(matches!(a.overlays.last(), Some(Overlay::Help { .. })));
    run(&mut a, [Action::ToggleHelp]);
    assert!(a.overlays.is_empty());
    run(&mut a, [Action::Quit]);
    assert!(a.save.should_quit(), "nothing unsaved: quit at once");
    let mut a = app();
    run(&mut a, [Action::Nudge { dx: 1, dy: 1 }, Action::Quit]);
    assert!(!a.save.should_quit());
    assert_eq!(a.effects.last(), Some(&Effect::Save { generation: 1 }));
    run(&mut a, [Action::Saved { generation: 1 }]);
    assert!(a.save.should_quit());
    // A failing save does not trap the user.
    let mut a = app();
    run(
        &mut a,
        [
            Action::Nudge { dx: 1, dy: 1 },
            Action::Quit,
            Action::SaveFailed { error: "disk full".into() },
        ],
    );
    assert!(!a.save.should_quit() && a.status.contains("disk full"));
    run(&mut a, [Action::Quit]);
    assert!(a.save.should_quit());
}

#[test]
fn switching_clips_saves_first_and_names_the_clip() {
    let mut a = app();
    run(&mut a, [Action::NextClip]);
    assert_eq!(a.status, "the session has one clip");
    assert!(!a.save.should_quit());
    a.clip_names = vec!["s1".into(), "s2".into(), "s3".into()];
    run(&mut a, [Action::PrevClip]);
    assert_eq!((a.switch_clip, a.save.should_quit()), (Some(2), true), "nothing unsaved: at once");
    let mut a = app();
    a.clip_names = vec!["s1".into(), "s2".into()];
    run(&mut a, [Action::Nudge { dx: 1, dy: 0 }, Action::NextClip]);
    assert_eq!(a.switch_clip, Some(1));
    assert!(!a.save.should_quit(), "waits for the save");
    let generation = a.save.generation();
    run(&mut a, [Action::Saved { generation }]);
    assert!(a.save.should_quit());
    // A failed save keeps the user on this clip; q then quits rather than switching.
    let mut a = app();
    a.clip_names = vec!["s1".into(), "s2".into()];
    run(
        &mut a,
        [
            Action::Nudge { dx: 1, dy: 0 },
            Action::NextClip,
            Action::SaveFailed { error: "x".into() },
        ],
    );
    assert_eq!(a.switch_clip, None);
}

#[test]
fn loading_the_map_file_replaces_the_labels_as_one_undo_step() {
    let mut a = app();
    let before = a.map.clone().unwrap();
    run(&mut a, [Action::ShowHead, Action::LoadMap]);
    assert_eq!(a.effects.last(), Some(&Effect::LoadMap));
    let mut file = lipmap::model::LandmarkMap::default();
    file.to_vertex.insert(30, 7);
    file.to_vertex.insert(62, 9);
    run(&mut a, [Action::MapLoaded { map: file.clone(), path: "m.txt".into() }]);
    assert_eq!(a.map.as_ref(), Some(&file), "labels not in the file are dropped");
    assert!(a.status.starts_with("2 landmarks from m.txt"), "{}", a.status);
    run(&mut a, [Action::Undo]);
    assert_eq!(a.map.as_ref(), Some(&before));
}

#[test]
fn the_mean_row_stays_last_in_either_order() {
    use lipmap::tui::screens::analysis::view::sorted_rows;
    use lipmap::tui::screens::analysis::{AnalysisRow, AnalysisTable, AnalysisView};
    let table = AnalysisTable {
        title: "t".into(),
        columns: vec!["sentence".into(), "W".into()],
        rows: vec![
            AnalysisRow::numbers("a", &[2.0], None),
            AnalysisRow::numbers("mean", &[1.0], None),
            AnalysisRow::numbers("b", &[0.5], None),
        ],
    };
    let up = AnalysisView { sort_column: 1, ..Default::default() };
    assert_eq!(sorted_rows(&table, &up), vec![2, 0, 1]);
    let down = AnalysisView { descending: true, ..up };
    assert_eq!(sorted_rows(&table, &down), vec![0, 2, 1]);
}
