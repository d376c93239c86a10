//! Sessions and frame sources end to end: save/load round trips, relative paths, schema
//! refusal, crash safety of saves, the editor lock, the fit cache, and frames from image
//! folders and videos (real carphone data from ../shared when present).

use lipmap::alignment::{Alignment, Phone};
use lipmap::fit::{FitSettings, FrameFit};
use lipmap::io::atomic::temp_path;
use lipmap::io::frames::{FrameError, FrameOptions, FrameSource};
use lipmap::landmarks::{
    FrameLandmarks, LandmarkPoint, LandmarkSet, N_LANDMARKS, PointSource, Track,
};
use lipmap::session::store::{backup_path, lock_path};
use lipmap::session::{
    CURRENT_SCHEMA, Clip, FramesRef, LockInfo, MapRef, ModelRef, Session, SessionError,
    SessionLock, View,
};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn frame(f: usize, seed: f64) -> FrameLandmarks {
    let pts = (0..N_LANDMARKS)
        .map(|i| {
            LandmarkPoint::tracked(
                100.0 + seed + i as f64 * 1.25,
                50.0 + (f as f64 * 0.1 + i as f64).sin(),
            )
        })
        .collect();
    FrameLandmarks::new(f, pts)
}

fn session_with_frames(file: &Path, n: usize) -> Session {
    let root = file.parent().unwrap().parent().unwrap();
    let mut s = Session::new(file);
    let mut clip =
        Clip::new("clip1", View::new(FramesRef::Images { dir: root.join("frames") }, 29.97));
    clip.set_tracked(Track::new((0..n).map(|f| frame(f, 0.0)).collect()));
    s.add_clip(clip).unwrap();
    s
}

fn fit_of(frame: usize) -> FrameFit {
    FrameFit {
        frame,
        yaw: 1.5,
        pitch: -2.0,
        roll: 0.25,
        scale: 0.01,
        tx: 3.0,
        ty: -4.0,
        identity: vec![0.1, -0.2],
        expression: vec![],
        reproj_rms_px: 1.2,
        residuals: vec![None; N_LANDMARKS],
        failed: None,
    }
}

// ---------------------------------------------------------------------------------------
// Round trips and paths

fn arb_point() -> impl Strategy<Value = LandmarkPoint> {
    // Any bit pattern a session may hold: normal floats folded into the accepted range.
    let any_within = prop::num::f64::NORMAL.prop_map(|v| v % lipmap::landmarks::MAX_COORDINATE_PX);
    let coord = prop_oneof![-1e4..1e4f64, any_within, Just(0.0)];
    (coord.clone(), coord, any::<bool>(), prop::option::of(0.0f32..1.0), 0..3u8).prop_map(
        |(x, y, visible, confidence, s)| {
            let source = [PointSource::Tracked, PointSource::Corrected, PointSource::Interpolated]
                [s as usize];
            LandmarkPoint { x, y, visible, confidence, source }
        },
    )
}

fn arb_frame(f: usize) -> impl Strategy<Value = FrameLandmarks> {
    (
        prop::collection::vec(arb_point(), N_LANDMARKS),
        prop::option::of(0.0..100.0f64),
        prop::option::of(0.0f32..1.0),
        any::<bool>(),
        prop::option::of(0.0f32..0.5),
    )
        .prop_map(move |(points, timestamp, confidence, success, rerun_disagreement)| {
            FrameLandmarks {
                frame: f,
                timestamp,
                confidence,
                success,
                rerun_disagreement,
                points,
                lip_contact_px: None,
            }
        })
}

type Parts = (
    Vec<FrameLandmarks>,
    Vec<(usize, usize, LandmarkPoint)>,
    Vec<usize>,
    Vec<(String, f64)>,
    Vec<f64>,
    bool,
    String,
    f64,
);

/// The random parts of a session; `build_session` places them under a real folder.
fn arb_parts() -> impl Strategy<Value = Parts> {
    let frames = prop::collection::btree_set(0..40usize, 0..6)
        .prop_flat_map(|set| set.into_iter().map(arb_frame).collect::<Vec<_>>());
    let corrections = prop::collection::vec((0..50usize, 0..N_LANDMARKS, arb_point()), 0..6);
    let reviewed = prop::collection::vec(0..50usize, 0..4);
    let phones = prop::collection::vec(("[a-zA-Z]{1,3}[0-2]?", 0.01..0.5f64), 0..5);
    let fits = prop::collection::vec(-1e3..1e3f64, 0..4);
    (frames, corrections, reviewed, phones, fits, any::<bool>(), "[a-z]{1,8}", -2.0..2.0f64)
}

/// A session with every optional part present in some cases.
fn build_session(parts: Parts, file: &Path) -> Session {
    let (frames, corr, reviewed, phones, coeffs, side, ext, offset) = parts;
    let root = file.parent().unwrap().parent().unwrap().to_path_buf();
    let mut s = Session::new(file);
    s.head_mesh = Some(root.join("heads/h.obj"));
    s.model = Some(ModelRef {
        path: root.join("models/m.bin"),
        blendshapes: side.then(|| root.join("models/b.bin")),
    });
    s.landmark_map = MapRef {
        file: Some(root.join("maps/ibug.toml")),
        inline: side.then(|| [(30, 114), (62, 7)].into()),
    };
    s.fit_settings.set = if side { LandmarkSet::F1 } else { LandmarkSet::F4 };
    s.extensions.insert(ext.clone(), serde_json::json!({"n": offset, "v": [1, 2]}));
    let mut clip =
        Clip::new("c1", View::new(FramesRef::Video { file: root.join("video/a.mp4") }, 29.97));
    clip.front.size = Some([176, 144]);
    if side {
        clip.side = Some(View {
            source: FramesRef::Images { dir: root.join("side") },
            fps: 50.0,
            size: None,
            offset_s: offset,
        });
    }
    clip.set_tracked(Track::new(frames));
    clip.landmarks_file = Some(root.join("lm/clip.csv"));
    for (f, i, p) in corr {
        clip.corrections.set(f, i, p).unwrap();
    }
    for f in reviewed {
        clip.corrections.set_reviewed(f, true);
    }
    let mut t = 0.0;
    clip.alignment = Some(Alignment {
        phones: phones
            .into_iter()
            .map(|(label, d)| {
                let p = Phone { start: t, end: t + d, label };
                t += d;
                p
            })
            .collect(),
    });
    clip.alignment_file = Some(root.join("align/a.TextGrid"));
    clip.extensions
        .insert("protrusion".into(), serde_json::json!({"line": [[1.5, 2.0], [3.0, 4.0]]}));
    let ci = s.add_clip(clip).unwrap();
    let fits: Vec<FrameFit> = s
        .effective_track(ci)
        .unwrap()
        .frames
        .iter()
        .map(|f| FrameFit { identity: coeffs.clone(), ..fit_of(f.frame) })
        .collect();
    let settings = s.fit_settings.clone();
    s.store_fits(ci, &settings, fits).unwrap();
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn save_then_load_gives_the_same_session(parts in arb_parts()) {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("sessions").join("p.lipmap.json");
        let s = build_session(parts, &file);
        s.save(&file).unwrap();
        let back = Session::load(&file).unwrap();
        prop_assert_eq!(&back, &s);
        // Exact floats: the cache made before saving is still valid after loading.
        prop_assert!(back.stale_frames(0).unwrap().is_empty(), "stale after reload: {:?}", back.stale_frames(0));
        // Saving the loaded session writes the same bytes.
        prop_assert_eq!(back.to_json(&file).unwrap(), std::fs::read(&file).unwrap());
    }
}

#[test]
fn paths_are_relative_on_disk_and_follow_a_moved_project() {
    let dir = tempfile::tempdir().unwrap();
    let project = dir.path().join("project");
    let file = project.join("sessions").join("a.lipmap.json");
    let mut s = session_with_frames(&file, 2);
    s.model = Some(ModelRef { path: project.join("models/sfm.bin"), blendshapes: None });
    s.save(&file).unwrap();
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains(r#""dir": "../frames""#), "{text}");
    assert!(text.contains(r#""path": "../models/sfm.bin""#), "{text}");
    assert!(!text.contains(&dir.path().display().to_string()), "an absolute path leaked: {text}");

    let moved = dir.path().join("moved");
    std::fs::rename(&project, &moved).unwrap();
    let back = Session::load(&moved.join("sessions/a.lipmap.json")).unwrap();
    assert_eq!(back.clips[0].front.source.path(), moved.join("frames"));
    assert_eq!(back.model.unwrap().path, moved.join("models/sfm.bin"));
    assert_eq!(back.name, "a");
}

#[test]
fn the_tracked_layer_is_never_changed_by_corrections() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions/c.lipmap.json");
    let mut s = session_with_frames(&file, 3);
    let before = s.clips[0].tracked().unwrap().as_ref().clone();
    s.set_correction(0, 1, 62, LandmarkPoint::tracked(7.5, 8.5)).unwrap();
    s.set_correction(0, 9, 0, LandmarkPoint::tracked(1.0, 2.0)).unwrap(); // untracked frame
    assert!(s.set_correction(0, 1, 68, LandmarkPoint::tracked(0.0, 0.0)).is_err());
    assert!(matches!(
        s.set_correction(4, 1, 1, LandmarkPoint::tracked(0.0, 0.0)),
        Err(SessionError::NoClip { .. })
    ));
    s.set_reviewed(0, 1, true).unwrap();
    s.save(&file).unwrap();
    let mut back = Session::load(&file).unwrap();
    assert_eq!(*back.clips[0].tracked().unwrap(), before);
    let e = back.effective_frame(0, 1).unwrap().unwrap();
    assert_eq!((e.points[62].x, e.points[62].source), (7.5, PointSource::Corrected));
    assert_eq!(back.effective_frame(0, 9).unwrap().unwrap().visible_points().count(), 1);
    assert!(back.corrections_of(0).unwrap().is_reviewed(1));
    back.clear_correction(0, 1, 62).unwrap();
    assert_eq!(back.effective_frame(0, 1).unwrap().unwrap(), before.get(1).unwrap().clone());
}

// ---------------------------------------------------------------------------------------
// Bad files

#[test]
fn a_session_from_a_newer_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("new.lipmap.json");
    let newer = CURRENT_SCHEMA + 1;
    std::fs::write(
        &file,
        format!("{{\n  \"schema_version\": {newer},\n  \"clips\": [], \"future\": {{}}\n}}\n"),
    )
    .unwrap();
    let err = Session::load(&file).unwrap_err();
    assert!(matches!(err, SessionError::NewerSchema { found, .. } if found == newer), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains("newer lipmap")
            && msg.contains(&format!("schema {newer}"))
            && msg.contains("new.lipmap.json"),
        "{msg}"
    );
}

#[test]
fn load_errors_keep_serde_json_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.lipmap.json");
    std::fs::write(&file, "{\n  \"schema_version\": 1,\n  \"clips\": [,]\n}\n").unwrap();
    match Session::load(&file).unwrap_err() {
        SessionError::Parse { line, column, message, .. } => {
            assert_eq!((line, column), (3, 13), "{message}");
        }
        e => panic!("expected a parse error, got {e}"),
    }
    // A bad field deep inside: the wrong number of coordinates in a frame.
    std::fs::write(
        &file,
        "{\"schema_version\": 1, \"clips\": [{\"name\": \"a\",\n \"front\": {\"source\": {\"kind\": \"images\", \"dir\": \"f\"}, \"fps\": 25},\n \"tracked\": [{\"frame\": 0, \"xy\": [1, 2]}]}]}",
    )
    .unwrap();
    let msg = Session::load(&file).unwrap_err().to_string();
    assert!(
        msg.contains("bad.lipmap.json:3:") && msg.contains("`xy` has 2 numbers, expected 136"),
        "{msg}"
    );
    std::fs::write(&file, "{\"clips\": []}").unwrap();
    assert!(Session::load(&file).unwrap_err().to_string().contains("not a lipmap session"));
    std::fs::write(&file, "").unwrap();
    assert!(matches!(Session::load(&file).unwrap_err(), SessionError::Parse { line: 1, .. }));
}

#[test]
fn duplicate_clip_names_and_non_finite_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions/d.lipmap.json");
    let mut s = session_with_frames(&file, 1);
    let dup = s.clips[0].clone();
    assert!(s.add_clip(dup.clone()).is_err());
    s.clips.push(dup);
    assert!(s.save(&file).unwrap_err().to_string().contains("two clips are named"));
    assert!(!file.exists(), "nothing may be written for an invalid session");
    s.clips.pop();
    let good = s.clips[0].tracked().unwrap().as_ref().clone();
    let mut bad = good.clone();
    bad.frames[0].points[5].x = f64::NAN;
    s.clips[0].set_tracked(bad);
    let err = s.save(&file).unwrap_err().to_string();
    assert!(err.contains("tracked frame 0: point 6 (NaN"), "{err}");
    s.clips[0].set_tracked(good);
    // A non-finite fit is stored as a failed frame instead of making the file unloadable.
    let settings = FitSettings::default();
    s.store_fits(0, &settings, vec![FrameFit { yaw: f64::NAN, ..fit_of(0) }]).unwrap();
    s.save(&file).unwrap();
    let back = Session::load(&file).unwrap();
    assert!(back.cached_fit(0, &settings, 0).unwrap().unwrap().failed.is_some());
}

// ---------------------------------------------------------------------------------------
// Per-clip data files (schema 3)

/// The session `s` as a schema-2 build wrote it to `file`: each clip's tracks inline, every
/// clip's cache entries in one session-wide `fit_cache` naming their clip.
fn as_schema_2(s: &Session, file: &Path) -> String {
    let mut v: serde_json::Value = serde_json::from_slice(&s.to_json(file).unwrap()).unwrap();
    let mut cache = Vec::new();
    for clip in v["clips"].as_array_mut().unwrap() {
        assert!(clip["tracked"].is_array(), "unsaved data is written inline: {}", clip["tracked"]);
        let name = clip["name"].clone();
        let entries = clip.as_object_mut().unwrap().remove("fit_cache").unwrap_or_default();
        for mut e in entries.as_array().cloned().unwrap_or_default() {
            e["clip"] = name.clone();
            cache.push(e);
        }
    }
    v["fit_cache"] = cache.into();
    v["schema_version"] = 2.into();
    serde_json::to_string_pretty(&v).unwrap()
}

#[test]
fn an_old_session_with_inline_tracks_migrates_to_data_files_on_save() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("old.lipmap.json");
    let mut s = session_with_frames(&file, 6);
    let settings = FitSettings::default();
    s.store_fits(0, &settings, (0..6).map(fit_of).collect()).unwrap();
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    std::fs::write(&file, as_schema_2(&s, &file)).unwrap();

    // Read as it is: the tracks in memory, the cache moved into its clip and still valid.
    let old = Session::load(&file).unwrap();
    assert_eq!(old, s);
    assert!(old.stale_frames(0).unwrap().is_empty());
    assert_eq!(old.clips[0].tracked_file(), None);
    // Saved: schema 3, a reference and a summary in the JSON, the frames in the data folder.
    old.save(&file).unwrap();
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("\"schema_version\": 3"), "{text}");
    assert!(
        !text.contains("\"xy\"") && !text.contains("\"yaw\""),
        "per-frame data left in the JSON"
    );
    let data = dir.path().join("sessions").join("old.lipmap.d");
    let mut names: Vec<String> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names[0].starts_with("clip1.") && names[0].ends_with(".fits"), "{names:?}");
    assert!(names[1].starts_with("clip1.") && names[1].ends_with(".track"), "{names:?}");
    assert!(text.contains(&format!("\"file\": \"old.lipmap.d/{}\"", names[1])), "{text}");
    let back = Session::load(&file).unwrap();
    assert_eq!(back, s);
    assert_eq!(back.cached_fits(0, &settings).unwrap().len(), 6);
    assert!(back.stale_frames(0).unwrap().is_empty(), "the cache survives the move");
    // A load-save cycle is byte-identical and writes no new data file.
    back.save(&file).unwrap();
    assert_eq!(std::fs::read_to_string(&file).unwrap(), text);
    assert_eq!(std::fs::read_dir(&data).unwrap().count(), 2);
}

#[test]
fn a_clips_data_is_read_when_used_and_a_missing_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("lazy.lipmap.json");
    let s = session_with_frames(&file, 4);
    s.save(&file).unwrap();
    let loaded = Session::load(&file).unwrap();
    let track = loaded.clips[0].tracked_file().expect("saved to a file");
    // Loading read only the JSON: the file is read when the clip is used.
    std::fs::write(&track, b"not a track file").unwrap();
    let e = loaded.effective_track(0).unwrap_err().to_string();
    assert!(e.contains(track.to_str().unwrap()) && e.contains("too short"), "{e}");
    std::fs::remove_file(&track).unwrap();
    let e = Session::load(&file).unwrap_err().to_string();
    assert!(e.contains("lazy.lipmap.json") && e.contains("tracked") && e.contains("clip1."), "{e}");
}

#[test]
fn a_missing_fit_cache_empties_the_clips_cache_and_the_session_still_opens() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("cached.lipmap.json");
    let mut s = session_with_frames(&file, 5);
    let settings = FitSettings::default();
    s.store_fits(0, &settings, (0..5).map(fit_of).collect()).unwrap();
    s.save(&file).unwrap();
    let data = dir.path().join("sessions").join("cached.lipmap.d");
    let fits = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "fits"))
        .expect("a fits file");
    std::fs::remove_file(&fits).unwrap();
    // The fits are lost (they can be made again), the tracked frames are not.
    let back = Session::load(&file).unwrap();
    assert_eq!(back.lost_fit_caches, vec![("clip1".to_string(), fits.clone())]);
    assert!(back.cached_fits(0, &settings).unwrap().is_empty());
    assert_eq!(back.stale_frames(0).unwrap().len(), 5, "every frame to be fitted again");
    assert_eq!(back.effective_track(0).unwrap().frames.len(), 5);
    let read = lipmap::workflow::session::read_session(&file).unwrap();
    let said: Vec<&str> = read.notices.iter().map(|w| w.0.as_str()).collect();
    assert!(
        said.len() == 1
            && said[0].contains(fits.to_str().unwrap())
            && said[0].contains("lipmap fit"),
        "{said:?}"
    );
    // Saved again, the session no longer refers to the lost file.
    back.save(&file).unwrap();
    assert!(Session::load(&file).unwrap().lost_fit_caches.is_empty());
}

#[test]
fn a_session_saved_under_another_name_takes_its_data_along() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a").join("s.lipmap.json");
    let s = session_with_frames(&a, 3);
    s.save(&a).unwrap();
    let b = dir.path().join("b").join("t.lipmap.json");
    let loaded = Session::load(&a).unwrap();
    let frames = loaded.effective_track(0).unwrap();
    loaded.save(&b).unwrap();
    std::fs::remove_dir_all(dir.path().join("a")).unwrap();
    let back = Session::load(&b).unwrap();
    // The old folder is gone, so these frames were read from the new name's data folder.
    assert_eq!(back.effective_track(0).unwrap(), frames);
    assert_eq!(frames.frames.len(), 3);
    assert_eq!(back.clips.len(), 1);
    assert!(
        back.clips[0].tracked_file().unwrap().starts_with(dir.path().join("b").join("t.lipmap.d"))
    );
}

// Crash safety

const SAVE_LOOP_ENV: &str = "LIPMAP_TEST_SAVE_LOOP";

fn big_session(file: &Path, name: &str) -> Session {
    let mut s = session_with_frames(file, 3000);
    s.name = name.to_string();
    s
}

/// Not a test on its own: the body of the child process `a_save_killed_midway_...` kills.
#[test]
fn child_process_saving_in_a_loop() {
    let Some(file) = std::env::var_os(SAVE_LOOP_ENV) else { return };
    let file = PathBuf::from(file);
    let a = big_session(&file, "A");
    let b = big_session(&file, "B");
    println!("ready");
    for i in 0.. {
        let s = if i % 2 == 0 { &a } else { &b };
        s.save(&file).unwrap();
    }
}

#[test]
fn a_save_killed_midway_leaves_the_previous_session_whole() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("k.lipmap.json");
    let original = big_session(&file, "original");
    original.save(&file).unwrap();
    let exe = std::env::current_exe().unwrap();
    let mut seen = std::collections::BTreeSet::new();
    let mut mid_save_kills = 0;
    for delay_ms in [0u64, 40, 90, 170] {
        let mut child = std::process::Command::new(&exe)
            .args(["child_process_saving_in_a_loop", "--exact", "--nocapture", "--test-threads=1"])
            .env(SAVE_LOOP_ENV, &file)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Wait until the child has built its sessions and started saving.
        let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        while !line.contains("ready") {
            line.clear();
            if std::io::BufRead::read_line(&mut out, &mut line).unwrap() == 0 {
                panic!("child exited before saving");
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        child.kill().unwrap(); // SIGKILL: no destructors, no cleanup, like a crash
        child.wait().unwrap();
        let killed_mid_save = std::fs::read_dir(file.parent().unwrap())
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().contains(".tmp."));
        if killed_mid_save {
            mid_save_kills += 1;
        }
        let back = Session::load(&file).expect("the session must load after a crash mid-save");
        assert!(["original", "A", "B"].contains(&back.name.as_str()), "{}", back.name);
        let expected = big_session(&file, &back.name);
        assert_eq!(back.clips, expected.clips);
        seen.insert(back.name.clone());
    }
    // A later save still works and clears the dead child's temp files.
    original.save(&file).unwrap();
    let leftovers: Vec<_> = std::fs::read_dir(file.parent().unwrap())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp."))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    println!(
        "versions seen after kills: {seen:?}; kills that left a temp file (mid-save): {mid_save_kills}"
    );
}

#[test]
fn a_partial_temp_file_from_a_crash_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("t.lipmap.json");
    let s = session_with_frames(&file, 5);
    s.save(&file).unwrap();
    // Simulate a crash after writing half of the next version, before the rename.
    let mut next = s.clone();
    next.name = "next".into();
    let bytes = next.to_json(&file).unwrap();
    // The temp file of a process that has since died.
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let temp = temp_path(&file, dead, 0);
    std::fs::write(&temp, &bytes[..bytes.len() / 2]).unwrap();
    assert_eq!(Session::load(&file).unwrap(), s);
    next.save(&file).unwrap();
    assert_eq!(Session::load(&file).unwrap().name, "next");
    assert!(!temp.exists());
}

#[test]
fn saves_rotate_three_backups() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("b.lipmap.json");
    let mut s = session_with_frames(&file, 1);
    // Each save comes well after the one before: the newest backup is made to look old.
    let age_newest_backup = || {
        if let Ok(f) = std::fs::File::options().write(true).open(backup_path(&file, 1)) {
            let old = std::time::SystemTime::now() - 2 * lipmap::session::store::BACKUP_SPACING;
            f.set_modified(old).unwrap();
        }
    };
    for i in 0..5 {
        s.name = format!("v{i}");
        age_newest_backup();
        s.save(&file).unwrap();
    }
    let name_of = |p: PathBuf| Session::load(&p).unwrap().name;
    assert_eq!(name_of(file.clone()), "v4");
    assert_eq!(name_of(backup_path(&file, 1)), "v3");
    assert_eq!(name_of(backup_path(&file, 2)), "v2");
    assert_eq!(name_of(backup_path(&file, 3)), "v1");
    assert!(!backup_path(&file, 4).exists());
    assert!(backup_path(&file, 1).ends_with("b.lipmap.json.bak"));
    // Saves in quick succession (autosave while editing) keep the backups as they are, so
    // they still hold states from minutes ago.
    for i in 5..9 {
        s.name = format!("v{i}");
        s.save(&file).unwrap();
    }
    // (`v3`, the newest backup, was written just before `v4`: too recent to push along.)
    assert_eq!(name_of(file.clone()), "v8");
    assert_eq!(name_of(backup_path(&file, 1)), "v3");
    assert_eq!(name_of(backup_path(&file, 2)), "v2");
    assert_eq!(name_of(backup_path(&file, 3)), "v1");
}

// ---------------------------------------------------------------------------------------
// Lock

#[test]
fn a_second_editor_is_refused_with_the_holder_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("l.lipmap.json");
    let lock = SessionLock::acquire(&file).unwrap();
    let me = LockInfo::current();
    let err = SessionLock::acquire(&file).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, SessionError::Locked { .. }));
    assert!(
        msg.contains(&format!("{}@{}", me.user, me.host))
            && msg.contains(&format!("pid {}", me.pid)),
        "{msg}"
    );
    assert!(msg.contains("l.lipmap.json"), "{msg}");
    drop(lock);
    assert!(!lock_path(&file).exists(), "released on drop");
    let _again = SessionLock::acquire(&file).unwrap();
}

#[test]
fn a_stale_lock_on_this_host_is_taken_over_but_not_a_remote_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.lipmap.json");
    // A process that has certainly exited.
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .arg("--list")
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let dead_pid = child.id();
    child.wait().unwrap();
    let mut stale = LockInfo::current();
    stale.pid = dead_pid;
    std::fs::write(lock_path(&file), serde_json::to_string(&stale).unwrap()).unwrap();
    let lock = SessionLock::acquire(&file).expect("a dead holder's lock is taken over");
    assert_eq!(SessionLock::holder(&file).unwrap().pid, std::process::id());
    drop(lock);

    let remote = LockInfo { host: "another-machine".into(), pid: dead_pid, ..LockInfo::current() };
    std::fs::write(lock_path(&file), serde_json::to_string(&remote).unwrap()).unwrap();
    let msg = SessionLock::acquire(&file).unwrap_err().to_string();
    assert!(msg.contains("another-machine") && msg.contains("delete"), "{msg}");
}

// ---------------------------------------------------------------------------------------
// Fit cache

#[test]
fn a_correction_makes_only_its_frame_stale() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("f.lipmap.json");
    let mut s = session_with_frames(&file, 6);
    s.model = Some(ModelRef { path: dir.path().join("m.bin"), blendshapes: None });
    s.fit_settings.set = LandmarkSet::F4;
    let settings = s.fit_settings.clone();
    assert_eq!(s.stale_frames(0).unwrap(), (0..6).collect::<Vec<_>>());
    s.store_fits(0, &settings, (0..6).map(fit_of).collect()).unwrap();
    assert!(s.stale_frames(0).unwrap().is_empty());

    s.set_correction(0, 2, 62, LandmarkPoint::tracked(10.0, 20.0)).unwrap();
    assert_eq!(s.stale_frames(0).unwrap(), vec![2]);
    // A jaw point is outside the F4 set: the F4 fit is still valid.
    s.set_correction(0, 4, 3, LandmarkPoint::tracked(10.0, 20.0)).unwrap();
    assert_eq!(s.stale_frames(0).unwrap(), vec![2]);
    assert_eq!(s.cached_fits(0, &settings).unwrap().len(), 5);
    // Re-fitting the stale frame merges into the cache; saving and loading keeps it valid.
    s.store_fits(0, &settings, vec![fit_of(2)]).unwrap();
    s.save(&file).unwrap();
    let mut s = Session::load(&file).unwrap();
    assert!(s.stale_frames(0).unwrap().is_empty());
    // Other settings have their own entry; a changed model invalidates everything.
    let f5 = FitSettings { set: LandmarkSet::F5, ..settings.clone() };
    assert_eq!(s.stale_frames_with(0, &f5).unwrap().len(), 6);
    s.model.as_mut().unwrap().path = dir.path().join("other.bin");
    assert_eq!(s.stale_frames(0).unwrap().len(), 6);
    assert!(s.cached_fit(0, &settings, 1).unwrap().is_none());
}

#[test]
fn a_clip_fit_goes_stale_as_a_whole() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sessions").join("g.lipmap.json");
    let mut s = session_with_frames(&file, 4);
    let settings = FitSettings { clip: true, ..FitSettings::default() };
    s.store_fits(0, &settings, (0..4).map(fit_of).collect()).unwrap();
    assert!(s.stale_frames_with(0, &settings).unwrap().is_empty());
    s.set_correction(0, 1, 50, LandmarkPoint::tracked(1.0, 1.0)).unwrap();
    assert_eq!(s.stale_frames_with(0, &settings).unwrap(), vec![0, 1, 2, 3]);
}

// ---------------------------------------------------------------------------------------
// Frames

#[test]
fn image_folder_opens_in_natural_order_with_a_bounded_cache() {
    let Some(dir) = lipmap::testdata::shared("data/carphone/frames") else { return };
    let src = FrameSource::open(
        &dir,
        &FrameOptions { fps: Some(29.97), cache_mb: 1, ..FrameOptions::default() },
    )
    .unwrap();
    assert_eq!((src.len(), src.size(), src.fps()), (120, [176, 144], 29.97));
    assert!(src.frame_path(2).unwrap().ends_with("frame_0002.png"));
    let f0 = src.get(0).unwrap();
    assert_eq!(f0.dimensions(), (176, 144));
    let direct = image::open(dir.join("frame_0000.png")).unwrap().into_rgb8();
    assert_eq!(*f0, direct);
    for i in 0..120 {
        src.get(i).unwrap();
    }
    assert!(src.cached_bytes() <= 1 << 20, "cache holds {} bytes", src.cached_bytes());
    assert!(src.is_cached(119) && !src.is_cached(0));
    assert!(matches!(src.get(120), Err(FrameError::OutOfRange { len: 120, .. })));
}

#[test]
fn frames_decode_from_several_threads() {
    let Some(dir) = lipmap::testdata::shared("data/carphone/frames") else { return };
    let src = Arc::new(FrameSource::open(&dir, &FrameOptions::default()).unwrap());
    let handles: Vec<_> = (0..4)
        .map(|t| {
            let src = Arc::clone(&src);
            std::thread::spawn(move || {
                (t..120).step_by(4).map(|i| src.get(i).unwrap().len()).sum::<usize>()
            })
        })
        .collect();
    let total: usize = handles.into_iter().map(|h| h.join().unwrap()).sum();
    assert_eq!(total, 120 * 176 * 144 * 3);
}

#[test]
fn natural_sort_and_mixed_formats_in_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    for i in [1, 2, 10, 11, 3] {
        let img = image::RgbImage::from_pixel(4, 3, image::Rgb([i as u8, 0, 0]));
        let ext = if i == 3 { "ppm" } else { "png" };
        img.save(dir.path().join(format!("frame{i}.{ext}"))).unwrap();
    }
    std::fs::write(dir.path().join("notes.txt"), "not a frame").unwrap();
    std::fs::create_dir(dir.path().join("sub.png")).unwrap();
    let src = FrameSource::open(dir.path(), &FrameOptions::default()).unwrap();
    let order: Vec<u8> = (0..src.len()).map(|i| src.get(i).unwrap().get_pixel(0, 0)[0]).collect();
    assert_eq!(order, vec![1, 2, 3, 10, 11]);
    assert_eq!(src.fps(), lipmap::io::frames::DEFAULT_FOLDER_FPS);
    // A frame of another size is an error naming it, not a panic.
    image::RgbImage::new(5, 5).save(dir.path().join("frame12.png")).unwrap();
    let src = FrameSource::open(dir.path(), &FrameOptions::default()).unwrap();
    let msg = src.get(5).unwrap_err().to_string();
    assert!(msg.contains("frame12.png") && msg.contains("5x5"), "{msg}");
    let empty = tempfile::tempdir().unwrap();
    assert!(matches!(
        FrameSource::open(empty.path(), &FrameOptions::default()),
        Err(FrameError::NoFrames { .. })
    ));
}

fn ffmpeg_available() -> bool {
    let ok = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!(
            "skipping: the `ffmpeg` program is not installed (Debian: apt-get install ffmpeg)"
        );
    }
    ok
}

#[test]
fn video_frames_match_the_decoded_pngs() {
    let Some(video) = lipmap::testdata::shared("data/carphone/carphone_pristine.mp4") else {
        return;
    };
    let Some(pngs) = lipmap::testdata::shared("data/carphone/frames") else { return };
    if !ffmpeg_available() {
        return;
    }
    let src =
        FrameSource::open(&video, &FrameOptions { video_chunk: 8, ..FrameOptions::default() })
            .unwrap();
    assert_eq!((src.len(), src.size()), (120, [176, 144]));
    assert!((src.fps() - 30000.0 / 1001.0).abs() < 1e-9);
    // Out of order, across chunk borders, including the last frame.
    for i in [37, 0, 8, 7, 119, 64] {
        let got = src.get(i).unwrap();
        let want = image::open(pngs.join(format!("frame_{i:04}.png"))).unwrap().into_rgb8();
        let mad = got
            .as_raw()
            .iter()
            .zip(want.as_raw())
            .map(|(a, b)| (*a as f64 - *b as f64).abs())
            .sum::<f64>()
            / want.as_raw().len() as f64;
        // Neighbouring frames differ by several grey levels on average; the same frame by
        // at most colour-conversion rounding.
        assert!(mad < 1.5, "frame {i}: mean abs difference {mad}");
        if i > 0 {
            let prev =
                image::open(pngs.join(format!("frame_{:04}.png", i - 1))).unwrap().into_rgb8();
            let mad_prev = got
                .as_raw()
                .iter()
                .zip(prev.as_raw())
                .map(|(a, b)| (*a as f64 - *b as f64).abs())
                .sum::<f64>()
                / prev.as_raw().len() as f64;
            assert!(mad < mad_prev, "frame {i} matches frame {} better", i - 1);
        }
    }
    assert!(src.is_cached(38) && !src.is_cached(48), "chunk of 8 around frame 37");
    assert!(src.get(120).is_err());
}

#[test]
fn a_missing_video_is_an_error_naming_it() {
    let err = FrameSource::open(Path::new("/nonexistent/clip.mp4"), &FrameOptions::default())
        .unwrap_err();
    assert!(err.to_string().contains("/nonexistent/clip.mp4"), "{err}");
    let missing = FrameError::ProgramMissing { program: "ffmpeg" }.to_string();
    assert!(
        missing.contains("`ffmpeg`") && missing.contains("apt-get install ffmpeg"),
        "{missing}"
    );
}

#[test]
fn a_session_opens_its_clip_frames() {
    let Some(frames) = lipmap::testdata::shared("data/carphone/frames") else { return };
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("x.lipmap.json");
    let mut s = Session::new(&file);
    let mut clip = Clip::new("carphone", View::new(FramesRef::Images { dir: frames }, 29.97));
    clip.side = Some(View { offset_s: 0.1, ..clip.front.clone() });
    s.add_clip(clip).unwrap();
    s.save(&file).unwrap();
    let s = Session::load(&file).unwrap();
    let src = s.open_frames(0, 16).unwrap();
    assert_eq!((src.len(), src.fps()), (120, 29.97));
    assert!(s.open_side_frames(0, 16).unwrap().is_some());
}

#[test]
fn the_landmark_map_comes_from_the_file_until_labelled_inline() {
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("ibug_to_head.txt");
    std::fs::write(&toml, "[landmark_mappings]\n31 = 114 # nose tip\n63 = 7\n").unwrap();
    let mut map = MapRef { file: Some(toml), inline: None };
    let from_file = map.resolve().unwrap().unwrap();
    assert_eq!((from_file.vertex(30), from_file.vertex(62)), (Some(114), Some(7)));
    let mut edited = from_file.clone();
    edited.to_vertex.remove(&62);
    map.set_inline(&edited);
    let now = map.resolve().unwrap().unwrap();
    assert_eq!((now.vertex(30), now.vertex(62)), (Some(114), None));
}

/// Rewrites every stored `FitSettings` of a saved session the way lipmap wrote them before
/// the solver was a setting: `pose_refinement_steps` and `estimate_noise` in place of
/// `"solver"`.
fn as_written_before_the_solver_setting(text: &str, steps: usize, noise: bool) -> String {
    fn rewrite(v: &mut serde_json::Value, steps: usize, noise: bool) {
        if let Some(m) = v.as_object_mut() {
            if m.remove("solver").is_some() {
                m.insert("pose_refinement_steps".into(), steps.into());
                m.insert("estimate_noise".into(), noise.into());
            }
            m.values_mut().for_each(|c| rewrite(c, steps, noise));
        } else if let Some(a) = v.as_array_mut() {
            a.iter_mut().for_each(|c| rewrite(c, steps, noise));
        }
    }
    let mut tree: serde_json::Value = serde_json::from_str(text).unwrap();
    rewrite(&mut tree, steps, noise);
    serde_json::to_string_pretty(&tree).unwrap()
}

#[test]
fn a_session_from_before_the_solver_setting_loads_with_the_same_solver_and_cache() {
    use lipmap::fit::Solver;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("p").join("s.lipmap.json");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    let cases = [
        (0, true, Solver::Alternating),
        (1, true, Solver::Joint { pose_refinement_steps: 1, estimate_noise: true }),
        (3, false, Solver::Joint { pose_refinement_steps: 3, estimate_noise: false }),
    ];
    for (steps, noise, solver) in cases {
        let mut s = session_with_frames(&file, 4);
        s.fit_settings = FitSettings { solver, clip: true, ..FitSettings::default() };
        let settings = s.fit_settings.clone();
        s.store_fits(0, &settings, (0..4).map(fit_of).collect()).unwrap();
        s.save(&file).unwrap();
        let saved = std::fs::read_to_string(&file).unwrap();
        assert!(saved.contains("\"solver\""));
        std::fs::write(&file, as_written_before_the_solver_setting(&saved, steps, noise)).unwrap();
        let back = Session::load(&file).unwrap();
        assert_eq!(back.fit_settings, settings, "steps {steps}");
        // The cache is keyed by the settings: the old entry still answers.
        assert_eq!(back.cached_fits(0, &settings).unwrap().len(), 4, "steps {steps}");
    }
    // Settings older still (neither key) take the defaults of that time: the joint solver.
    session_with_frames(&file, 1).save(&file).unwrap();
    let mut tree: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    tree["fit_settings"].as_object_mut().unwrap().remove("solver");
    std::fs::write(&file, tree.to_string()).unwrap();
    assert_eq!(Session::load(&file).unwrap().fit_settings.solver, Solver::default());
}
