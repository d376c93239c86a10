//! The TUI's session adapter: open a session, edit through `update`, save, reopen; the
//! correction is stored with source "corrected" beside the tracker's untouched value, and
//! the session is locked while open.

use lipmap::landmarks::PointSource;
use lipmap::session::{Clip, FramesRef, Session, View};
use lipmap::tui::fixtures::{face_image, synthetic_track};
use lipmap::tui::session_bridge::SessionBridge;
use lipmap::tui::{Action, App, update};

const W: u32 = 96;
const H: u32 = 72;

fn apply(app: &mut App, actions: &[Action]) {
    for a in actions {
        let mut next = Some(a.clone());
        while let Some(a) = next {
            next = update(app, a);
        }
    }
}

fn make_session(dir: &std::path::Path) -> std::path::PathBuf {
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for f in 0..6 {
        let img = face_image(f, W, H);
        image::RgbImage::from_raw(W, H, img.rgb)
            .unwrap()
            .save(frames.join(format!("frame_{f:04}.png")))
            .unwrap();
    }
    let path = dir.join("s.lipmap.json");
    let mut s = Session::new(&path);
    let view =
        View { source: FramesRef::Images { dir: frames }, fps: 25.0, size: None, offset_s: 0.0 };
    let mut clip = Clip::new("clip1", view);
    clip.set_tracked(synthetic_track(6, W, H));
    s.add_clip(clip).unwrap();
    s.save(&path).unwrap();
    path
}

#[test]
fn edits_round_trip_through_the_session_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_session(dir.path());
    let original = synthetic_track(6, W, H).frames[0].points[62];
    {
        let (mut app, mut bridge, frames) = SessionBridge::open(&path, 0).unwrap();
        assert_eq!(app.n_frames(), 6);
        assert_eq!(app.frames.cache.size, Some((W, H)));
        let img = frames.load(2).unwrap();
        assert_eq!((img.width, img.height), (W, H));
        // The session is locked while open.
        let err = SessionBridge::open(&path, 0).err().expect("second editor refused").to_string();
        assert!(err.contains("open in another editor"), "{err}");
        app.term_size = (80, 24);
        apply(&mut app, &[Action::Nudge { dx: 0, dy: -3 }, Action::ToggleReviewed]);
        bridge.save(&app).unwrap();
    }
    let s = Session::load(&path).unwrap();
    let c = &s.clips[0];
    let fixed = c.corrections.get(0, 62).expect("correction stored");
    assert_eq!(fixed.source, PointSource::Corrected);
    assert!(fixed.y < original.y);
    assert_eq!(c.tracked().unwrap().frames[0].points[62], original, "tracker's value kept");
    assert_eq!(c.corrections.len(), 1);
    assert!(c.corrections.is_reviewed(0));

    // Reopen: the correction is there; undoing everything and saving removes it.
    let (mut app, mut bridge, _) = SessionBridge::open(&path, 0).unwrap();
    assert_eq!(app.track.frames[0].points[62], *fixed);
    assert!(app.reviewed.contains(&0));
    app.term_size = (80, 24);
    apply(&mut app, &[Action::RevertPoint, Action::ToggleReviewed]);
    bridge.save(&app).unwrap();
    drop(bridge);
    let s = Session::load(&path).unwrap();
    assert!(s.clips[0].corrections.is_empty());
    assert!(!s.clips[0].corrections.is_reviewed(0));
}

#[test]
fn missing_frames_still_open_for_landmark_editing() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_session(dir.path());
    std::fs::remove_dir_all(dir.path().join("frames")).unwrap();
    let (app, _bridge, frames) = SessionBridge::open(&path, 0).unwrap();
    assert!(app.status.contains("frames"), "{}", app.status);
    assert!(frames.load(0).is_err());
    assert_eq!(app.n_frames(), 6);
}

#[test]
fn saving_the_map_never_overwrites_the_input_map_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_session(dir.path());
    let input_map = dir.path().join("input_map.txt");
    std::fs::write(&input_map, "[landmark_mappings]\n31 = 114 # nose tip\n").unwrap();
    let mut s = Session::load(&path).unwrap();
    s.landmark_map.file = Some(input_map.clone());
    s.save(&path).unwrap();
    let before = std::fs::read_to_string(&input_map).unwrap();

    let (mut app, mut bridge, _) = SessionBridge::open(&path, 0).unwrap();
    assert_eq!(app.map.as_ref().unwrap().vertex(30), Some(114));
    app.map.as_mut().unwrap().to_vertex.insert(48, 7);
    let written = bridge.save_map(&app).unwrap();
    assert_ne!(written, input_map);
    assert_eq!(std::fs::read_to_string(&input_map).unwrap(), before, "input untouched");
    let again = bridge.save_map(&app).unwrap();
    assert_eq!(again, written, "its own file is reused");
    bridge.save(&app).unwrap();
    drop(bridge);
    let s = Session::load(&path).unwrap();
    let m = s.landmark_map.resolve().unwrap().unwrap();
    assert_eq!((m.vertex(30), m.vertex(48)), (Some(114), Some(7)));
    let from_file = lipmap::io::landmark_map_toml::read_landmark_map(&written).unwrap();
    assert_eq!(from_file.vertex(48), Some(7));
}

#[test]
fn autosave_runs_on_the_saver_thread_and_keeps_later_edits_unsaved() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_session(dir.path());
    let (mut app, mut bridge, _) = SessionBridge::open(&path, 0).unwrap();
    app.term_size = (80, 24);
    let (tx, rx) = std::sync::mpsc::channel();
    bridge.start_saver(tx);
    apply(&mut app, &[Action::Nudge { dx: 0, dy: -3 }, Action::Save]);
    assert!(app.save.in_flight());
    let generation = app.save.generation();
    bridge.save_in_background(&app, generation).unwrap();
    // Another edit while the save is on its way.
    apply(&mut app, &[Action::Nudge { dx: 2, dy: 0 }]);
    let reply = rx.recv_timeout(std::time::Duration::from_secs(10)).expect("the saver replies");
    assert_eq!(reply, Action::Saved { generation });
    apply(&mut app, &[reply]);
    assert!(!app.save.in_flight());
    assert_eq!(app.save.unsaved(), 1, "the later edit is still to be saved");
    let on_disk = Session::load(&path).unwrap();
    let p = on_disk.effective_frame(0, 0).unwrap().unwrap().points[62];
    assert_eq!(p.source, PointSource::Corrected);
    // The next save writes the later edit too; dropping the bridge waits for the saver.
    apply(&mut app, &[Action::Save]);
    bridge.save_in_background(&app, app.save.generation()).unwrap();
    drop(bridge);
    let q = Session::load(&path).unwrap().effective_frame(0, 0).unwrap().unwrap().points[62];
    assert!(q.x > p.x, "{} then {}", p.x, q.x);
}
