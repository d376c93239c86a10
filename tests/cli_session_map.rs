//! The `lipmap` binary on a real clip as a new user meets it: a session without a landmark
//! map, setting one with `import --mapping`, too small a map, runs beside an open editor, and
//! what `validate` says about a video. Real data from ../shared (skipped when absent).

mod common;
use common::{lipmap, s, text};

use lipmap::landmarks::{LandmarkPoint, PointSource};
use lipmap::session::Session;
use lipmap::session::store::lock_path;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Frames of landmarks in the sessions: enough to evaluate, few enough for a fast fit.
const FRAMES: usize = 6;

struct Inputs {
    _carphone: common::Carphone,
    root: PathBuf,
    frames: PathBuf,
    landmarks: PathBuf,
    model: PathBuf,
    mapping: PathBuf,
}

/// Carphone frames (read in place), its first frames of dlib landmarks as a CSV, the eos SFM
/// model and its map.
fn inputs() -> Option<Inputs> {
    let c = common::carphone(FRAMES)?;
    Some(Inputs {
        root: c.root.clone(),
        frames: c.frames.clone(),
        landmarks: c.landmarks.clone(),
        model: c.eos.join("sfm_shape_3448.bin"),
        mapping: c.eos.join("ibug_to_sfm.txt"),
        _carphone: c,
    })
}

/// `lipmap new` of the clip without a map (plus `extra` arguments); returns the session path.
fn new_session(i: &Inputs, name: &str, extra: &[&str]) -> (PathBuf, Output) {
    let session = i.root.join(format!("{name}.lipmap.json"));
    let mut args = vec![
        "new",
        s(&session),
        "--frames",
        s(&i.frames),
        "--landmarks",
        s(&i.landmarks),
        "--model",
        s(&i.model),
    ];
    args.extend_from_slice(extra);
    let out = lipmap(&args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    (session, out)
}

/// The stderr lines that are not progress-bar residue.
fn err_lines(out: &Output) -> Vec<String> {
    text(&out.stderr).lines().filter(|l| !l.trim().is_empty()).map(String::from).collect()
}

#[test]
fn a_session_without_a_map_is_made_and_fit_says_how_to_add_one() {
    let Some(i) = inputs() else { return };
    let (session, out) = new_session(&i, "nomap", &[]);
    let stdout = text(&out.stdout);
    // Named after the clip (the folder above `frames/`), not the landmark folder.
    assert!(stdout.contains("clip `carphone` with 6 frames of landmarks"), "{stdout}");
    assert!(stdout.contains("no model map yet (what `fit` uses)"), "{stdout}");
    // No --fps for an image folder: one notice, saying how to set it.
    let notice = format!(
        "lipmap: note: {} is a folder of images: assuming 25 fps (set it with --fps)",
        i.frames.display()
    );
    assert_eq!(err_lines(&out), [notice]);

    // The session loads, validates and has no map.
    let loaded = Session::load(&session).unwrap();
    assert!(loaded.landmark_map.file.is_none() && loaded.landmark_map.inline.is_none());
    assert_eq!(loaded.clips[0].name, "carphone");
    let v = lipmap(&["validate", s(&session)]);
    assert!(v.status.success(), "{}", text(&v.stdout));
    assert!(
        text(&v.stdout).contains("ok (session, 1 clip, 6 frames tracked"),
        "{}",
        text(&v.stdout)
    );

    // fit and eval: one line, exit 2.
    let want = format!(
        "lipmap: the session has no model map (what `fit` uses): label it in the TUI (view 2) \
         or `lipmap import {} --mapping FILE`",
        session.display()
    );
    for cmd in ["fit", "eval"] {
        let out = lipmap(&[cmd, s(&session)]);
        assert_eq!(out.status.code(), Some(2), "{cmd}");
        let lines: Vec<String> =
            err_lines(&out).into_iter().filter(|l| !l.contains("phone alignment")).collect();
        assert_eq!(lines, std::slice::from_ref(&want), "{cmd}");
    }

    // An empty map file is refused as a map, and taken with --accept-map-warnings (a start
    // for labelling), saying so; it then fails the same way.
    let empty = i.root.join("empty.toml");
    std::fs::write(&empty, "[landmark_mappings]\n").unwrap();
    let (session, out) = new_session(
        &i,
        "emptymap",
        &["--mapping", s(&empty), "--fps", "30", "--accept-map-warnings"],
    );
    assert!(text(&out.stderr).contains("it maps no landmark"), "{:?}", err_lines(&out));
    assert!(text(&out.stdout).contains("maps no landmarks yet"), "{}", text(&out.stdout));
    assert_eq!(Session::load(&session).unwrap().clips[0].front.fps, 30.0);
    let out = lipmap(&["fit", s(&session)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("the session has no model map"));
}

#[test]
fn import_mapping_sets_the_map_and_a_differing_labelled_map_is_warned_about() {
    let Some(i) = inputs() else { return };
    let (session, _) = new_session(&i, "setmap", &["--fps", "25"]);
    // `import SESSION --mapping FILE` alone: no clip needed.
    let out = lipmap(&["import", s(&session), "--mapping", s(&i.mapping)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("model map (what `fit` uses) set to") && stdout.contains("(50 landmarks)"),
        "{stdout}"
    );
    let mut loaded = Session::load(&session).unwrap();
    // Compared as files: the session keeps the path as given (a symlinked data folder stays
    // symlinked), so resolve both sides.
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap();
    let stored = loaded.landmark_map.file.as_deref().map(canonical);
    assert_eq!(stored, Some(canonical(&i.mapping)));
    assert_eq!(loaded.clips.len(), 1);

    // fit works now, with singular/plural counts right.
    let out = lipmap(&["fit", s(&session)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("carphone: 6 frames (6 refitted"), "{}", text(&out.stdout));
    assert!(!text(&out.stderr).contains("warning"), "{}", text(&out.stderr));

    // A labelled (inline) map that differs from the file: fit and eval warn once, naming it.
    let mut inline = loaded.landmark_map.resolve().unwrap().unwrap();
    let first = *inline.to_vertex.keys().next().unwrap();
    inline.to_vertex.remove(&first);
    loaded.landmark_map.set_inline(&inline);
    loaded.save(&session).unwrap();
    for cmd in ["fit", "eval"] {
        let out = lipmap(&[cmd, s(&session)]);
        assert!(out.status.success(), "{cmd}: {}", text(&out.stderr));
        let warnings: Vec<String> =
            err_lines(&out).into_iter().filter(|l| l.contains("labelled in the TUI")).collect();
        assert_eq!(warnings.len(), 1, "{cmd}: {}", text(&out.stderr));
        assert!(warnings[0].contains("ibug_to_sfm.txt"), "{}", warnings[0]);
        assert!(warnings[0].contains("lipmap import"), "{}", warnings[0]);
    }

    // Importing the file again replaces the labelled map, and says so.
    let out = lipmap(&["import", s(&session), "--mapping", s(&i.mapping)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("replaces the map labelled in the TUI (49 landmarks)"), "{stdout}");
    assert!(stdout.contains("cached fits dropped"), "{stdout}");
    let loaded = Session::load(&session).unwrap();
    assert!(loaded.landmark_map.inline.is_none());
    assert!(!loaded.has_cached_fits());
    let out = lipmap(&["fit", s(&session)]);
    assert!(!text(&out.stderr).contains("labelled in the TUI"), "{}", text(&out.stderr));

    // Nothing to import is an error, before touching the session.
    let before = std::fs::read(&session).unwrap();
    let out = lipmap(&["import", s(&session)]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(std::fs::read(&session).unwrap(), before);
}

#[test]
fn import_head_adds_the_users_head_and_says_how_to_label_it() {
    let (Some(i), Some(mh)) = (inputs(), lipmap::testdata::shared("data/makehuman")) else {
        return;
    };
    let head = mh.join("base.obj");
    // Without a map: the head is set and the hint names `map suggest`.
    let (session, _) = new_session(&i, "addhead", &["--fps", "25"]);
    let out = lipmap(&["import", s(&session), "--head", s(&head)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("head mesh set to") && stdout.contains("(19158 vertices)"), "{stdout}");
    assert!(stdout.contains("no map for this head yet") && stdout.contains("lipmap map suggest"));
    // With no label yet, `map suggest` names the step to take now (labelling in the TUI), not
    // a fit, which needs a map.
    let m = i.root.join("suggested.toml");
    let out = lipmap(&["map", "suggest", s(&session), "--out", s(&m)]);
    assert_eq!(out.status.code(), Some(2));
    let e = err_lines(&out).join("\n");
    assert!(e.contains("label at least 4 landmarks") && e.contains("lipmap tui"), "{e}");
    assert!(!e.contains("fit it"), "{e}");
    // The SFM model is another mesh: a setup with two maps, said in one line, not a warning.
    assert!(err_lines(&out).iter().all(|l| !l.contains("warning")), "{}", text(&out.stderr));
    assert!(stdout.contains("another mesh than the model"), "{stdout}");
    let loaded = Session::load(&session).unwrap();
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap();
    assert_eq!(loaded.head_mesh.as_deref().map(canonical), Some(canonical(&head)));

    // `--mapping` is the model's map (labelled on the SFM mesh), so it is not checked against
    // MakeHuman; importing the same head again replaces nothing.
    let out = lipmap(&["import", s(&session), "--mapping", s(&i.mapping), "--head", s(&head)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("model map (what `fit` uses) set to"), "{stdout}");
    assert!(!stdout.contains("does not fit this head"), "{stdout}");
    assert!(!stdout.contains("replaces"), "the same head replaces nothing: {stdout}");

    // `map suggest` now suggests the head's map (the model's has labels): with none on the
    // head it names that map, where labels are made, and the map that has some.
    let out = lipmap(&["map", "suggest", s(&session), "--out", s(&m)]);
    assert_eq!(out.status.code(), Some(2));
    let e = err_lines(&out).join("\n");
    assert!(e.starts_with("lipmap: the head map on base.obj: "), "{e}");
    assert!(e.contains("view 2") && e.contains("the model map has 50 labels: --map model"), "{e}");
    // `indices` measures the head through the head map, and its hint names this session.
    let out = lipmap(&["indices", s(&session)]);
    assert_eq!(out.status.code(), Some(2));
    let e = err_lines(&out).join("\n");
    assert!(e.contains("base.obj has no map yet"), "{e}");
    assert!(e.contains(&format!("lipmap import {} --head-mapping", s(&session))), "{e}");
    // `--map model` chooses the other one, and the output names it.
    let out =
        lipmap(&["map", "suggest", s(&session), "--map", "model", "--frame", "0", "--out", s(&m)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.starts_with("the model map on sfm_shape_3448.bin: matched to frame 0"),
        "{stdout}"
    );
    assert!(stdout.contains("lipmap import") && stdout.contains("--mapping"), "{stdout}");
    // The same failure through the workflow, as the TUI's `o`/`O` show it: no command-line
    // hint in a view where labels are being made.
    let loaded = Session::load(&session).unwrap();
    let Err(e) = lipmap::workflow::map::suggest_map_from_labels(
        &loaded,
        lipmap::session::MapRole::Head,
        lipmap::model::LandmarkMap::default(),
        None,
        lipmap::workflow::map::MatchTo::Frame(None, None),
    ) else {
        panic!("suggestions from no labels")
    };
    assert!(matches!(e, lipmap::workflow::Error::Suggest { .. }), "{e}");
    assert!(e.to_string().contains("label at least 4") && !e.to_string().contains("lipmap tui"));
}

#[test]
fn too_small_a_map_fails_once_before_fitting() {
    let Some(i) = inputs() else { return };
    let small = i.root.join("small.toml");
    // Two points of F4 (nose tip and a mouth corner), as a first labelling might leave.
    std::fs::write(&small, "[landmark_mappings]\n31 = 114\n49 = 398\n").unwrap();
    let (session, out) = new_session(&i, "small", &["--fps", "25", "--mapping", s(&small)]);
    assert!(
        text(&out.stdout)
            .contains("the landmark map has 2 landmarks of set F4; a fit needs at least 4"),
        "{}",
        text(&out.stdout)
    );
    for cmd in ["fit", "eval"] {
        let out = lipmap(&[cmd, s(&session)]);
        assert_eq!(out.status.code(), Some(2), "{cmd}");
        let lines: Vec<String> =
            err_lines(&out).into_iter().filter(|l| !l.contains("phone alignment")).collect();
        assert_eq!(
            lines,
            ["lipmap: the landmark map has 2 landmarks of set F4; a fit needs at least 4"],
            "{cmd}"
        );
    }
    // Nothing was fitted or cached.
    assert!(!Session::load(&session).unwrap().has_cached_fits());
    // The same check through the core, as the TUI calls it: 1 point reads singular.
    let map = lipmap::io::landmark_map_toml::read_landmark_map(&small).unwrap();
    let settings = lipmap::fit::FitSettings {
        set: lipmap::landmarks::LandmarkSet::F4,
        ..lipmap::fit::FitSettings::default()
    };
    let e = lipmap::workflow::check_map_for_fit(&map, 3448, &settings).unwrap_err();
    assert_eq!(e.to_string(), "the landmark map has 2 landmarks of set F4; a fit needs at least 4");
    let one = lipmap::model::LandmarkMap { to_vertex: [(30, 114)].into_iter().collect() };
    let e = lipmap::workflow::check_map_for_fit(&one, 3448, &settings).unwrap_err();
    assert!(e.to_string().contains("has 1 landmark of set"), "{e}");
    // Points outside the set or past the model's vertices do not count.
    let full = lipmap::io::landmark_map_toml::read_landmark_map(&i.mapping).unwrap();
    assert!(lipmap::workflow::check_map_for_fit(&full, 3448, &settings).unwrap() >= 4);
    assert!(lipmap::workflow::check_map_for_fit(&full, 10, &settings).is_err());
}

#[test]
fn eval_exits_nonzero_when_every_fit_failed() {
    let Some(i) = inputs() else { return };
    let (session, _) = new_session(&i, "allfail", &["--fps", "25", "--mapping", s(&i.mapping)]);
    // Every frame's 68 points at one spot: no camera can be solved for any frame.
    let mut loaded = Session::load(&session).unwrap();
    for frame in 0..FRAMES {
        for p in 0..68 {
            let pt = LandmarkPoint {
                source: PointSource::Corrected,
                ..LandmarkPoint::tracked(50.0, 50.0)
            };
            loaded.set_correction(0, frame, p, pt).unwrap();
        }
    }
    loaded.save(&session).unwrap();
    let out = lipmap(&["eval", s(&session)]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stdout));
    assert!(
        text(&out.stderr).contains("every fit failed (6 frames of 1 clip)"),
        "{}",
        text(&out.stderr)
    );
    // fit reports it without NaN and with one line per distinct reason.
    let out = lipmap(&["fit", s(&session)]);
    assert_eq!(out.status.code(), Some(1));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("6 failed, median reprojection RMS —"), "{stdout}");
    assert!(!stdout.contains("NaN"), "{stdout}");
    let failures: Vec<String> =
        err_lines(&out).into_iter().filter(|l| l.starts_with("carphone:")).collect();
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert!(failures[0].starts_with("carphone: 6 frames failed (0-5): "), "{failures:?}");
}

#[test]
fn eval_and_export_run_read_only_while_another_editor_holds_the_lock() {
    let Some(i) = inputs() else { return };
    let (session, _) = new_session(&i, "locked", &["--fps", "25", "--mapping", s(&i.mapping)]);
    // Another editor (on another host, so never taken for stale) holds the session.
    let lock = lock_path(&session);
    std::fs::write(&lock, r#"{"user":"ann","host":"lab-tui","pid":4242,"since_unix":0}"#).unwrap();
    let before = std::fs::read(&session).unwrap();

    let out = lipmap(&["eval", s(&session)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("RMSE per sentence"), "{}", text(&out.stdout));
    let notes: Vec<String> =
        err_lines(&out).into_iter().filter(|l| l.contains("another editor")).collect();
    assert_eq!(notes.len(), 1, "{}", text(&out.stderr));
    assert!(notes[0].starts_with("lipmap: note: ") && notes[0].contains("ann@lab-tui"));

    let dir = i.root.join("export");
    let out = lipmap(&["export", s(&session), "--out", s(&dir)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(dir.join("tables/sentences.csv").is_file() && dir.join("plots").is_dir());
    assert!(!dir.join("meshes").exists());

    // Neither saved anything (the fits stayed in memory); the lock is still the editor's.
    assert_eq!(std::fs::read(&session).unwrap(), before);
    assert!(std::fs::read_to_string(&lock).unwrap().contains("lab-tui"));
    // fit changes the session: still refused.
    let out = lipmap(&["fit", s(&session)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("open in another editor"), "{}", text(&out.stderr));
}

#[test]
fn validate_recognises_a_video_and_a_frames_folder() {
    let Some(video) = lipmap::testdata::shared("data/carphone/carphone_pristine.mp4") else {
        return;
    };
    let Some(frames) = lipmap::testdata::shared("data/carphone/frames") else { return };
    if Command::new("ffmpeg").arg("-version").output().is_err() {
        eprintln!("skipping: ffmpeg not installed");
        return;
    }
    let out = lipmap(&["validate", s(&video), s(&frames)]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(stdout.contains("ok (video, 120 frames at 29.97 fps, 176x144)"), "{stdout}");
    assert!(stdout.contains("ok (image folder, 120 frames at 25 fps assumed"), "{stdout}");
}

#[test]
fn a_bad_session_file_is_named_once_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.lipmap.json");
    std::fs::write(&path, "{\"schema_version\": 1, \"name\": ").unwrap();
    for cmd in ["eval", "indices", "fit"] {
        let out = lipmap(&[cmd, path.to_str().unwrap()]);
        assert!(!out.status.success(), "{cmd}");
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{cmd}: {err}");
        assert_eq!(lines[0].matches("broken.lipmap.json").count(), 1, "{cmd}: {err}");
    }
}

/// `eval --heads` with the session's own head and no `--mapping` takes the session's head
/// map (its file), as `transfer` does; another head without a map names what was looked
/// for, once.
#[test]
fn eval_heads_takes_the_session_heads_own_map() {
    let (Some(i), Some(mh)) = (inputs(), lipmap::testdata::shared("data/makehuman")) else {
        return;
    };
    let head = mh.join("base.obj");
    let head_map =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let (session, _) = new_session(
        &i,
        "evalheads",
        &["--fps", "25", "--mapping", s(&i.mapping), "--head", s(&head)],
    );
    let out = lipmap(&["import", s(&session), "--head-mapping", s(&head_map)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = lipmap(&["eval", s(&session), "--heads", s(&head)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains(&format!("map {}", head_map.display())), "{stdout}");
    // A copy of the head elsewhere is another head: no map beside it, said once.
    let copy = i.root.join("other.obj");
    std::fs::copy(&head, &copy).unwrap();
    let out = lipmap(&["eval", s(&session), "--heads", s(&copy)]);
    assert_eq!(out.status.code(), Some(2));
    let e = err_lines(&out).join("\n");
    assert_eq!(e.matches(s(&copy)).count(), 1, "{e}");
    assert!(e.contains("other.toml or other_map.toml"), "{e}");
}

/// The W/H RMSE row of `lipmap eval`'s first table (`--format csv`, its title a `#` line):
/// its two numbers.
fn first_rmse_row(stdout: &str) -> (f64, f64) {
    let row = stdout.lines().filter(|l| !l.starts_with('#')).nth(1).unwrap_or_default();
    let v: Vec<f64> = row.split(',').skip(1).take(2).filter_map(|x| x.parse().ok()).collect();
    assert_eq!(v.len(), 2, "{stdout}");
    (v[0], v[1])
}

/// `eval --heads` with the session's own model as a head fits the landmarks `eval` fits
/// (sealed lips closed, the default), so its W/H RMSE equals `eval`'s, not another fit's.
#[test]
fn eval_heads_on_the_sessions_own_model_gives_evals_figures() {
    let Some(c) = common::carphone(120) else {
        return;
    };
    let session = c.root.join("own.lipmap.json");
    let (model, map) = (c.eos.join("sfm_shape_3448.bin"), c.eos.join("ibug_to_sfm.txt"));
    let args = ["--frames", s(&c.frames), "--landmarks", s(&c.landmarks), "--model", s(&model)];
    let mut new = vec!["new", s(&session), "--mapping", s(&map)];
    new.extend(args);
    let out = lipmap(&new);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // A head folder holding the session's own model and map.
    let head = c.root.join("samemodel");
    std::fs::create_dir(&head).unwrap();
    std::fs::copy(&model, head.join("sfm_shape_3448.bin")).unwrap();
    std::fs::copy(&map, head.join("ibug_to_sfm.txt")).unwrap();
    let eval = |extra: &[&str]| {
        let mut a = vec!["eval", s(&session), "--pose", "image-plane", "--format", "csv"];
        a.extend_from_slice(extra);
        let out = lipmap(&a);
        assert!(out.status.success(), "{}", text(&out.stderr));
        first_rmse_row(&text(&out.stdout))
    };
    let own = eval(&[]);
    let as_head = eval(&["--heads", s(&head)]);
    assert!(
        (own.0 - as_head.0).abs() < 1e-9 && (own.1 - as_head.1).abs() < 1e-9,
        "{own:?} {as_head:?}"
    );
}
