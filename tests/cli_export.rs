//! `lipmap export` end to end on real data: a session of the carphone clip (first frames),
//! the SFM model and a Praat alignment, exported as landmarks, CSV tables, PNGs and (when
//! asked for) OBJs.

mod common;

use lipmap::cli::Outcome;
use lipmap::cli::export::{self, ExportArgs, TABLE_FILES};
use lipmap::cli::output::NormaliseArg;
use lipmap::io::landmark_format::{LandmarkFormat, read_track};
use lipmap::io::{model_source, obj};
use lipmap::landmarks::{LandmarkPoint, LandmarkSet, PointSource};
use lipmap::session::Session;
use lipmap::workflow::create::{ClipInputs, NewSession, create_session};
use std::path::{Path, PathBuf};

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
            landmarks,
            alignment: Some((textgrid, None)),
            side: None,
            name: Some("carphone".into()),
        },
        head: None,
        model: model.clone(),
        blendshapes: Some(blendshapes.clone()),
        mapping: Some(eos.join("ibug_to_sfm.txt")),
        set: LandmarkSet::F4,
        force: false,
    };
    create_session(&args).unwrap();
    // One correction, so effective landmarks differ from the tracked ones; its x carries the
    // float noise a drag in the TUI leaves, which the export must not spell out.
    let mut s = Session::load(&session).unwrap();
    let mut p = s.effective_frame(0, 2).unwrap().points[62];
    p.x = p.x.floor() + 0.285_380_952_380_95;
    p.source = PointSource::Corrected;
    s.set_correction(0, 2, 62, p).unwrap();
    s.save(&session).unwrap();
    Some(Fixture { _carphone: c, root, session, model, blendshapes })
}

fn args(f: &Fixture, out: &Path) -> ExportArgs {
    ExportArgs {
        session: f.session.to_string_lossy().into_owned(),
        out: out.to_path_buf(),
        landmarks: None,
        meshes: false,
        tables: false,
        plots: false,
        all: false,
        clip: None,
        normalise: NormaliseArg::MinMax,
        worst: 10,
        plot_width: 1200,
    }
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
    let mut stdout = Vec::new();
    let outcome = export::run(&args(&f, &out_dir), &mut stdout).unwrap();
    let stdout = String::from_utf8_lossy(&stdout).into_owned();
    assert_eq!(outcome, Outcome::Ok, "{stdout}");
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
    assert!(!out_dir.join("meshes").exists(), "{stdout}");
    assert!(!stdout.contains("meshes"), "{stdout}");
    assert!(stdout.contains("landmarks (csv): 1 file in"), "{stdout}");
    assert!(stdout.contains("plots: 1 PNG file in"), "{stdout}");
    let meshes_dir = f.root.join("meshes-export");
    let a = ExportArgs { meshes: true, ..args(&f, &meshes_dir) };
    assert_eq!(export::run(&a, &mut Vec::new()).unwrap(), Outcome::Ok);
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

    // A PNG that decodes, as wide as asked, three panels (W, H, and the head's P) high.
    let png = image::open(export::plot_path(&out_dir, "carphone")).unwrap();
    assert_eq!((png.width(), png.height()), (1200, 44 + 3 * 160 + 2 * 16 + 28));

    // Fits were stored; a second export fits nothing and leaves the file byte for byte.
    assert_eq!(session.cached_fits(0, &session.fit_settings).len(), FRAMES);
    let before = std::fs::read(&f.session).unwrap();
    let again = f.root.join("again");
    let a = ExportArgs { all: true, ..args(&f, &again) };
    assert_eq!(export::run(&a, &mut Vec::new()).unwrap(), Outcome::Ok);
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
        let a = ExportArgs {
            landmarks: Some(format),
            clip: Some("carphone".into()),
            ..args(&f, &out_dir)
        };
        assert_eq!(export::run(&a, &mut Vec::new()).unwrap(), Outcome::Ok);
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
    let a = ExportArgs { meshes: true, ..args(&f, &out_dir) };
    let err = export::run(&a, &mut Vec::new()).unwrap_err().to_string();
    assert!(err.contains("no model"), "{err}");
    assert!(!out_dir.join("meshes").exists());
}

#[test]
fn unknown_clip_and_single_pts_are_refused() {
    let Some(f) = fixture() else { return };
    let out_dir = f.root.join("x");
    let a = ExportArgs { clip: Some("nope".into()), ..args(&f, &out_dir) };
    let err = export::run(&a, &mut Vec::new()).unwrap_err().to_string();
    assert!(err.contains("no clip `nope`") && err.contains("carphone"), "{err}");
    // `pts` (one frame per file) is not a track format for export.
    use clap::Parser;
    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        a: ExportArgs,
    }
    let bad = Cli::try_parse_from(["x", "s", "--out", "o", "--landmarks", "pts"]);
    assert!(bad.is_err());
    let ok =
        Cli::try_parse_from(["x", "s", "--out", "o", "--landmarks", "pts-dir", "--plots"]).unwrap();
    assert_eq!(ok.a.landmarks, Some(LandmarkFormat::PtsFolder));
    assert!(ok.a.plots && !ok.a.meshes);
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
    let a = ExportArgs { meshes: true, ..args(&f, &out_dir) };
    let outcome = export::run(&a, &mut Vec::new()).unwrap();
    let s = Session::load(&f.session).unwrap();
    let failed: Vec<usize> = s
        .cached_fits(0, &s.fit_settings)
        .iter()
        .filter(|fit| fit.failed.is_some())
        .map(|fit| fit.frame)
        .collect();
    let objs = files_in(&out_dir.join("meshes/carphone"), "obj");
    assert_eq!(objs.len() + failed.len(), FRAMES);
    assert_eq!(failed, vec![4]);
    assert_eq!(outcome, Outcome::Partial);
    assert!(!export::mesh_path(&out_dir, "carphone", 4).exists());
    assert!(export::mesh_path(&out_dir, "carphone", 3).exists());
}
