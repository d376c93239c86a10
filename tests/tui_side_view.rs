//! The TUI's side view on a small demo session: the profile is measured on a worker's job,
//! the side frame of each front frame decodes, moving the lip point stores a side-view
//! correction in the session (undoable), P in the analysis follows it, and the view draws.

use lipmap::demo::{DemoOptions, generate};
use lipmap::session::{Clip, FramesRef, Session, View as SessionView};
use lipmap::tui::screens::View;
use lipmap::tui::screens::side::SideState;
use lipmap::tui::session_bridge::SessionBridge;
use lipmap::tui::{Action, App, update};
use ratatui::Terminal;
use ratatui::backend::TestBackend;

fn apply(app: &mut App, actions: &[Action]) {
    for a in actions {
        let mut next = Some(a.clone());
        while let Some(a) = next {
            next = update(app, a);
        }
    }
}

#[test]
fn side_view_corrections_reach_the_session_and_p() {
    let dir = tempfile::tempdir().unwrap();
    let opts = DemoOptions {
        out_dir: dir.path().to_path_buf(),
        sentences: 1,
        width: 360,
        height: 240,
        write_model: false,
        max_frames: Some(12),
        ..DemoOptions::default()
    };
    let out = generate(&opts).unwrap();
    let c = &out.speakers[0].clips[0];
    let path = dir.path().join("side.lipmap.json");
    let mut session = Session::new(&path);
    let front = SessionView::new(FramesRef::Images { dir: c.front_dir.clone().unwrap() }, c.fps);
    let mut clip = Clip::new(c.name.clone(), front);
    clip.side =
        Some(SessionView::new(FramesRef::Images { dir: c.side_dir.clone().unwrap() }, c.fps));
    clip.set_tracked(lipmap::io::track_csv::read_track_csv(&c.tracked_csv).unwrap());
    session.add_clip(clip).unwrap();
    session.save(&path).unwrap();

    let (mut app, mut bridge, _) = SessionBridge::open(&path, 0).unwrap();
    assert_eq!(app.side, SideState::Measuring);
    app.term_size = (80, 24);
    // What the run loop does on its threads, done here in order.
    let reply = bridge.side_view_job().expect("a side view")();
    apply(&mut app, &[reply, Action::ShowSide, Action::NextFrame, Action::NextFrame]);
    assert_eq!(app.view, View::Side);
    let side = app.side.view().expect("measured");
    assert_eq!(side.n_frames, 12);
    assert!(side.track.automatic.iter().all(|p| p.failed.is_none()), "{:?}", side.track);
    let k = side.frame_for(app.frame(), app.fps).unwrap();
    assert_eq!(k, 2);
    assert!(side.images.is_empty());
    let load = app.effects.contains(&lipmap::tui::app::Effect::LoadSideFrame(2));
    assert!(load, "the side frame is asked for: {:?}", app.effects);
    let image = bridge.side_frames().unwrap().load(2).unwrap();
    apply(&mut app, &[Action::SideFrameLoaded { frame: 2, image: image.into() }]);

    let side = app.side.view().unwrap();
    let auto = side.track.effective(k, &side.setup).unwrap();
    let before_p = app.side.view().unwrap().p_series(app.n_frames(), app.fps)[2].unwrap();
    // Ten steps forward (the face looks right): P grows.
    apply(&mut app, &[Action::NudgeLipPoint { dx: 10, dy: 0 }]);
    let side = app.side.view().unwrap();
    let moved = side.track.corrected[&k];
    assert!(moved.x > auto.upper_lip_px.unwrap().x);
    let after_p = side.p_series(app.n_frames(), app.fps)[2].unwrap();
    assert!(after_p > before_p, "P {before_p} -> {after_p}");
    assert!(side.track.effective(k, &side.setup).unwrap().source.as_str() == "corrected");

    // It draws: the panel names the side frame and the corrected source.
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| lipmap::tui::draw(&app, &lipmap::tui::Keymap::default(), f)).unwrap();
    let screen = format!("{:?}", t.backend().buffer());
    assert!(screen.contains("side frame 2/12") && screen.contains("corrected"), "{screen}");

    bridge.save(&app).unwrap();
    let saved = Session::load(&path).unwrap();
    assert_eq!(saved.clips[0].profile_corrections.get(&2), Some(&moved));
    // Undo clears it again, and so does the file on the next save.
    apply(&mut app, &[Action::Undo]);
    assert!(app.side.view().unwrap().track.corrected.is_empty());
    bridge.save(&app).unwrap();
    assert!(Session::load(&path).unwrap().clips[0].profile_corrections.is_empty());
}
