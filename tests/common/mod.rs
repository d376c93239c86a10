//! Inputs shared by the command-line tests: the carphone clip's frames (read in place) and
//! its first frames of dlib landmarks written as a lipmap CSV into a temp folder, with eos's
//! SFM model files (`None`, with the skip notice, when ../shared is absent); and a one-sentence
//! demo session made by the lipmap binary.

// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

pub mod tmux;

use lipmap::io::landmark_format::{LandmarkFormat, read_track, write_track};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub struct Carphone {
    /// Keeps the temp folder alive as long as the inputs.
    pub _dir: tempfile::TempDir,
    pub root: PathBuf,
    pub frames: PathBuf,
    /// The first `n_frames` frames of dlib's landmarks, as a lipmap CSV in `root`.
    pub landmarks: PathBuf,
    /// eos's share folder (sfm_shape_3448.bin, its blendshapes, ibug_to_sfm.txt).
    pub eos: PathBuf,
}

pub fn carphone(n_frames: usize) -> Option<Carphone> {
    let frames = lipmap::testdata::shared("data/carphone/frames")?;
    let pts = lipmap::testdata::shared("data/carphone/dlib68_pts")?;
    let eos = lipmap::testdata::shared("peer/eos/share")?;
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let mut track = read_track(&pts).unwrap();
    track.frames.truncate(n_frames);
    let landmarks = root.join("carphone.csv");
    write_track(&track, &landmarks, LandmarkFormat::LipmapCsv).unwrap();
    Some(Carphone { _dir: dir, root, frames, landmarks, eos })
}

/// The MakeHuman head (`../shared/data/makehuman/base.obj`, `None` with a skip notice when
/// absent): its folder, mesh, skin mask and the repository's hand map (mouth corners
/// completed).
pub fn makehuman() -> Option<(PathBuf, lipmap::model::Mesh, Vec<bool>, lipmap::model::LandmarkMap)>
{
    let Some(dir) = lipmap::testdata::shared("data/makehuman") else {
        eprintln!("skipped: ../shared/data/makehuman is absent");
        return None;
    };
    let path = dir.join("base.obj");
    let mesh = lipmap::io::obj::read_obj(&path).unwrap();
    let skin = lipmap::io::obj::labelable_vertices(&path).unwrap().unwrap();
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let map = lipmap::io::landmark_map_toml::read_landmark_map(&fixture)
        .unwrap()
        .with_commissures_completed();
    Some((dir, mesh, skin, map))
}

/// Distance from `p` to the polyline through `points`.
pub fn to_polyline(p: &lipmap::math::Point3, points: &[lipmap::math::Point3]) -> f64 {
    points
        .windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let t = ((p - w[0]).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
            (p - (w[0] + t * d)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// How many of `map`'s landmarks share a vertex with an earlier one (0: each its own).
pub fn vertices_used_twice(map: &lipmap::model::LandmarkMap) -> usize {
    let used: std::collections::BTreeSet<usize> = map.to_vertex.values().copied().collect();
    map.to_vertex.len() - used.len()
}

/// The rotation by `deg` degrees about `axis` (any length).
pub fn rotation_deg(axis: lipmap::math::Vector3, deg: f64) -> lipmap::math::Matrix3 {
    *nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
        .matrix()
}

/// The vertices of MakeHuman's `base.obj` in `dir` whose triangles hide what is behind them.
pub fn makehuman_occluders(dir: &Path) -> Vec<bool> {
    lipmap::io::obj::occluding_vertices(&dir.join("base.obj")).unwrap().unwrap()
}

/// The rows of `lipmap saqp cv --json`'s summary, one per synthesizer: its kept calibration.
pub fn synth_rows(json: &[u8]) -> Vec<serde_json::Value> {
    let tables: serde_json::Value = serde_json::from_slice(json).unwrap();
    let summary = &tables["summary"];
    assert!(summary["title"].as_str().unwrap().starts_with("Predicted vs ground-truth"));
    let rows = summary["rows"].as_array().expect("the synthesizer table");
    rows.iter().filter(|r| r["kept"] == "yes").cloned().collect()
}

/// `lipmap demo --no-tui --sentences 1 --out DIR/demo` run by the binary under test; returns
/// the demo session's path.
pub fn demo_session(dir: &Path) -> PathBuf {
    let demo = dir.join("demo");
    let st = Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .args(["demo", "--no-tui", "--sentences", "1", "--out"])
        .arg(&demo)
        .output()
        .unwrap();
    assert!(st.status.success(), "demo failed: {}", String::from_utf8_lossy(&st.stderr));
    demo.join("demo.lipmap.json")
}

/// Runs the lipmap binary under test with `args`.
pub fn lipmap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lipmap")).args(args).output().unwrap()
}

/// A run's output bytes as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
