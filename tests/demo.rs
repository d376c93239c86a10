//! End-to-end checks of the built-in demo speaker on reduced options (few frames, small
//! images) so they stay fast in the dev profile: determinism, the truth's phonetics, the
//! injected errors, the speakers' facial-index classes, and the renders.

use lipmap::demo::{DemoOptions, DemoOutput, generate};
use lipmap::io::track_csv::read_track_csv;
use lipmap::math::Point2;
use lipmap::measure::{BoundsTable, FacialIndex, IndexClass, facial_indices};
use std::path::Path;

fn small(dir: &Path) -> DemoOptions {
    DemoOptions {
        out_dir: dir.to_path_buf(),
        sentences: 2,
        width: 240,
        height: 160,
        write_model: false,
        side_view: true,
        max_frames: Some(40),
        ..DemoOptions::default()
    }
}

/// Reads truth.csv into (phone, w, h, p) rows.
fn truth_rows(path: &Path) -> Vec<(String, f64, f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (cp, cw, ch, cpp) = (col("phone"), col("w"), col("h"), col("p"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[cp].to_string(),
                f[cw].parse().unwrap(),
                f[ch].parse().unwrap(),
                f[cpp].parse().unwrap(),
            )
        })
        .collect()
}

fn run(dir: &Path, opts: DemoOptions) -> DemoOutput {
    generate(&DemoOptions { out_dir: dir.to_path_buf(), ..opts }).unwrap()
}

#[test]
fn same_seed_gives_the_same_bytes() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let opts = DemoOptions { write_frames: false, ..small(a.path()) };
    let oa = run(a.path(), opts.clone());
    let ob = run(b.path(), opts.clone());
    for (ca, cb) in oa.speakers[0].clips.iter().zip(&ob.speakers[0].clips) {
        for (pa, pb) in [
            (&ca.truth_csv, &cb.truth_csv),
            (&ca.tracked_csv, &cb.tracked_csv),
            (&ca.errors_csv, &cb.errors_csv),
            (&ca.phones_csv, &cb.phones_csv),
        ] {
            assert_eq!(std::fs::read(pa).unwrap(), std::fs::read(pb).unwrap(), "{}", pa.display());
        }
    }
    let c = tempfile::tempdir().unwrap();
    let oc = run(c.path(), DemoOptions { seed: opts.seed + 1, ..opts });
    let ta = std::fs::read(&oa.speakers[0].clips[0].tracked_csv).unwrap();
    let tc = std::fs::read(&oc.speakers[0].clips[0].tracked_csv).unwrap();
    assert_ne!(ta, tc, "another seed gives another speaker track");
}

#[test]
fn truth_follows_the_phones() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        DemoOptions { write_frames: false, sentences: 4, max_frames: None, ..small(dir.path()) },
    );
    let mut bilabial_h = Vec::new();
    let mut open_h = Vec::new();
    let mut rounded_p = Vec::new();
    let mut spread_p = Vec::new();
    for clip in &out.speakers[0].clips {
        let rows = truth_rows(&clip.truth_csv);
        assert_eq!(rows.len(), clip.n_frames);
        // Silence at the start: the neutral, closed mouth.
        assert!(rows[0].2 < 0.02, "first frame H {}", rows[0].2);
        for (phone, _w, h, p) in &rows {
            let base = phone.trim_end_matches(|c: char| c.is_ascii_digit());
            match base {
                "B" | "P" | "M" => bilabial_h.push(*h),
                "AA" | "AY" | "AH" | "AE" | "EH" => open_h.push(*h),
                _ => {}
            }
            match base {
                "UW" | "W" | "OW" => rounded_p.push(*p),
                "IY" | "EY" | "IH" => spread_p.push(*p),
                _ => {}
            }
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max_open = open_h.iter().copied().fold(0.0, f64::max);
    assert!(!open_h.is_empty() && max_open > 0.15, "open vowels open the mouth: {open_h:?}");
    if !bilabial_h.is_empty() {
        let min_b = bilabial_h.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min_b < 0.1 * max_open, "bilabials close the mouth: {bilabial_h:?}");
        assert!(mean(&bilabial_h) < mean(&open_h));
    }
    if !rounded_p.is_empty() && !spread_p.is_empty() {
        assert!(mean(&rounded_p) > mean(&spread_p), "rounded vowels protrude");
    }
}

#[test]
fn injected_errors_are_recorded_and_present_in_the_tracked_landmarks() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(dir.path(), DemoOptions { write_frames: false, ..small(dir.path()) });
    for clip in &out.speakers[0].clips {
        assert!(!clip.injected_errors.is_empty());
        let tracked = read_track_csv(&clip.tracked_csv).unwrap();
        let truth = read_track_csv(&clip.true_csv).unwrap();
        let errors_text = std::fs::read_to_string(&clip.errors_csv).unwrap();
        assert_eq!(errors_text.lines().count(), 1 + clip.injected_errors.len());
        let worst = |f: usize| {
            let (a, b) = (tracked.get(f).unwrap(), truth.get(f).unwrap());
            a.points
                .iter()
                .zip(&b.points)
                .map(|(p, q)| (p.pos() - q.pos()).norm())
                .fold(0.0, f64::max)
        };
        for e in &clip.injected_errors {
            assert!(worst(e.frame) > 3.5, "error at frame {} not visible", e.frame);
        }
        // Elsewhere only the tracker noise (σ 0.7 px) remains.
        let flagged: Vec<usize> = clip.injected_errors.iter().map(|e| e.frame).collect();
        for f in 0..clip.n_frames {
            if !flagged.contains(&f) {
                assert!(worst(f) < 4.0, "frame {f} has an unrecorded error");
            }
        }
    }
}

#[test]
fn speakers_fall_in_the_classes_they_were_made_for() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        DemoOptions {
            write_frames: false,
            speakers: 5,
            sentences: 1,
            max_frames: Some(3),
            ..small(dir.path())
        },
    );
    let bounds = BoundsTable::default();
    for s in &out.speakers {
        // First frame: silence, the neutral face. Indices are ratios, so the true image
        // landmarks (a frontal view with a few degrees of head motion) classify the speaker.
        let truth = read_track_csv(&s.clips[0].true_csv).unwrap();
        let pts: Vec<Option<Point2>> =
            truth.get(0).unwrap().points.iter().map(|p| Some(p.pos())).collect();
        let ix = facial_indices(&pts).unwrap();
        let vmh = bounds
            .classify(FacialIndex::VerticalMouthHeight, ix.get(FacialIndex::VerticalMouthHeight));
        let mw = bounds.classify(FacialIndex::MouthWidth, ix.get(FacialIndex::MouthWidth));
        let want = s.made_for.clone().unwrap_or(("middle".into(), "middle".into()));
        let name = |c: Option<IndexClass>| c.map(|c| c.to_string()).unwrap_or_default();
        assert_eq!((name(vmh), name(mw)), want, "speaker {}", s.index);
    }
}

#[test]
fn rendered_front_frame_has_lips_at_the_lip_landmarks() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        DemoOptions {
            sentences: 1,
            max_frames: Some(2),
            width: 360,
            height: 240,
            ..small(dir.path())
        },
    );
    let clip = &out.speakers[0].clips[0];
    let truth = read_track_csv(&clip.true_csv).unwrap();
    let frame = truth.get(0).unwrap();
    let img =
        image::open(clip.front_dir.as_ref().unwrap().join("frame_00000.png")).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (360, 240));
    let at = |x: f64, y: f64| img.get_pixel(x.round() as u32, y.round() as u32).0;
    let redness = |c: [u8; 3]| c[0] as i32 - c[1] as i32;
    // Upper and lower lip body (between the outer and inner contours at the midline): lip
    // red, far redder than the skin of the cheek beside the mouth.
    let p = |l: usize| frame.points[l].pos();
    let upper = (p(51) + p(62).coords) / 2.0;
    let lower = (p(57) + p(66).coords) / 2.0;
    let cheek = p(48) + (p(48) - p(54)) * 0.4;
    for lip in [upper, lower] {
        let (c, s) = (at(lip.x, lip.y), at(cheek.x, cheek.y));
        assert!(redness(c) > redness(s) + 25, "lip {c:?} vs skin {s:?}");
        assert!((c[0] as i32) < (s[0] as i32), "lips are darker than skin");
    }
    // The background is the light plain colour; the side view's is dark.
    assert!(img.get_pixel(2, 2).0.iter().all(|&v| v > 200));
    let side =
        image::open(clip.side_dir.as_ref().unwrap().join("frame_00000.png")).unwrap().to_rgb8();
    assert!(side.get_pixel(2, 2).0.iter().all(|&v| v < 50));
    assert!(side.pixels().filter(|px| px.0[0] > 100).count() > 1000, "the profile is bright");
}

#[test]
fn an_open_mouth_shows_the_dark_interior_between_the_inner_lips() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        DemoOptions {
            sentences: 4,
            max_frames: None,
            width: 360,
            height: 240,
            side_view: false,
            ..small(dir.path())
        },
    );
    let clip = &out.speakers[0].clips[0];
    let rows = truth_rows(&clip.truth_csv);
    let (f, _) = rows.iter().enumerate().max_by(|a, b| a.1.2.total_cmp(&b.1.2)).unwrap();
    let truth = read_track_csv(&clip.true_csv).unwrap();
    let fr = truth.get(f).unwrap();
    let mid = (fr.points[62].pos() + fr.points[66].pos().coords) / 2.0;
    let img = image::open(clip.front_dir.as_ref().unwrap().join(format!("frame_{f:05}.png")))
        .unwrap()
        .to_rgb8();
    let c = img.get_pixel(mid.x.round() as u32, mid.y.round() as u32).0;
    assert!(c.iter().all(|&v| v < 80), "mouth interior at frame {f} is {c:?}");
}

#[test]
fn poses_and_model_are_written_with_one_topology() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        DemoOptions {
            write_frames: false,
            write_model: true,
            speakers: 2,
            sentences: 1,
            max_frames: Some(2),
            ..small(dir.path())
        },
    );
    assert_eq!(out.poses.len(), 161);
    let head = lipmap::io::obj::read_obj(&out.head_obj).unwrap();
    for p in [&out.poses[0], &out.poses[80], &out.poses[160]] {
        let m = lipmap::io::obj::read_obj(p).unwrap();
        assert_eq!(m.faces, head.faces);
        assert_eq!(m.vertices.len(), head.vertices.len());
    }
    let model = lipmap::io::model_file::read_model_file(out.model.as_ref().unwrap()).unwrap();
    assert_eq!(model.num_vertices(), head.vertices.len());
    assert!((1..=8).contains(&model.num_shape_components()), "{}", model.num_shape_components());
    // A reshaped speaker has its own head and model of the same topology.
    let s1 = &out.speakers[1];
    assert_ne!(s1.head_obj, out.head_obj);
    let own = lipmap::io::obj::read_obj(&s1.head_obj).unwrap();
    assert_eq!(own.faces, head.faces);
    assert_ne!(own.vertices, head.vertices);
    let own_model = lipmap::io::model_file::read_model_file(s1.model.as_ref().unwrap()).unwrap();
    assert_eq!(own_model.num_vertices(), head.vertices.len());
    let map = std::fs::read_to_string(&out.landmark_map).unwrap();
    assert!(map.contains("[landmark_mappings]"));
    assert_eq!(map.lines().filter(|l| l.starts_with(|c: char| c.is_ascii_digit())).count(), 68);
}
