//! `lipmap speech` through the binary: a small model trained on demo sessions (whose clips
//! carry the demo voice), scored and animated; and the bad inputs a user can give it (empty,
//! truncated, too-slow-rate WAVs, audio far shorter than its clip, a file that is not a
//! model, another model version, a model trained at another frame rate, absurd numbers in a
//! model, a session without audio), each a one-line error naming the file or setting.

use lipmap::io::wav::write_wav;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{lipmap, s, text};

/// The one error line of a failed run.
fn one_error(out: &Output) -> String {
    assert!(!out.status.success(), "expected a failure, got: {}", text(&out.stdout));
    let lines: Vec<String> =
        text(&out.stderr).lines().filter(|l| !l.trim().is_empty()).map(String::from).collect();
    assert_eq!(lines.len(), 1, "not one line: {lines:?}");
    lines[0].clone()
}

/// A 3-sentence demo session (its clips carry the demo voice) and a small model trained on
/// it: N 8 asked (shrunk to what 3 sentences allow), M 1, t_c 1 keeps the debug-build
/// training to seconds.
fn trained(dir: &Path) -> (PathBuf, PathBuf) {
    let demo = dir.join("demo");
    let out = lipmap(&["demo", "--no-tui", "--sentences", "3", "--out", s(&demo)]);
    assert!(out.status.success(), "demo: {}", text(&out.stderr));
    let session = demo.join("demo.lipmap.json");
    let model = dir.join("speech.json");
    let out = lipmap(&[
        "speech",
        "train",
        s(&session),
        "--states",
        "8",
        "--mixtures",
        "1",
        "--context",
        "1",
        "--out",
        s(&model),
    ]);
    assert!(out.status.success(), "train: {}", text(&out.stderr));
    let said = text(&out.stdout);
    assert!(said.contains("trained on 3 clips"), "{said}");
    // 3 sentences (under 200 frames) are too few for 8 states of 43-dimensional Gaussians:
    // shrunk, and said in one line.
    let states: usize = said
        .split(" states × 1 mixtures")
        .next()
        .and_then(|head| head.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no model size in {said}"));
    assert!((2..8).contains(&states), "{said}");
    let stderr = text(&out.stderr);
    let warned: Vec<&str> = stderr.lines().filter(|l| l.contains("too few for 8 states")).collect();
    assert_eq!(warned.len(), 1, "{stderr}");
    assert!(warned[0].contains(&format!("training {states} × 1 instead")), "{}", warned[0]);
    // Why Baum–Welch stopped, and why there is no held-out estimate.
    assert!(said.contains("Baum-Welch from k-means: stopped"), "{said}");
    assert!(said.contains("no held-out estimate: fewer than 10 clips"), "{said}");
    (session, model)
}

fn first_voice(session: &Path) -> PathBuf {
    let s = lipmap::session::Session::load(session).unwrap();
    s.clips[0].audio.as_ref().expect("demo clips carry audio").file.clone()
}

#[test]
fn train_eval_animate_and_every_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let (session, model) = trained(dir.path());

    let out = lipmap(&["speech", "eval", s(&model), s(&session)]);
    assert!(out.status.success(), "eval: {}", text(&out.stderr));
    let table = text(&out.stdout);
    for want in ["AV-HMM", "linear baseline", "RMSE per phoneme", "fitted head"] {
        assert!(table.contains(want), "no `{want}` in\n{table}");
    }
    let json = lipmap(&["speech", "eval", s(&model), s(&session), "--json"]);
    let tables: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let scores = &tables["scores"];
    assert!(scores["title"].as_str().unwrap().starts_with("Visual parameters"), "{scores}");
    let acc = scores["rows"][0]["ACC"].as_f64().unwrap();
    assert!((-1.0..=1.0).contains(&acc), "ACC {acc}");
    // Each clip's estimate adapted to the speaker from its other clips, or not when asked.
    assert!(table.contains("adapted to the session's speaker from the visual truth"), "{table}");
    let plain = lipmap(&["speech", "eval", s(&model), s(&session), "--no-speaker-adaptation"]);
    assert!(text(&plain.stdout).contains("not adapted to the session's speaker"));
    // Scored on its own training clips: said on stderr and in the table.
    assert!(table.contains("NOT held out: 3 of the 3 clips"), "{table}");
    assert!(text(&out.stderr).contains("3 of the 3 clips scored were in the model's training set"));
    session_names_the_model(&session, &model);

    // Animate from the demo voice, and from a stereo 48 kHz copy (resampled, mixed).
    let voice = first_voice(&session);
    let anim = dir.path().join("anim");
    let animate = |more: &[&str]| {
        let mut args = vec!["speech", "animate", s(&model), "--audio", s(&voice)];
        args.extend_from_slice(more);
        lipmap(&args)
    };
    let out = animate(&["--out", s(&anim)]);
    assert!(out.status.success(), "animate: {}", text(&out.stderr));
    let mouth = lipmap::io::npy_model::read_npy(&anim.join("mouth.npy")).unwrap();
    let coefficients = lipmap::io::npy_model::read_npy(&anim.join("coefficients.npy")).unwrap();
    assert!(!anim.join("shapes.npy").exists(), "whole meshes only with --shapes");
    let audio = lipmap::io::wav::read_wav(&voice).unwrap();
    let frames = (audio.samples.len() as f64 / 16_000.0 * 24.0) as usize;
    assert!(mouth.shape[0].abs_diff(frames) <= 1, "{:?} vs {frames}", mouth.shape);
    assert_eq!(mouth.shape[1], 3 * 23);
    assert_eq!(coefficients.shape[0], mouth.shape[0]);
    assert!(mouth.data.iter().chain(&coefficients.data).all(|v| v.is_finite()));
    let out = animate(&["--shapes", "--out", s(&anim)]);
    assert!(out.status.success(), "animate --shapes: {}", text(&out.stderr));
    let shapes = lipmap::io::npy_model::read_npy(&anim.join("shapes.npy")).unwrap();
    assert_eq!(shapes.shape[0], mouth.shape[0]);
    // The mouth columns are the shapes' mouth vertices.
    let model_json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
    let v0 = model_json["head"]["mouth_vertices"][0].as_u64().unwrap() as usize;
    assert!((shapes.data[3 * v0] - mouth.data[0]).abs() < 1e-4);

    // The same voice carried onto a head (the demo's own OBJ and map): one row per frame of
    // the animation, the head's vertex count wide, and the mouth moves.
    let demo = session.parent().unwrap();
    let on_head = dir.path().join("on_head");
    let out = animate(&[
        "--head",
        s(&demo.join("head.obj")),
        "--mapping",
        s(&demo.join("head_map.toml")),
        "--out",
        s(&on_head),
    ]);
    assert!(out.status.success(), "animate --head: {}", text(&out.stderr));
    let head = lipmap::io::npy_model::read_npy(&on_head.join("head_shapes.npy")).unwrap();
    let mesh = lipmap::io::obj::read_obj(&demo.join("head.obj")).unwrap();
    assert_eq!(head.shape, vec![mouth.shape[0], 3 * mesh.vertices.len()]);
    let width = head.shape[1];
    let first = &head.data[..width];
    let moved = head
        .data
        .chunks(width)
        .map(|row| row.iter().zip(first).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max));
    assert!(moved.fold(0.0, f64::max) > 1e-3, "the transferred head never moves");

    // `validate` knows the model, the WAV and a synthesized-motion CSV by their content.
    let motion = dir.path().join("synth.csv");
    let m = lipmap::io::motion_csv::VertexMotion {
        vertices: vec![3, 9],
        frames: vec![vec![lipmap::math::Point3::new(1.0, 2.0, 3.0); 2]; 4],
    };
    std::fs::write(&motion, lipmap::io::motion_csv::format_motion_csv(&m)).unwrap();
    let out = lipmap(&["validate", s(&model), s(&voice), s(&motion)]);
    let said = text(&out.stdout);
    assert!(out.status.success(), "validate: {said}{}", text(&out.stderr));
    let states = lipmap::workflow::speech::load_speech_model(&model).unwrap().speech.hmm.n_states();
    for want in [
        format!("ok (speech model, {states} states at 24 fps"),
        "ok (audio, ".into(),
        "ok (synthesized motion, 4 frames of 2 vertices)".into(),
    ] {
        assert!(said.contains(&want), "no `{want}` in\n{said}");
    }

    let stereo = dir.path().join("stereo48k.wav");
    write_stereo(&stereo, &lipmap::speech::resample(&audio.samples, 16_000.0, 48_000.0).unwrap());
    let out = lipmap(&["speech", "animate", s(&model), "--audio", s(&stereo), "--out", s(&anim)]);
    assert!(out.status.success(), "stereo 48 kHz: {}", text(&out.stderr));

    bad_wavs(dir.path(), &model, &voice, &anim);
    bad_models(dir.path(), &model, &session);
    short_audio(dir.path(), &session);
}

/// A clip whose audio is one sample long for its 60-odd frames is refused by training (exit
/// 2, one line naming the clip and the margin) and by import.
fn short_audio(dir: &Path, session: &Path) {
    let one = dir.join("one_sample.wav");
    write_wav(&one, &[0.1], 16_000).unwrap();
    let mut short = lipmap::session::Session::load(session).unwrap();
    short.clips[0].audio.as_mut().unwrap().file = one.clone();
    let name = short.clips[0].name.clone();
    let path = session.with_file_name("short.lipmap.json");
    short.save(&path).unwrap();
    let out = lipmap(&["speech", "train", s(&path), "--out", s(&dir.join("short.json"))]);
    assert_eq!(out.status.code(), Some(2));
    let e = one_error(&out);
    assert!(
        e.contains(&format!("clip `{name}`")) && e.contains("25 %") && e.contains("one_sample.wav"),
        "{e}"
    );
    let out = lipmap(&["import", s(&path), "--audio", s(&one), "--clip", &name]);
    let e = one_error(&out);
    assert!(e.contains("25 %"), "{e}");
}

/// Training (and scoring) recorded the model in the session; the TUI's charts drive the
/// clip's head with it, and say why when they cannot (no model named, no audio).
fn session_names_the_model(session: &Path, model: &Path) {
    use lipmap::tui::Action;
    use lipmap::workflow::speech_session::drive_clip_with_session_model;
    let mut s = lipmap::session::Session::load(session).unwrap();
    let named = s.speech_model.clone().expect("speech train records the model");
    assert_eq!(named, std::path::absolute(model).unwrap());
    let n = s.clips[0].tracked_summary().frames;
    match lipmap::tui::jobs::speech_for_tui(&mut s.clone(), 0) {
        Action::SpeechReady { series } => {
            let names: Vec<&str> = series.iter().map(|(m, _)| m.as_str()).collect();
            assert!(names.contains(&"W") && names.contains(&"H"), "{names:?}");
            for (m, pts) in &series {
                assert!(pts.len() * 10 >= n * 9, "{m}: {} points of {n} frames", pts.len());
                // Min–max normalised like the video's and the fitted head's series.
                assert!(pts.iter().all(|p| (-1e-9..=1.0 + 1e-9).contains(&p.1)), "{m}");
            }
        }
        other => panic!("no speech-driven series: {other:?}"),
    }
    let mut unnamed = s.clone();
    unnamed.speech_model = None;
    let e = drive_clip_with_session_model(&mut unnamed, 0).unwrap_err().to_string();
    assert!(e.contains("names no speech model") && e.contains("speech train"), "{e}");
    s.clips[0].audio = None;
    let e = drive_clip_with_session_model(&mut s, 0).unwrap_err().to_string();
    assert_eq!(e, "the clip has no audio");
}

/// `samples` as a 2-channel 48 kHz 16-bit WAV (both channels the same).
fn write_stereo(path: &Path, samples: &[f32]) {
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: 48_000,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    for v in samples {
        let x = (v.clamp(-1.0, 1.0) * 32767.0) as i16;
        w.write_sample(x).unwrap();
        w.write_sample(x).unwrap();
    }
    w.finalize().unwrap();
}

fn bad_wavs(dir: &Path, model: &Path, voice: &Path, anim: &Path) {
    let animate = |wav: &Path| {
        one_error(&lipmap(&["speech", "animate", s(model), "--audio", s(wav), "--out", s(anim)]))
    };
    let empty = dir.join("empty.wav");
    std::fs::write(&empty, b"").unwrap();
    let e = animate(&empty);
    assert!(e.contains("empty.wav"), "{e}");

    let truncated = dir.join("truncated.wav");
    let bytes = std::fs::read(voice).unwrap();
    std::fs::write(&truncated, &bytes[..30]).unwrap();
    let e = animate(&truncated);
    assert!(e.contains("truncated.wav"), "{e}");

    let slow = dir.join("8k.wav");
    write_wav(&slow, &vec![0.1; 8000], 8000).unwrap();
    let e = animate(&slow);
    assert!(e.contains("8k.wav") && e.contains("8000 Hz"), "{e}");

    let e = animate(&dir.join("missing.wav"));
    assert!(e.contains("missing.wav"), "{e}");
}

fn bad_models(dir: &Path, model: &Path, session: &Path) {
    let eval = |m: &Path| one_error(&lipmap(&["speech", "eval", s(m), s(session)]));
    // A session file is not a model.
    let e = eval(session);
    assert!(e.contains("not a speech model"), "{e}");

    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(model).unwrap()).unwrap();
    let edited = |name: &str, edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = file.clone();
        edit(&mut v);
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
        p
    };
    let e = eval(&edited("v99.json", &|v| v["version"] = 99.into()));
    assert!(e.contains("v99.json") && e.contains("version 99"), "{e}");

    // A model trained on 25 fps features refuses a 24 fps session, naming the field.
    let fps25 = edited("fps25.json", &|v| {
        v["speech"]["features"]["mfcc"]["frame_rate"] = 25.0.into();
    });
    let e = eval(&fps25);
    assert!(e.contains("frame rate (fps) = 25") && e.contains("= 24"), "{e}");

    // Damaged numbers: a covariance that is not positive definite, absurd values, a
    // transition row that is not a distribution; each named by its field.
    let broken = edited("broken.json", &|v| {
        // nalgebra writes a matrix as [column-major data, rows, columns].
        v["speech"]["hmm"]["states"][0][0]["gaussian"]["cov"][0][0] = (-1.0).into();
    });
    let e = eval(&broken);
    assert!(e.contains("broken.json") && e.contains("hmm.states[0][0]"), "{e}");
    for (name, edit, field) in [
        (
            "mean.json",
            &(|v: &mut serde_json::Value| v["speech"]["visual"]["mean"][0][0] = 1e308.into())
                as &dyn Fn(&mut serde_json::Value),
            "speech.visual.mean[0]",
        ),
        (
            "gauss.json",
            &|v: &mut serde_json::Value| {
                v["speech"]["hmm"]["states"][1][0]["gaussian"]["mean"][0][2] = 1e300.into()
            },
            "hmm.states[1][0].gaussian.mean[2]",
        ),
        (
            "neutral.json",
            &|v: &mut serde_json::Value| v["head"]["neutral_identity"][0] = (-1e12).into(),
            "head.neutral_identity[0]",
        ),
        (
            "baseline.json",
            &|v: &mut serde_json::Value| v["speech"]["baseline"]["weights"][0][3] = 1e307.into(),
            "speech.baseline.weights",
        ),
        (
            "rows.json",
            &|v: &mut serde_json::Value| v["speech"]["hmm"]["transitions"][0][0] = 7.0.into(),
            "hmm.transitions row 0",
        ),
    ] {
        let e = eval(&edited(name, edit));
        assert!(e.contains(name) && e.contains(field), "{name}: {e}");
        let e = one_error(&lipmap(&[
            "speech",
            "animate",
            s(&dir.join(name)),
            "--audio",
            s(&first_voice(session)),
            "--out",
            s(&dir.join("never")),
        ]));
        assert!(e.contains(field), "{name}: {e}");
    }
    assert!(!dir.join("never").exists());

    // A session whose clips have no audio trains nothing.
    let mut silent = lipmap::session::Session::load(session).unwrap();
    silent.clips.iter_mut().for_each(|c| c.audio = None);
    let silent_path = session.with_file_name("silent.lipmap.json");
    silent.save(&silent_path).unwrap();
    let out = lipmap(&["speech", "train", s(&silent_path), "--out", s(&dir.join("x.json"))]);
    let lines = text(&out.stderr);
    assert!(!out.status.success());
    assert!(lines.contains("no clip with audio"), "{lines}");
}
