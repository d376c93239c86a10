//! lipmap's own reading of dlib's 68-point shape predictor against dlib itself: on the
//! carphone clip (dlib's tracks in ../shared), on two photographs with human landmarks, and
//! the re-alignment from corrected points on the demo's tracker errors. Every test skips
//! with a notice when the predictor (Debian `libdlib-data`), the detector (Debian
//! `opencv-data`) or the shared data is absent.

use lipmap::demo::{DemoOptions, generate};
use lipmap::io::frames::{FrameOptions, FrameSource};
use lipmap::io::landmark_format::read_track;
use lipmap::landmarks::Track;
use lipmap::landmarks::flags::{FlagReason, FlagThresholds};
use lipmap::track::realign::realign_shape;
use lipmap::track::tracker::FaceTracker;
use lipmap::track::{
    CascadeStart, DEBIAN_CASCADE_PATH, DEBIAN_PREDICTOR_PATH, FaceBox, GrayImage, box_from_shape,
    run_cascade,
};
use lipmap::workflow::flags::{clip_flags, flag_lines};
use lipmap::workflow::no_progress;
use lipmap::workflow::track::{
    Tracked, Tracker, TrackerFiles, gray_of, load_tracker, track_frames,
};
use nalgebra::Vector2;
use std::collections::BTreeSet;
use std::path::Path;
use std::sync::OnceLock;

/// The predictor and detector, read once for the whole file (`None` with a notice when
/// Debian's files are absent).
fn tracker() -> Option<&'static Tracker> {
    static T: OnceLock<Option<Tracker>> = OnceLock::new();
    T.get_or_init(|| {
        for f in [DEBIAN_PREDICTOR_PATH, DEBIAN_CASCADE_PATH] {
            if !Path::new(f).is_file() {
                eprintln!("skipping: {f} not found (apt-get install libdlib-data opencv-data)");
                return None;
            }
        }
        Some(load_tracker(&TrackerFiles::default()).unwrap())
    })
    .as_ref()
}

fn points(track: &Track, frame: usize) -> Vec<Vector2<f64>> {
    track.frames[frame].points.iter().map(|p| Vector2::new(p.x, p.y)).collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn image(path: &Path) -> GrayImage {
    let img = image::open(path).unwrap().to_rgb8();
    GrayImage::from_rgb(img.width() as usize, img.height() as usize, img.as_raw())
}

/// The carphone clip, dlib's tracks of it and lipmap's.
struct Carphone {
    tracker: &'static Tracker,
    dlib: Track,
    /// What to add to a point of `dlib` to put it in the frame's pixel coordinates.
    shift: Vector2<f64>,
    frames: FrameSource,
    ours: Tracked,
}

/// `None` (with a notice) without the predictor, the detector or `../shared`.
fn carphone() -> Option<Carphone> {
    let (Some(tracker), Some(frames_dir), Some(pts)) = (
        tracker(),
        lipmap::testdata::shared("data/carphone/frames"),
        lipmap::testdata::shared("data/carphone/dlib68_pts"),
    ) else {
        return None;
    };
    // The .pts files hold dlib's points on a 3× enlarged frame divided by 3, with no 1-based
    // shift (dlib 20 on a 3× bicubic enlargement reproduces them to ±1 px of that image);
    // lipmap's .pts reader subtracts 1 as the format says, so a point of the original frame
    // (pixel centres at integers, enlargement centre-aligned: x = X/3 − 1/3) is the read
    // value + 2/3.
    let dlib = read_track(&pts).unwrap();
    let frames = FrameSource::open(&frames_dir, &FrameOptions::default()).unwrap();
    let ours = track_frames(tracker, &frames, &no_progress).unwrap();
    Some(Carphone { tracker, dlib, shift: Vector2::new(2.0 / 3.0, 2.0 / 3.0), frames, ours })
}

#[test]
fn carphone_agrees_with_dlibs_own_tracks() {
    let Some(Carphone { tracker: t, dlib, shift, frames, ours }) = carphone() else { return };
    assert!(ours.lost.is_empty(), "lost frames {:?}", ours.lost);
    let (mut from_detector, mut from_dlib_box, mut as_read) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..frames.len() {
        let reference: Vec<Vector2<f64>> = points(&dlib, f).iter().map(|p| p + shift).collect();
        let tracked = points(&ours.track, f);
        // dlib's box as its tracks show it: the box placing the mean shape on them.
        let face = box_from_shape(&t.predictor.mean_shape, &reference).unwrap();
        let gray = gray_of(&frames, f).unwrap();
        let from_box = run_cascade(&t.predictor, gray.view(), &face, &CascadeStart::default());
        for i in 0..68 {
            from_detector.push((tracked[i] - reference[i]).norm());
            from_dlib_box.push((from_box[i] - reference[i]).norm());
            as_read.push((tracked[i] - reference[i] + shift).norm());
        }
    }
    let (d, b, r) = (median(from_detector), median(from_dlib_box), median(as_read));
    println!(
        "carphone, 120 frames × 68 points, median distance to dlib's tracks: lipmap's tracker \
         (own detector) {d:.3} px, from dlib's box {b:.3} px; own tracker against the .pts as \
         lipmap reads them {r:.3} px; face detected on {} frames",
        ours.detected.len()
    );
    assert!(d <= 1.0 && b <= 1.0, "median {d:.3} / {b:.3} px > 1 px");
}

/// Mean point error over the outer eye-corner distance (36–45) of the human landmarks.
fn normalised_error(got: &[Vector2<f64>], human: &[Vector2<f64>]) -> f64 {
    let mean = got.iter().zip(human).map(|(a, b)| (a - b).norm()).sum::<f64>() / 68.0;
    mean / (human[36] - human[45]).norm()
}

#[test]
fn photos_error_is_within_a_hundredth_of_dlibs() {
    let Some(t) = tracker() else { return };
    // dlib 20.0 (PyPI dlib-bin) on the same photos, `get_frontal_face_detector()(img, 0)` and
    // the same predictor: its box (left, top, right, bottom) and its error as computed here
    // (docs/tracking.md has the script).
    let cases = [
        ("takeo.ppm", [31.0, 65.0, 135.0, 169.0], 0.0378),
        ("einstein.jpg", [362.0, 285.0, 448.0, 371.0], 0.0666),
    ];
    for (name, b, dlib_error) in cases {
        let Some(photo) = lipmap::testdata::shared(&format!("data/images/{name}")) else { return };
        let human = read_track(&photo.with_extension("pts")).unwrap();
        let human = points(&human, 0);
        let gray = image(&photo);
        let dlib_box = FaceBox { left: b[0], top: b[1], width: b[2] - b[0], height: b[3] - b[1] };
        let same_box = run_cascade(&t.predictor, gray.view(), &dlib_box, &CascadeStart::default());
        // dlib returns whole pixels.
        let rounded: Vec<Vector2<f64>> =
            same_box.iter().map(|p| p.map(|v| (v + 0.5).floor())).collect();
        let e_box = normalised_error(&rounded, &human);
        let ft = FaceTracker {
            predictor: &t.predictor,
            detector: Some(&t.detector),
            options: t.options.clone(),
        };
        let own = ft.track_frame(gray.view(), None).expect("a face");
        let e_own = normalised_error(&own.points, &human);
        println!(
            "{name}: error / eye distance: dlib {dlib_error:.4}; lipmap from dlib's box {e_box:.4}, \
             from its own detector {e_own:.4}"
        );
        // Not exactly dlib's on einstein.jpg: a greyscale JPEG that the image crate and
        // libjpeg decode a grey level apart here and there, which flips a few splits.
        assert!((e_box - dlib_error).abs() <= 0.01, "{name}: {e_box:.4} vs dlib {dlib_error:.4}");
        assert!((e_own - dlib_error).abs() <= 0.01, "{name}: {e_own:.4} vs dlib {dlib_error:.4}");
    }
}

/// The outer and inner lip points of the upper and lower lips (iBUG-68, 0-based), and the
/// two a user corrects on each: the midline's outer and inner points.
const UPPER_LIP: [usize; 8] = [49, 50, 51, 52, 53, 61, 62, 63];
const LOWER_LIP: [usize; 8] = [55, 56, 57, 58, 59, 65, 66, 67];
const UPPER_FIXED: [usize; 2] = [51, 62];
const LOWER_FIXED: [usize; 2] = [57, 66];

#[test]
fn correcting_two_lip_points_brings_the_rest_of_the_lip_along() {
    let Some(t) = tracker() else { return };
    let dir = tempfile::tempdir().unwrap();
    let opts = DemoOptions {
        out_dir: dir.path().join("demo"),
        sentences: 4,
        side_view: false,
        write_model: false,
        ..DemoOptions::default()
    };
    let out = generate(&opts).unwrap();
    let (mut before, mut after) = (0.0, 0.0);
    let mut cases = 0;
    for clip in &out.speakers[0].clips {
        let truth = read_track(&clip.true_csv).unwrap();
        let tracked = read_track(&clip.tracked_csv).unwrap();
        let frames =
            FrameSource::open(clip.front_dir.as_ref().unwrap(), &FrameOptions::default()).unwrap();
        for err in &clip.injected_errors {
            // The demo's tracker errors move one or two lip points (a swap, a jump of 10–25
            // px); a real tracker drags the whole lip (dlib's lower lip on the tongue,
            // docs/flags.md). The test gives the error's displacement to every point of the
            // lip it hit, and the user corrects that lip's two midline points.
            let f = err.frame;
            let truth_pts = points(&truth, f);
            let mut shape = points(&tracked, f);
            // Undo the demo's own error first: only the dragged lip is to be wrong.
            match err.other {
                Some(o) => shape.swap(err.point, o),
                None => shape[err.point] -= Vector2::new(err.dx, err.dy),
            }
            let d = match err.other {
                None => Vector2::new(err.dx, err.dy),
                // A swap puts the point on its partner: the lip is dragged by their gap.
                Some(o) => Vector2::new(0.0, truth_pts[o].y - truth_pts[err.point].y),
            };
            let (lip, fixed) = if UPPER_LIP.contains(&err.point) || [48, 60].contains(&err.point) {
                (UPPER_LIP, UPPER_FIXED)
            } else {
                (LOWER_LIP, LOWER_FIXED)
            };
            for &i in &lip {
                shape[i] = truth_pts[i] + d;
            }
            let held: Vec<(usize, Vector2<f64>)> =
                fixed.iter().map(|&i| (i, truth_pts[i])).collect();
            let gray = gray_of(&frames, f).unwrap();
            let realigned = realign_shape(&t.predictor, gray.view(), &shape, &held).unwrap();
            let others: Vec<usize> = lip.iter().copied().filter(|i| !fixed.contains(i)).collect();
            let err_of = |s: &[Vector2<f64>]| {
                others.iter().map(|&i| (s[i] - truth_pts[i]).norm()).sum::<f64>()
                    / others.len() as f64
            };
            let (b, a) = (err_of(&shape), err_of(&realigned));
            println!(
                "{} frame {f} ({} {}): other lip points {b:.2} px -> {a:.2} px",
                clip.name, err.kind, err.point
            );
            for &(i, p) in &held {
                assert_eq!(realigned[i], p, "a held point moved");
            }
            before += b;
            after += a;
            cases += 1;
        }
    }
    assert!(cases >= 4, "too few injected errors to judge: {cases}");
    let fall = 1.0 - after / before;
    println!(
        "{cases} errors: other lip points' mean error {:.2} -> {:.2} px ({:.0} % less)",
        before / cases as f64,
        after / cases as f64,
        100.0 * fall
    );
    assert!(fall >= 0.5, "the other lip points' error fell by only {:.0} %", 100.0 * fall);
}

/// Mean distance over `idx` between two shapes.
fn mean_error(a: &[Vector2<f64>], b: &[Vector2<f64>], idx: &[usize]) -> f64 {
    idx.iter().map(|&i| (a[i] - b[i]).norm()).sum::<f64>() / idx.len() as f64
}

/// Re-alignment on the real clip, against dlib's tracks (carphone has no human landmarks):
/// (a) on the frames where lipmap's tracker flags itself (confidence < 0.8), the user moves
/// the two lip points farthest from dlib's to dlib's positions; (b) on every frame, dlib's
/// lower lip is dragged up onto the tongue by 0.1 eye distance (≈ 3 px, the size of the bias
/// `docs/flags.md` describes) and its two midline points are corrected. Reported: the other
/// lip points' mean distance to dlib's before and after.
#[test]
fn realigning_carphone_frames_from_corrected_lip_points() {
    let Some(Carphone { tracker: t, dlib, shift, frames, ours }) = carphone() else { return };
    let lips: Vec<usize> = (48..68).collect();
    let (mut flagged, mut flagged_before, mut flagged_after) = (Vec::new(), 0.0, 0.0);
    let (mut dragged_before, mut dragged_after) = (0.0, 0.0);
    for f in 0..frames.len() {
        let reference: Vec<Vector2<f64>> = points(&dlib, f).iter().map(|p| p + shift).collect();
        let gray = gray_of(&frames, f).unwrap();
        // (a) lipmap's own low-confidence frames.
        let tracked = points(&ours.track, f);
        if ours.track.frames[f].confidence.is_some_and(|c| c < 0.8) {
            let mut worst: Vec<(f64, usize)> =
                lips.iter().map(|&i| ((tracked[i] - reference[i]).norm(), i)).collect();
            worst.sort_by(|a, b| b.0.total_cmp(&a.0));
            let held: Vec<(usize, Vector2<f64>)> =
                worst[..2].iter().map(|&(_, i)| (i, reference[i])).collect();
            let others: Vec<usize> =
                lips.iter().copied().filter(|i| held.iter().all(|h| h.0 != *i)).collect();
            let re = realign_shape(&t.predictor, gray.view(), &tracked, &held).unwrap();
            let (b, a) =
                (mean_error(&tracked, &reference, &others), mean_error(&re, &reference, &others));
            println!("carphone frame {f} (flagged): other lip points {b:.2} -> {a:.2} px");
            flagged.push(f);
            flagged_before += b;
            flagged_after += a;
        }
        // (b) a lower lip dragged onto the tongue.
        let up = Vector2::new(0.0, -0.1 * (reference[36] - reference[45]).norm());
        let mut shape = reference.clone();
        for &i in &LOWER_LIP {
            shape[i] += up;
        }
        let held: Vec<(usize, Vector2<f64>)> =
            LOWER_FIXED.iter().map(|&i| (i, reference[i])).collect();
        let others: Vec<usize> =
            LOWER_LIP.iter().copied().filter(|i| !LOWER_FIXED.contains(i)).collect();
        let re = realign_shape(&t.predictor, gray.view(), &shape, &held).unwrap();
        dragged_before += mean_error(&shape, &reference, &others);
        dragged_after += mean_error(&re, &reference, &others);
    }
    let n = frames.len() as f64;
    let k = flagged.len().max(1) as f64;
    println!(
        "carphone, {} flagged frames {flagged:?}: other lip points' mean distance to dlib's \
         {:.2} -> {:.2} px; lower lip dragged up 0.1 eye distance on all {n} frames, midline \
         corrected: other lower-lip points {:.2} -> {:.2} px ({:.0} % less)",
        flagged.len(),
        flagged_before / k,
        flagged_after / k,
        dragged_before / n,
        dragged_after / n,
        100.0 * (1.0 - dragged_after / dragged_before)
    );
    assert!(
        dragged_after <= 0.5 * dragged_before,
        "a dragged lower lip's error fell by only {:.0} %",
        100.0 * (1.0 - dragged_after / dragged_before)
    );
}

/// The session use cases the TUI's key and `lipmap propagate` call: a demo clip whose tracked
/// lower lip is dragged on one frame; the user corrects its midline; the frame re-aligned in
/// memory brings the other lower-lip points toward the truth without changing the session,
/// and `propagate_session_correction` stores them (marked interpolated) and saves.
#[test]
fn session_realignment_moves_the_lip_and_propagate_saves_it() {
    use lipmap::landmarks::{LandmarkPoint, PointSource};
    use lipmap::session::{Clip, FramesRef, Session, View};
    use lipmap::track::realign::PropagateOptions;
    use lipmap::workflow::track::{propagate_session_correction, realign_session_frame};
    let Some(t) = tracker() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = generate(&DemoOptions {
        out_dir: dir.path().join("demo"),
        sentences: 1,
        side_view: false,
        write_model: false,
        max_frames: Some(8),
        ..DemoOptions::default()
    })
    .unwrap();
    let c = &out.speakers[0].clips[0];
    let truth = read_track(&c.true_csv).unwrap();
    let f = 3;
    let drag = 12.0;
    let mut tracked = truth.clone();
    for &i in &LOWER_LIP {
        tracked.frames[f].points[i].y -= drag;
    }
    let path = dir.path().join("s.lipmap.json");
    let mut session = Session::new(&path);
    let mut view = View::new(FramesRef::Images { dir: c.dir.join("front") }, c.fps);
    view.size = Some([c.width, c.height]);
    let mut clip = Clip::new(c.name.clone(), view);
    clip.set_tracked(tracked);
    for &i in &LOWER_FIXED {
        let p = truth.frames[f].points[i];
        clip.corrections.set(f, i, LandmarkPoint::tracked(p.x, p.y)).unwrap();
    }
    session.add_clip(clip).unwrap();
    session.save(&path).unwrap();

    let others: Vec<usize> =
        LOWER_LIP.iter().copied().filter(|i| !LOWER_FIXED.contains(i)).collect();
    let truth_pts = points(&truth, f);
    let realigned = realign_session_frame(&session, 0, f, t).unwrap();
    let got: Vec<Vector2<f64>> = realigned.points.iter().map(|p| Vector2::new(p.x, p.y)).collect();
    let after = mean_error(&got, &truth_pts, &others);
    println!(
        "demo frame {f}, lower lip dragged {drag} px: other lower-lip points -> {after:.2} px"
    );
    assert!(after < 0.5 * drag, "other lower-lip points still {after:.2} px off");
    for &i in &LOWER_FIXED {
        assert_eq!(realigned.points[i].source, PointSource::Corrected);
        assert_eq!(got[i], truth_pts[i]);
    }
    assert!(others.iter().all(|&i| realigned.points[i].source == PointSource::Interpolated));
    // In memory only: the session file still has only the user's two points.
    let on_disk = Session::load(&path).unwrap();
    assert!(on_disk.clips[0].corrections.get(f, others[0]).is_none());

    let p = propagate_session_correction(
        path.to_str().unwrap(),
        None,
        f,
        t,
        &PropagateOptions::default(),
    )
    .unwrap();
    assert_eq!(p.frames[0], f);
    assert_eq!(p.held, LOWER_FIXED.to_vec());
    let saved = Session::load(&path).unwrap();
    let stored = saved.clips[0].corrections.get(f, others[0]).expect("stored");
    assert_eq!(stored.source, PointSource::Interpolated);
    // A frame without corrected points is a clear error.
    let e = realign_session_frame(&saved, 0, f + 1, t).unwrap_err().to_string();
    assert!(e.contains("no corrected point"), "{e}");
}

/// A clip whose first frames the detector missed: a rough face box drawn on the first one
/// (dlib's box from its tracks, 15 % too big and off by a tenth of its side, as a hand
/// draws it) gives those frames dlib's points, and the track stops where it meets the
/// clip's landmarks again.
#[test]
fn a_drawn_face_box_tracks_the_lost_frames_and_stops_where_the_track_resumes() {
    use lipmap::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, PointSource};
    use lipmap::track::realign::PropagateOptions;
    use lipmap::workflow::track::track_from_box;
    let Some(Carphone { tracker: t, dlib, shift, frames, ours }) = carphone() else { return };
    let lost = 10;
    let mut existing = ours.track.clone();
    for f in &mut existing.frames[..lost] {
        *f = FrameLandmarks {
            success: false,
            ..FrameLandmarks::new(f.frame, vec![LandmarkPoint::missing(); N_LANDMARKS])
        };
    }
    let reference: Vec<Vector2<f64>> = points(&dlib, 0).iter().map(|p| p + shift).collect();
    let b = box_from_shape(&t.predictor.mean_shape, &reference).unwrap();
    let side = 1.15 * b.width;
    let face = FaceBox {
        left: b.left + 0.1 * b.width - (side - b.width) / 2.0,
        top: b.top - 0.1 * b.width - (side - b.width) / 2.0,
        width: side,
        height: side,
    };
    let decoded = std::cell::Cell::new(0);
    let image = |f: usize| {
        decoded.set(decoded.get() + 1);
        gray_of(&frames, f)
    };
    let got = track_from_box(t, face, &existing, 0, image, &PropagateOptions::default()).unwrap();
    let last = got.last().unwrap().frame;
    println!("face box on frame 0: frames 0–{last} tracked, {} decoded", decoded.get());
    assert!(got.len() >= lost, "only {} frames", got.len());
    assert!(last < lost + 5, "ran on to frame {last}: it should meet the clip's track");
    let mut d = Vec::new();
    for fl in &got {
        assert!(fl.points.iter().all(|p| p.source == PointSource::Interpolated && p.visible));
        assert!(fl.points[0].confidence.is_some());
        let reference: Vec<Vector2<f64>> =
            points(&dlib, fl.frame).iter().map(|p| p + shift).collect();
        d.extend(
            fl.points.iter().zip(&reference).map(|(p, r)| (Vector2::new(p.x, p.y) - r).norm()),
        );
    }
    let m = median(d);
    println!("their points against dlib's tracks: median {m:.3} px");
    assert!(m <= 1.0, "median {m:.3} px from dlib's");
    // Not a box.
    let none = FaceBox { width: 0.0, ..face };
    assert!(
        track_from_box(t, none, &existing, 0, |f| gray_of(&frames, f), &Default::default())
            .is_err()
    );
}

/// The TUI's tracker job on the same clip: a re-alignment of a frame whose lower lip the
/// user moved (two points) comes back as the frame's other points moved, the corrected
/// ones kept; a missing predictor file is one line naming the flag.
#[test]
#[ignore = "open: on carphone frame 57 the cascade pulls the dragged lower-lip neighbours back \
            to where it tracked them (0.02 px of the 2 px correction follow)"]
fn the_tuis_tracker_job_realigns_and_names_a_missing_predictor() {
    use lipmap::landmarks::{LandmarkPoint, PointSource};
    use lipmap::tui::FrameProvider;
    use lipmap::tui::action::Action;
    use lipmap::tui::jobs::{TrackJob, TrackerSource, track_for_tui};
    use lipmap::workflow::track::TrackerFiles;
    struct Frames(FrameSource);
    impl FrameProvider for Frames {
        fn load(&self, frame: usize) -> anyhow::Result<lipmap::tui::FrameImage> {
            let img = self.0.get(frame)?;
            Ok(lipmap::tui::FrameImage {
                width: img.width(),
                height: img.height(),
                rgb: img.as_raw().clone(),
            })
        }
    }
    let Some(Carphone { frames, ours, .. }) = carphone() else { return };
    let f = 57;
    let mut landmarks = ours.track.frames[f].clone();
    for i in [57, 66] {
        let p = landmarks.points[i];
        landmarks.points[i] = LandmarkPoint {
            source: PointSource::Corrected,
            ..LandmarkPoint::tracked(p.x, p.y + 2.0)
        };
    }
    let provider = Frames(frames);
    let source = TrackerSource::new(TrackerFiles::default());
    let said = std::cell::RefCell::new(Vec::new());
    let say = |s: String| said.borrow_mut().push(s);
    let job = TrackJob::Realign { landmarks: landmarks.clone(), image: None };
    let Action::Realigned { before, after } = track_for_tui(&source, &provider, job, &say) else {
        panic!("no re-alignment");
    };
    assert_eq!(*before, landmarks);
    assert_eq!(after.points[57], landmarks.points[57]);
    let moved = after.points.iter().filter(|p| p.source == PointSource::Interpolated).count();
    assert_eq!(moved, 66);
    // The lower lip's other points followed the two moved down.
    let dy: f64 =
        [56, 58, 65, 67].iter().map(|&i| after.points[i].y - landmarks.points[i].y).sum::<f64>()
            / 4.0;
    println!("frame {f}: lower midline moved 2 px down, its neighbours followed by {dy:.2} px");
    assert!(dy > 0.5, "neighbours moved {dy:.2} px");
    assert!(said.borrow().iter().any(|s| s.contains("reading the shape predictor")));

    let missing = TrackerSource::new(TrackerFiles {
        predictor: None,
        detector: Some("/nonexistent/cascade.xml".into()),
    });
    let job = TrackJob::Realign { landmarks, image: None };
    let Action::TrackerFailed { error } = track_for_tui(&missing, &provider, job, &say) else {
        panic!("a missing file is an error");
    };
    assert!(!error.contains('\n') && error.contains("/nonexistent/cascade.xml"), "{error}");
}

/// lipmap's tracker's self-check on carphone, through the flags: the frames where its
/// cascade parts from its own re-run are the frames where dlib's model (the same model) is
/// wrong. Frames 115 and 116 were labelled by eye on dlib's tracks (lower inner lip on the
/// tongue; `tests/flags_real_tracker.rs`), and lipmap's points there are dlib's.
#[test]
fn carphone_self_check_flags_the_frames_dlib_gets_wrong() {
    let Some(Carphone { ours, .. }) = carphone() else { return };
    let flags = clip_flags(&ours.track, &[], &[], &FlagThresholds::default());
    for l in flag_lines("carphone (lipmap's tracker)", &flags, ours.track.len()) {
        println!("{l}");
    }
    let rerun: BTreeSet<usize> = flags
        .iter()
        .filter(|f| f.reasons.iter().any(|r| matches!(r, FlagReason::TrackerRerun { .. })))
        .map(|f| f.frame)
        .collect();
    let flagged: BTreeSet<usize> = flags.iter().map(|f| f.frame).collect();
    println!(
        "carphone: {} of {} frames flagged, {} by the self-check: {rerun:?}",
        flagged.len(),
        ours.track.len(),
        rerun.len()
    );
    for frame in [115, 116] {
        assert!(rerun.contains(&frame), "labelled tracker error at frame {frame} not flagged");
    }
    // A real, correctly tracked fast opening, and most of the clip, pass.
    assert!(!rerun.contains(&76), "frame 76 flagged by the self-check");
    assert!(
        rerun.len() * 10 < ours.track.len(),
        "{} frames flagged by the self-check",
        rerun.len()
    );
}
