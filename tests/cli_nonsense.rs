//! Nonsense refused where it enters, through the binary: maps on one vertex, empty maps,
//! left/right swapped maps and heads that are not surfaces (for `map check`, `import`, `new`
//! and `transfer`, with `--accept-map-warnings` to go on); sessions whose model, head, map or
//! audio file is missing or whose audio rate is 0 (`validate`); phone files with empty
//! labels, phones of no or negative length and a thousand phones of a nanosecond; a damaged
//! data file of a session. Each is exit 2 with one line naming the file (and line or field).

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{lipmap, s, text};

/// The one error line of a run that must exit 2.
fn refused(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(2), "expected exit 2; stdout: {}", text(&out.stdout));
    let lines: Vec<String> =
        text(&out.stderr).lines().filter(|l| !l.trim().is_empty()).map(String::from).collect();
    assert_eq!(lines.len(), 1, "not one line: {lines:?}");
    lines[0].clone()
}

/// The one line `lipmap validate` prints for a file that fails (it exits 2).
fn invalid(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(2), "expected exit 2: {}", text(&out.stdout));
    let lines: Vec<String> = text(&out.stdout).lines().map(String::from).collect();
    assert_eq!(lines.len(), 1, "not one line: {lines:?}");
    lines[0].clone()
}

fn ok(out: &Output) {
    assert!(out.status.success(), "failed: {}", text(&out.stderr));
}

/// A one-sentence demo without frames: its session, model and the model's map.
fn demo(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let out_dir = dir.join("demo");
    ok(&lipmap(&["demo", "--no-tui", "--no-frames", "--sentences", "1", "--out", s(&out_dir)]));
    (out_dir.join("demo.lipmap.json"), out_dir.join("model.lmm"), out_dir.join("head_map.toml"))
}

/// An eos TOML map of iBUG landmark `l` (1-based) to `vertex(l)`.
fn write_map(path: &Path, landmarks: impl Iterator<Item = usize>, vertex: impl Fn(usize) -> usize) {
    let mut t = String::from("[landmark_mappings]\n");
    for l in landmarks {
        t.push_str(&format!("{l} = {}\n", vertex(l)));
    }
    std::fs::write(path, t).unwrap();
}

/// The demo map with every mirror pair (jaw, brows, eyes, nostrils, lips) exchanged.
fn swapped(map: &Path, out: &Path) {
    let m = lipmap::io::landmark_map_toml::read_landmark_map(map).unwrap();
    let mut to = m.to_vertex.clone();
    for (r, l) in lipmap::model::map_check::MIRROR_PAIRS {
        if let (Some(a), Some(b)) = (m.vertex(r), m.vertex(l)) {
            to.insert(r, b);
            to.insert(l, a);
        }
    }
    write_map(out, to.keys().map(|k| k + 1), |l| to[&(l - 1)]);
}

#[test]
fn maps_on_one_vertex_empty_or_swapped_are_refused_by_import_new_and_transfer() {
    let dir = tempfile::tempdir().unwrap();
    let (session, model, map) = demo(dir.path());
    let one_vertex = dir.path().join("one_vertex.toml");
    write_map(&one_vertex, 1..=68, |_| 5);
    let empty = dir.path().join("empty.toml");
    std::fs::write(&empty, "[landmark_mappings]\n").unwrap();
    let mirror = dir.path().join("swapped.toml");
    swapped(&map, &mirror);

    for (file, want) in [
        (&one_vertex, "landmarks 1, 2, 3"),
        (&empty, "it maps no landmark"),
        (&mirror, "swapped left/right"),
    ] {
        let e = refused(&lipmap(&["import", s(&session), "--mapping", s(file)]));
        assert!(e.contains(s(file)) && e.contains(want), "{e}");
        assert!(e.contains("--accept-map-warnings"), "{e}");
    }
    // Nothing changed; accepted, it goes on with the problems said.
    let before = lipmap::session::Session::load(&session).unwrap();
    assert_eq!(before.landmark_map.file.as_deref(), Some(map.as_path()));
    let out =
        lipmap(&["import", s(&session), "--mapping", s(&one_vertex), "--accept-map-warnings"]);
    ok(&out);
    assert!(text(&out.stderr).contains("share vertex 5"), "{}", text(&out.stderr));
    ok(&lipmap(&["import", s(&session), "--mapping", s(&map)]));

    // `new` takes the same checks.
    let clip = &before.clips[0];
    let landmarks = clip.landmarks_file.clone().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    let n = clip.tracked_summary().last_frame.unwrap() + 1;
    for k in 0..n {
        image::RgbImage::new(64, 48).save(frames.join(format!("f{k:04}.png"))).unwrap();
    }
    let new = |name: &str, mapping: &Path, more: &[&str]| {
        let path = dir.path().join(name);
        let mut args = vec!["new", s(&path), "--frames", s(&frames), "--landmarks"];
        args.extend([s(&landmarks), "--model", s(&model), "--mapping", s(mapping), "--fps", "25"]);
        args.extend(more);
        lipmap(&args)
    };
    let e = refused(&new("a.lipmap.json", &empty, &[]));
    assert!(e.contains("empty.toml") && e.contains("it maps no landmark"), "{e}");
    let e = refused(&new("b.lipmap.json", &one_vertex, &[]));
    assert!(e.contains("one_vertex.toml") && e.contains("share vertex 5"), "{e}");
    assert!(!dir.path().join("b.lipmap.json").exists());
    ok(&new("c.lipmap.json", &one_vertex, &["--accept-map-warnings"]));

    // `transfer` onto the demo head with the swapped map: every frame would be mirrored.
    let head = session.with_file_name("head.obj");
    let out_dir = dir.path().join("out");
    let transfer = |mapping: &Path, more: &[&str]| {
        let mut args = vec!["transfer", s(&session), "--head", s(&head), "--mapping"];
        args.extend([s(mapping), "--out", s(&out_dir)]);
        args.extend(more);
        lipmap(&args)
    };
    let e = refused(&transfer(&mirror, &[]));
    assert!(e.contains("swapped.toml") && e.contains("swapped left/right"), "{e}");
    assert!(!out_dir.exists(), "nothing written");
    // Accepted, the map check no longer stops it (the transfer itself may still find the
    // mirrored map unusable, and says so in its own words).
    let out = transfer(&mirror, &["--accept-map-warnings"]);
    assert!(!text(&out.stderr).contains("fails the checks"), "{}", text(&out.stderr));
}

#[test]
fn map_check_refuses_a_head_that_is_not_a_surface() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("map.toml");
    write_map(&map, 1..=68, |l| l - 1);
    // On the twisted cubic (t, t², t³) no three vertices are collinear.
    let cubic = |k: usize| {
        let t = k as f64 / 10.0;
        [t, t * t, t * t * t]
    };
    let heads: [(&str, String, &str); 3] = [
        ("no_faces.obj", vertices(cubic), "has no faces"),
        (
            "line.obj",
            vertices(|k| [k as f64, 2.0 * k as f64, 0.0]) + &faces(),
            "every one of the mesh's 66 faces has zero area",
        ),
        (
            "slivers.obj",
            vertices(cubic) + "v 0 0 0\nv 1 1 1\nv 2 2 2\n" + &faces() + "f 69 70 71\nf 71 70 69\n",
            "2 of the mesh's 68 faces have zero area",
        ),
    ];
    for (name, obj, want) in heads {
        let head = dir.path().join(name);
        std::fs::write(&head, obj).unwrap();
        let path = dir.path().join(format!("{name}.lipmap.json"));
        let mut session = lipmap::session::Session::new(&path);
        session.head_mesh = Some(head.clone());
        session.landmark_map.file = Some(map.clone());
        session.save(&path).unwrap();
        let out = lipmap(&["map", "check", s(&path)]);
        let e = refused(&out);
        assert_eq!(e, "lipmap: the landmark map has problems");
        let said = text(&out.stdout);
        assert!(said.contains(want) && said.contains(s(&head)), "{name}: {said}");
    }
}

/// 68 OBJ vertices from `at(k)`.
fn vertices(at: impl Fn(usize) -> [f64; 3]) -> String {
    (0..68).map(at).map(|[x, y, z]| format!("v {x} {y} {z}\n")).collect()
}

/// A strip of triangles over the 68 vertices.
fn faces() -> String {
    (1..=66).map(|k| format!("f {k} {} {}\n", k + 1, k + 2)).collect()
}

#[test]
fn validate_names_a_missing_file_an_absurd_field_and_a_damaged_data_file() {
    let dir = tempfile::tempdir().unwrap();
    let (session, model, map) = demo(dir.path());
    let out = lipmap(&["validate", s(&session)]);
    ok(&out);
    assert!(text(&out.stdout).contains("1 clip, "), "{}", text(&out.stdout));

    let variant = |name: &str, edit: &dyn Fn(&mut lipmap::session::Session)| {
        let mut s = lipmap::session::Session::load(&session).unwrap();
        edit(&mut s);
        let path = session.with_file_name(name);
        s.save(&path).unwrap();
        path
    };
    let gone = dir.path().join("gone");
    for (name, field, edit) in [
        (
            "m.lipmap.json",
            "model",
            &(|s: &mut lipmap::session::Session| {
                s.model.as_mut().unwrap().path = gone.join("model.lmm")
            }) as &dyn Fn(&mut lipmap::session::Session),
        ),
        ("h.lipmap.json", "head_mesh", &|s| s.head_mesh = Some(gone.join("head.obj"))),
        ("p.lipmap.json", "landmark_map", &|s| s.landmark_map.file = Some(gone.join("map.toml"))),
        ("a.lipmap.json", "audio", &|s| {
            s.clips[0].audio.as_mut().unwrap().file = gone.join("v.wav")
        }),
    ] {
        let path = variant(name, edit);
        let e = invalid(&lipmap(&["validate", s(&path)]));
        assert!(e.contains(name) && e.contains(field) && e.contains(s(&gone)), "{e}");
    }
    // An audio rate of 0 (edited by hand): refused when the session is read.
    let zero = session.with_file_name("z.lipmap.json");
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&session).unwrap()).unwrap();
    json["clips"][0]["audio"]["sample_rate"] = 0.into();
    std::fs::write(&zero, serde_json::to_vec(&json).unwrap()).unwrap();
    let e = invalid(&lipmap(&["validate", s(&zero)]));
    assert!(e.contains("z.lipmap.json") && e.contains("audio: sample_rate 0 Hz"), "{e}");

    // A data file damaged on disk: named with its record and field, by `validate` and by a
    // command that reaches the clip.
    let loaded = lipmap::session::Session::load(&session).unwrap();
    let track = loaded.clips[0].tracked_file().unwrap();
    let mut bytes = std::fs::read(&track).unwrap();
    // The first record's first x (after the 16-byte head, the JSON header, the frame number,
    // the flags and a timestamp or confidence when flagged) made infinite: exponent all ones.
    let head = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let flags = bytes[16 + head + 4];
    let xy =
        16 + head + 5 + if flags & 2 != 0 { 8 } else { 0 } + if flags & 4 != 0 { 4 } else { 0 };
    bytes[xy + 6] |= 0xf0;
    bytes[xy + 7] = 0x7f;
    std::fs::write(&track, &bytes).unwrap();
    let named = |e: &str| e.contains(s(&track)) && e.contains("frame record") && e.contains("xy");
    let e = invalid(&lipmap(&["validate", s(&session)]));
    assert!(named(&e), "{e}");
    let out = lipmap(&["eval", s(&session)]);
    assert_eq!(out.status.code(), Some(2));
    let e = text(&out.stderr);
    assert!(named(e.lines().last().unwrap_or_default()), "{e}");
    let _ = (model, map);
}

#[test]
fn phone_files_with_empty_labels_or_phones_of_no_length_are_refused_with_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let many: String =
        (0..1000).map(|k| format!("{},{},AA\n", k as f64 * 1e-9, (k + 1) as f64 * 1e-9)).collect();
    for (name, body, want) in [
        (
            "empty_label.csv",
            "0,0.1,B\n0.1,0.2,\n".to_string(),
            ":3: the phone at 0.1–0.2 s has an empty label",
        ),
        ("zero.csv", "0,0.1,B\n0.1,0.1,AA\n".into(), ":3: phone `AA` (0.1–0.1 s) lasts no time"),
        (
            "negative.csv",
            "0,0.1,B\n0.2,0.15,AA\n".into(),
            ":3: phone `AA` (0.2–0.15 s) ends before it starts",
        ),
        ("nanoseconds.csv", many, ":2: phone `AA` (0–0.000000001 s) lasts 1e-9 s"),
    ] {
        let file = dir.path().join(name);
        std::fs::write(&file, format!("start,end,phone\n{body}")).unwrap();
        let e = invalid(&lipmap(&["validate", s(&file)]));
        assert!(e.contains(&format!("{}{want}", file.display())), "{e}");
    }
    // A TextGrid's empty interval is a silence, not a fault; a zero-length one is refused.
    let grid = |xmax2: f64| {
        format!(
            "File type = \"ooTextFile\"\nObject class = \"TextGrid\"\n\nxmin = 0\nxmax = 0.3\ntiers? <exists>\nsize = 1\nitem []:\n    item [1]:\n        class = \"IntervalTier\"\n        name = \"phones\"\n        xmin = 0\n        xmax = 0.3\n        intervals: size = 2\n        intervals [1]:\n            xmin = 0\n            xmax = 0.1\n            text = \"\"\n        intervals [2]:\n            xmin = 0.1\n            xmax = {xmax2}\n            text = \"AA\"\n"
        )
    };
    let tg = dir.path().join("ok.TextGrid");
    std::fs::write(&tg, grid(0.3)).unwrap();
    ok(&lipmap(&["validate", s(&tg)]));
    std::fs::write(&tg, grid(0.1)).unwrap();
    let e = invalid(&lipmap(&["validate", s(&tg)]));
    assert!(e.contains("tier `phones`, interval 2: phone `AA` (0.1–0.1 s) lasts no time"), "{e}");
}

/// A closed stderr (`lipmap fit S 2>&1 | head -2`) is no more an error than a closed stdout:
/// a command that fails keeps its exit code 2 and one that writes notes on stderr finishes
/// its work with 0, where a panic on the write ended both with 101.
#[test]
fn a_closed_stderr_changes_no_exit_code() {
    let run = |args: &[&str]| {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        std::process::Command::new(env!("CARGO_BIN_EXE_lipmap"))
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(writer)
            .status()
            .unwrap()
    };
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.lipmap.json");
    assert_eq!(run(&["fit", s(&missing)]).code(), Some(2));
    let out = dir.path().join("demo");
    let status = run(&["demo", "--no-tui", "--no-frames", "--sentences", "1", "--out", s(&out)]);
    assert_eq!(status.code(), Some(0));
    assert!(out.join("demo.lipmap.json").is_file());
}
