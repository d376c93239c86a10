//! Exporting end to end on real data: a session of the carphone clip (first frames), the SFM
//! model and a Praat alignment (made by `workflow::create`), exported through the
//! workflow as landmarks, CSV tables, PNGs and (when asked for) OBJs; hostile clip names and
//! symlinks inside the output folder; and the `lipmap export` binary's printed counts.

mod common;

use lipmap::io::landmark_format::{LandmarkFormat, read_track};
use lipmap::io::{model_source, obj};
use lipmap::landmarks::{LandmarkPoint, LandmarkSet, PointSource};
use lipmap::plot::{font::find_text, trajectory};
use lipmap::session::Session;
use lipmap::workflow::create::{ClipInputs, NewSession, create_session};
use lipmap::workflow::export::{
    self as export, ExportPlan, ExportReport, ExportRequest, TABLE_FILES,
};
use lipmap::workflow::{Normalisation, no_progress, open_for_read};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Frames of the clip in the session: enough for a sequence, few enough for a fast fit.
const FRAMES: usize = 6;

struct Fixture {
    _carphone: common::Carphone,
    root: PathBuf,
    session: PathBuf,
    model: PathBuf,
    blendshapes: PathBuf,
}

/// A session in a temp folder: carphone frames (read in place), its first `FRAMES` frames
/// of dlib landmarks (as a lipmap CSV in the temp folder), one correction, the SFM model.
fn fixture() -> Option<Fixture> {
    let c = common::carphone(FRAMES)?;
    let textgrid = lipmap::testdata::shared("data/speech/generated/praat_bin_blue.TextGrid")?;
    let (root, frames, landmarks, eos) =
        (c.root.clone(), c.frames.clone(), c.landmarks.clone(), c.eos.clone());
    let session = root.join("s.lipmap.json");
    let (model, blendshapes) =
        (eos.join("sfm_shape_3448.bin"), eos.join("expression_blendshapes_3448.bin"));
    let args = NewSession {
        path: session.clone(),
        clip: ClipInputs {
            frames,
            fps: Some(25.0),
            landmarks: landmarks.into(),
            alignment: Some((textgrid, None)),
            side: None,
            name: Some("carphone".into()),
            audio: None,
        },
        head: None,
        model: model.clone(),
        blendshapes: Some(blendshapes.clone()),
        mapping: Some(eos.join("ibug_to_sfm.txt")),
        set: LandmarkSet::F4,
        force: false,
        accept_map_warnings: false,
    };
    create_session(&args).unwrap();
    // One correction, so effective landmarks differ from the tracked ones; its x carries the
    // float noise a drag in the TUI leaves, which the export must not spell out.
    let mut s = Session::load(&session).unwrap();
    let mut p = s.effective_frame(0, 2).unwrap().unwrap().points[62];
    p.x = p.x.floor() + 0.285_380_952_380_95;
    p.source = PointSource::Corrected;
    s.set_correction(0, 2, 62, p).unwrap();
    s.save(&session).unwrap();
    Some(Fixture { _carphone: c, root, session, model, blendshapes })
}

fn args(out: &Path) -> ExportRequest {
    ExportRequest {
        out: out.to_path_buf(),
        plan: ExportPlan::of(None, false, false, false, false),
        clip: None,
        normalisation: Normalisation::MinMax,
        worst: 10,
        plot_width: 1200,
        pose: Default::default(),
    }
}

fn plan(landmarks: Option<LandmarkFormat>, meshes: bool, all: bool) -> ExportPlan {
    ExportPlan::of(landmarks, meshes, false, false, all)
}

/// Runs an export of the session at `session` as `lipmap export` does.
fn run(session: &Path, req: &ExportRequest) -> lipmap::workflow::Result<ExportReport> {
    let mut opened = open_for_read(&session.to_string_lossy())?;
    export::export(&mut opened, req, &no_progress)
}

fn files_of(w: &Option<export::Written>) -> usize {
    w.as_ref().map_or(0, |w| w.files)
}

fn files_in(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

#[test]
fn exports_all_but_meshes_by_default_and_leaves_an_up_to_date_session_alone() {
    let Some(f) = fixture() else { return };
    let out_dir = f.root.join("export");
    let report = run(&f.session, &args(&out_dir)).unwrap();
    assert!(report.failed_fits.is_empty() && report.warnings.is_empty(), "{report:?}");
    let session = Session::load(&f.session).unwrap();

    // Landmarks (csv by default) read back as the effective landmarks, correction included,
    // with at most 4 decimals.
    let csv_path = export::landmarks_path(&out_dir, "carphone", LandmarkFormat::LipmapCsv);
    let exported = read_track(&csv_path).unwrap();
    let effective = session.effective_track(0).unwrap();
    assert_eq!(exported.frames.len(), effective.frames.len());
    for (a, b) in exported.frames.iter().zip(&effective.frames) {
        for (p, q) in a.points.iter().zip(&b.points) {
            assert!((p.x - q.x).abs() <= 5e-5 && (p.y - q.y).abs() <= 5e-5, "{p:?} vs {q:?}");
            assert_eq!((p.visible, p.source), (q.visible, q.source));
        }
    }
    assert_eq!(exported.frames[2].points[62].source, PointSource::Corrected);
    let whole = exported.frames[2].points[62].x.floor();
    assert!((exported.frames[2].points[62].x - (whole + 0.2854)).abs() < 1e-9);
    let text = std::fs::read_to_string(&csv_path).unwrap();
    assert!(text.contains(&format!("2,62,{whole}.2854,")), "{}", &text[..200]);
    for line in text.lines().skip(1) {
        for field in line.split(',').skip(2).take(2) {
            let decimals = field.split('.').nth(1).map_or(0, str::len);
            assert!(decimals <= 4, "{line}");
        }
    }

    // No meshes unless asked for: an OBJ of the whole model per frame is huge.
    assert!(!out_dir.join("meshes").exists() && report.meshes.is_none());
    assert_eq!((files_of(&report.landmarks), files_of(&report.plots)), (1, 1));
    assert_eq!(files_of(&report.tables), TABLE_FILES.len());
    let meshes_dir = f.root.join("meshes-export");
    let a = ExportRequest { plan: plan(None, true, false), ..args(&meshes_dir) };
    let report = run(&f.session, &a).unwrap();
    assert_eq!(files_of(&report.meshes), FRAMES);
    assert!(report.failed_fits.is_empty());
    assert!(!meshes_dir.join("tables").exists() && !meshes_dir.join("landmarks").exists());

    // With --meshes: one OBJ per frame, in the model's vertex order and with its triangles.
    let out_dir_tables = out_dir.clone();
    let out_dir = meshes_dir;
    let model = model_source::load_model(&f.model, Some(&f.blendshapes)).unwrap();
    let objs = files_in(&out_dir.join("meshes/carphone"), "obj");
    assert_eq!(objs.len(), FRAMES);
    let mesh = obj::read_obj(&export::mesh_path(&out_dir, "carphone", 3)).unwrap();
    assert_eq!(mesh.num_vertices(), model.num_vertices());
    assert_eq!(mesh.num_vertices(), 3448);
    assert_eq!(mesh.faces.len(), model.triangles.len());
    // The fit moved the head away from the mean shape.
    let mean = model.shape.mean.as_slice();
    let moved = mesh.to_flat().iter().zip(mean).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(moved > 1e-3, "exported mesh is the mean shape");

    // The five tables; the sentence table has the clip's row.
    let out_dir = out_dir_tables;
    for name in TABLE_FILES {
        assert!(out_dir.join("tables").join(name).is_file(), "{name} missing");
    }
    let sentences = std::fs::read_to_string(out_dir.join("tables/sentences.csv")).unwrap();
    assert!(sentences.lines().count() >= 2, "{sentences}");
    assert!(sentences.contains("carphone"), "{sentences}");

    // A PNG that decodes, as wide as asked, with three panels (W, H, and the head's P).
    let png = image::open(export::plot_path(&out_dir, "carphone")).unwrap().to_rgb8();
    assert_eq!(png.width(), 1200);
    for label in ["W mouth width", "H mouth height", "P protrusion"] {
        let found = find_text(&png, label, trajectory::LABEL_PX, trajectory::INK, true);
        assert!(found.is_some(), "no `{label}` panel");
    }

    // Fits were stored; a second export fits nothing and leaves the file byte for byte.
    assert_eq!(session.cached_fits(0, &session.fit_settings).unwrap().len(), FRAMES);
    let before = std::fs::read(&f.session).unwrap();
    let again = f.root.join("again");
    let a = ExportRequest { plan: plan(None, false, true), ..args(&again) };
    run(&f.session, &a).unwrap();
    assert_eq!(std::fs::read(&f.session).unwrap(), before);
    // --all is landmarks, tables and plots; still no meshes.
    assert!(again.join("tables").is_dir() && !again.join("meshes").exists());
}

#[test]
fn landmarks_only_in_each_track_format_needs_no_model() {
    let Some(f) = fixture() else { return };
    // Without a model the session can still export landmarks (no fit is needed).
    let mut s = Session::load(&f.session).unwrap();
    s.model = None;
    s.save(&f.session).unwrap();
    let effective = s.effective_track(0).unwrap();
    for format in [
        LandmarkFormat::PtsFolder,
        LandmarkFormat::OpenFace,
        LandmarkFormat::DlibXml,
        LandmarkFormat::LipmapCsv,
    ] {
        let out_dir = f.root.join(format!("lm-{format}"));
        let a = ExportRequest {
            plan: plan(Some(format), false, false),
            clip: Some("carphone".into()),
            ..args(&out_dir)
        };
        let report = run(&f.session, &a).unwrap();
        let want = if format == LandmarkFormat::PtsFolder { FRAMES } else { 1 };
        assert_eq!(files_of(&report.landmarks), want, "{format}");
        let path = export::landmarks_path(&out_dir, "carphone", format);
        if format == LandmarkFormat::PtsFolder {
            assert_eq!(files_in(&path, "pts").len(), FRAMES);
        }
        let back = read_track(&path).unwrap();
        assert_eq!(back.frames.len(), FRAMES, "{format}");
        for (b, e) in back.frames.iter().zip(&effective.frames) {
            for (pb, pe) in b.points.iter().zip(&e.points) {
                // dlib imglab XML stores whole pixels; the text formats keep decimals.
                let tol = if format == LandmarkFormat::DlibXml { 0.5 } else { 1e-3 };
                let close = |a: f64, b: f64| (a - b).abs() <= tol;
                assert!(close(pb.x, pe.x) && close(pb.y, pe.y), "{format}: {pb:?} vs {pe:?}");
            }
        }
        assert!(!out_dir.join("meshes").exists() && !out_dir.join("plots").exists());
    }
    // Asking for meshes now fails with the reason, before writing any.
    let out_dir = f.root.join("no-model");
    let a = ExportRequest { plan: plan(None, true, false), ..args(&out_dir) };
    let err = run(&f.session, &a).unwrap_err().to_string();
    assert!(err.contains("no model"), "{err}");
    assert!(!out_dir.join("meshes").exists());
}

#[test]
fn unknown_clip_and_single_pts_are_refused() {
    let Some(f) = fixture() else { return };
    let out_dir = f.root.join("x");
    let a = ExportRequest { clip: Some("nope".into()), ..args(&out_dir) };
    let err = run(&f.session, &a).unwrap_err().to_string();
    assert!(err.contains("no clip `nope`") && err.contains("carphone"), "{err}");
    // `pts` (one frame per file) is not a track format for export.
    let st = Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .arg("export")
        .arg(&f.session)
        .args(["--out", "o", "--landmarks", "pts"])
        .output()
        .unwrap();
    assert_eq!(st.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&st.stderr).contains("pts-dir"));
}

#[test]
fn a_failed_fit_is_skipped_and_makes_the_outcome_partial() {
    let Some(f) = fixture() else { return };
    // A frame whose 68 points coincide cannot be fitted (no extent to solve a camera from).
    let mut s = Session::load(&f.session).unwrap();
    for i in 0..68 {
        s.set_correction(
            0,
            4,
            i,
            LandmarkPoint { source: PointSource::Corrected, ..LandmarkPoint::tracked(50.0, 50.0) },
        )
        .unwrap();
    }
    s.save(&f.session).unwrap();
    let out_dir = f.root.join("partial");
    let a = ExportRequest { plan: plan(None, true, false), ..args(&out_dir) };
    let report = run(&f.session, &a).unwrap();
    let s = Session::load(&f.session).unwrap();
    let failed: Vec<usize> = s
        .cached_fits(0, &s.fit_settings)
        .unwrap()
        .iter()
        .filter(|fit| fit.failed.is_some())
        .map(|fit| fit.frame)
        .collect();
    let objs = files_in(&out_dir.join("meshes/carphone"), "obj");
    assert_eq!(objs.len() + failed.len(), FRAMES);
    assert_eq!(failed, vec![4]);
    assert_eq!(files_of(&report.meshes), FRAMES - 1);
    assert_eq!(report.failed_fits.len(), 1);
    // The binary exits 1 (some frames skipped) and says why once.
    let st = Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .arg("export")
        .arg(&f.session)
        .arg("--out")
        .arg(f.root.join("partial-bin"))
        .arg("--meshes")
        .output()
        .unwrap();
    assert_eq!(st.status.code(), Some(1), "{}", String::from_utf8_lossy(&st.stderr));
    let stdout = String::from_utf8_lossy(&st.stdout);
    assert!(stdout.contains(&format!("meshes: {} OBJ files in", FRAMES - 1)), "{stdout}");
    assert!(!export::mesh_path(&out_dir, "carphone", 4).exists());
    assert!(export::mesh_path(&out_dir, "carphone", 3).exists());
}

/// Renames the session's only clip to `name` (as a hand-edited or hostile session would).
fn rename_clip(session: &Path, name: &str) {
    let mut s = Session::load(session).unwrap();
    s.clips[0].name = name.to_string();
    s.save(session).unwrap();
}

/// Every file under `dir`, recursively (symlinks not followed).
fn all_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if std::fs::symlink_metadata(&p).unwrap().is_dir() {
            out.extend(all_files(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn hostile_clip_names_stay_inside_out_and_the_counts_are_what_was_written() {
    let Some(f) = fixture() else { return };
    let victim = f.root.join("victim");
    std::fs::create_dir(&victim).unwrap();
    for (i, name) in ["../../evil", "/tmp/lipmap-abs-evil", "x/../../../evil2"].iter().enumerate() {
        rename_clip(&f.session, name);
        let out_dir = f.root.join(format!("deep/out{i}"));
        let a = ExportRequest {
            plan: plan(Some(LandmarkFormat::PtsFolder), true, true),
            ..args(&out_dir)
        };
        let report = run(&f.session, &a).unwrap();
        let files = all_files(&out_dir);
        // Landmarks (a .pts per frame), an OBJ per frame, 5 tables, 1 plot: all inside.
        assert_eq!(files.len(), FRAMES + FRAMES + TABLE_FILES.len() + 1, "{name}: {files:?}");
        assert_eq!(
            files_of(&report.landmarks)
                + files_of(&report.meshes)
                + files_of(&report.tables)
                + files_of(&report.plots),
            files.len()
        );
        assert!(files.iter().all(|p| p.starts_with(&out_dir)), "{files:?}");
    }
    assert!(!f.root.join("evil").exists() && !f.root.join("evil.csv").exists());
    assert!(!Path::new("/tmp/lipmap-abs-evil.csv").exists());
    assert!(!Path::new("/tmp/lipmap-abs-evil").exists());
    assert_eq!(std::fs::read_dir(&victim).unwrap().count(), 0);
}

#[cfg(unix)]
#[test]
fn symlinks_inside_out_are_replaced_not_written_through() {
    let Some(f) = fixture() else { return };
    let precious = f.root.join("precious.csv");
    std::fs::write(&precious, "keep me").unwrap();
    let elsewhere = f.root.join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    let out_dir = f.root.join("out");
    std::fs::create_dir_all(out_dir.join("landmarks")).unwrap();
    std::os::unix::fs::symlink(&precious, out_dir.join("landmarks/carphone.csv")).unwrap();
    std::os::unix::fs::symlink(&elsewhere, out_dir.join("plots")).unwrap();
    let report = run(&f.session, &args(&out_dir)).unwrap();
    assert_eq!(files_of(&report.landmarks), 1);
    assert_eq!(std::fs::read_to_string(&precious).unwrap(), "keep me");
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
    let lm = out_dir.join("landmarks/carphone.csv");
    assert!(std::fs::symlink_metadata(&lm).unwrap().is_file());
    assert!(std::fs::symlink_metadata(out_dir.join("plots")).unwrap().is_dir());
    assert!(out_dir.join("plots/carphone.png").is_file());
}

#[test]
fn an_escape_sequence_in_a_clip_name_reaches_the_terminal_escaped() {
    let Some(f) = fixture() else { return };
    rename_clip(&f.session, "evil\x1b[2J\x1b]0;owned\x07");
    for args in [vec!["eval"], vec!["fit"]] {
        let st = Command::new(env!("CARGO_BIN_EXE_lipmap"))
            .args(&args)
            .arg(&f.session)
            .output()
            .unwrap();
        let (out, err) = (st.stdout, st.stderr);
        assert!(!out.contains(&0x1b) && !err.contains(&0x1b) && !out.contains(&0x07), "{args:?}");
        let text = String::from_utf8_lossy(&out);
        assert!(text.contains("evil\\x1b[2J"), "{args:?}: {text}");
    }
}
