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
use lipmap::track::realign::{
    CorrectedFrame, NextFrame, PropagateOptions, PropagationEnd, propagate_realignment,
    realign_shape,
};
use lipmap::track::tracker::{FaceTracker, StartKind};
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

/// Demo seeds the re-alignment was not designed on (it was designed on the default seed's
/// errors and carphone frame 57; `docs/tracking.md`).
const HELD_OUT_SEEDS: [u64; 3] = [7304, 7305, 7306];

#[test]
fn correcting_two_lip_points_brings_the_rest_of_the_lip_along() {
    let Some(t) = tracker() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut sum = LipFigures::default();
    let mut cases = 0;
    for seed in HELD_OUT_SEEDS {
        let opts = DemoOptions {
            seed,
            out_dir: dir.path().join(format!("demo{seed}")),
            sentences: 4,
            side_view: false,
            write_model: false,
            ..DemoOptions::default()
        };
        let out = generate(&opts).unwrap();
        for clip in &out.speakers[0].clips {
            let truth = read_track(&clip.true_csv).unwrap();
            let tracked = read_track(&clip.tracked_csv).unwrap();
            let frames =
                FrameSource::open(clip.front_dir.as_ref().unwrap(), &FrameOptions::default())
                    .unwrap();
            for err in &clip.injected_errors {
                // The demo's tracker errors move one or two lip points (a swap, a jump of
                // 10–25 px); a real tracker drags the whole lip (dlib's lower lip on the
                // tongue, docs/flags.md). The test gives the error's displacement to every
                // point of the lip it hit, and the user corrects that lip's two midline points.
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
                let (lip, fixed) =
                    if UPPER_LIP.contains(&err.point) || [48, 60].contains(&err.point) {
                        (UPPER_LIP, UPPER_FIXED)
                    } else {
                        (LOWER_LIP, LOWER_FIXED)
                    };
                for &i in &lip {
                    shape[i] = truth_pts[i] + d;
                }
                let gray = gray_of(&frames, f).unwrap();
                let r = realign_moved_lip(t, &gray, &shape, &truth_pts, (&lip, &fixed));
                println!(
                    "seed {seed} {} frame {f} ({} {}, lip moved {:.0},{:.0} px): {}",
                    clip.name,
                    err.kind,
                    err.point,
                    d.x,
                    d.y,
                    r.line(1.0)
                );
                sum += r;
                cases += 1;
            }
        }
    }
    assert!(cases >= 12, "too few injected errors to judge: {cases}");
    println!("seeds {HELD_OUT_SEEDS:?}, {cases} errors: {}", sum.line(cases as f64));
    assert!(
        sum.fall() >= 0.5,
        "the other lip points' error fell by only {:.0} %",
        100.0 * sum.fall()
    );
}

/// Mean distance over `idx` between two shapes.
fn mean_error(a: &[Vector2<f64>], b: &[Vector2<f64>], idx: &[usize]) -> f64 {
    idx.iter().map(|&i| (a[i] - b[i]).norm()).sum::<f64>() / idx.len() as f64
}

/// How far a plain re-run of the cascade (nothing held, from `shape` in its own box) moves
/// the points `idx` of `shape`: the cascade's own spread on that frame, the most a
/// re-alignment may make a nearly right frame worse.
fn cascade_spread(t: &Tracker, gray: &GrayImage, shape: &[Vector2<f64>], idx: &[usize]) -> f64 {
    let face = box_from_shape(&t.predictor.mean_shape, shape).unwrap();
    let start = CascadeStart { shape: Some(shape), held: &[], carry: None };
    mean_error(&run_cascade(&t.predictor, gray.view(), &face, &start), shape, idx)
}

/// Re-alignment of nearly right points: the two of `lips` farthest from `reference` are
/// moved there and the rest re-aligned. Returns the other points' mean distance to
/// `reference` before and after, and the cascade's own spread on them.
fn realign_near_right(
    t: &Tracker,
    gray: &GrayImage,
    tracked: &[Vector2<f64>],
    reference: &[Vector2<f64>],
    lips: &[usize],
) -> (f64, f64, f64) {
    let mut worst: Vec<(f64, usize)> =
        lips.iter().map(|&i| ((tracked[i] - reference[i]).norm(), i)).collect();
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    let held: Vec<(usize, Vector2<f64>)> =
        worst[..2].iter().map(|&(_, i)| (i, reference[i])).collect();
    let others: Vec<usize> =
        lips.iter().copied().filter(|i| held.iter().all(|h| h.0 != *i)).collect();
    let re = realign_shape(&t.predictor, t.shape_prior(), gray.view(), tracked, &held).unwrap();
    (
        mean_error(tracked, reference, &others),
        mean_error(&re, reference, &others),
        cascade_spread(t, gray, tracked, &others),
    )
}

/// How far a re-alignment took a lip's points from the reference: the moved lip's points
/// other than the two corrected, and the other lip's (not moved, so any change is harm).
#[derive(Clone, Copy, Debug, Default)]
struct LipFigures {
    moved_before: f64,
    moved_after: f64,
    other_before: f64,
    other_after: f64,
    /// How far a plain re-run of the cascade moves the other lip (its own spread there).
    other_spread: f64,
}

impl std::ops::AddAssign for LipFigures {
    fn add_assign(&mut self, o: Self) {
        self.moved_before += o.moved_before;
        self.moved_after += o.moved_after;
        self.other_before += o.other_before;
        self.other_after += o.other_after;
        self.other_spread += o.other_spread;
    }
}

impl LipFigures {
    /// The share of the moved lip's error the re-alignment removed.
    fn fall(&self) -> f64 {
        1.0 - self.moved_after / self.moved_before
    }

    /// Per case, `n` cases: "moved lip B -> A px (F % less); other lip B -> A px (spread)".
    fn line(&self, n: f64) -> String {
        format!(
            "moved lip's other points {:.2} -> {:.2} px ({:.0} % less); the other lip's {:.2} -> \
             {:.2} px (cascade's own spread {:.2} px)",
            self.moved_before / n,
            self.moved_after / n,
            100.0 * self.fall(),
            self.other_before / n,
            self.other_after / n,
            self.other_spread / n
        )
    }
}

/// `shape` (a lip of it moved, so `lip`'s points are wrong), its lip's two midline points
/// `fixed` corrected to `reference`, re-aligned: how far the lip's other points and the other
/// lip's points are from `reference` before and after.
fn realign_moved_lip(
    t: &Tracker,
    gray: &GrayImage,
    shape: &[Vector2<f64>],
    reference: &[Vector2<f64>],
    (lip, fixed): (&[usize], &[usize]),
) -> LipFigures {
    let held: Vec<(usize, Vector2<f64>)> = fixed.iter().map(|&i| (i, reference[i])).collect();
    let others: Vec<usize> = lip.iter().copied().filter(|i| !fixed.contains(i)).collect();
    let other_lip: Vec<usize> =
        (48..68).filter(|i| !lip.contains(i) && ![48, 54, 60, 64].contains(i)).collect();
    let re = realign_shape(&t.predictor, t.shape_prior(), gray.view(), shape, &held).unwrap();
    for &(i, p) in &held {
        assert_eq!(re[i], p, "a held point moved");
    }
    LipFigures {
        moved_before: mean_error(shape, reference, &others),
        moved_after: mean_error(&re, reference, &others),
        other_before: mean_error(shape, reference, &other_lip),
        other_after: mean_error(&re, reference, &other_lip),
        other_spread: cascade_spread(t, gray, shape, &other_lip),
    }
}

/// `tracked` with the points `lip` moved by `drag` (pixels).
fn dragged(tracked: &[Vector2<f64>], lip: &[usize], drag: Vector2<f64>) -> Vec<Vector2<f64>> {
    let mut shape = tracked.to_vec();
    for &i in lip {
        shape[i] += drag;
    }
    shape
}

/// The carphone frame the re-alignment was designed on (the TUI test's); left out here.
const DESIGN_FRAME: usize = 57;

/// Re-alignment on the real clip, against dlib's tracks (carphone has no human landmarks):
/// (a) on the frames where lipmap's tracker flags itself (confidence < 0.8), the user moves
/// the two lip points farthest from dlib's to dlib's positions: the other lip points must not
/// move away from dlib's by more than the cascade's own spread there; (b) on every frame but
/// the design frame, lipmap's lower lip is dragged up onto the tongue by 0.1 eye distance
/// (≈ 3 px, the size of the bias `docs/flags.md` describes) and its two midline points are
/// corrected to dlib's. Reported: the other lip points' mean distance to dlib's before and
/// after.
#[test]
fn realigning_carphone_frames_from_corrected_lip_points() {
    let Some(Carphone { tracker: t, dlib, shift, frames, ours }) = carphone() else { return };
    let lips: Vec<usize> = (48..68).collect();
    let (mut flagged, mut near) = (Vec::new(), (0.0, 0.0, 0.0));
    let (mut lips_dragged, mut n) = (LipFigures::default(), 0.0);
    for f in (0..frames.len()).filter(|&f| f != DESIGN_FRAME) {
        let reference: Vec<Vector2<f64>> = points(&dlib, f).iter().map(|p| p + shift).collect();
        let gray = gray_of(&frames, f).unwrap();
        let tracked = points(&ours.track, f);
        // (a) lipmap's own low-confidence frames.
        if ours.track.frames[f].confidence.is_some_and(|c| c < 0.8) {
            let (b, a, spread) = realign_near_right(t, &gray, &tracked, &reference, &lips);
            println!(
                "carphone frame {f} (flagged): other lip points {b:.2} -> {a:.2} px (cascade's \
                 own spread {spread:.2} px)"
            );
            flagged.push(f);
            near = (near.0 + b, near.1 + a, near.2 + spread);
        }
        // (b) a lower lip dragged onto the tongue.
        let up = Vector2::new(0.0, -0.1 * (reference[36] - reference[45]).norm());
        let shape = dragged(&tracked, &LOWER_LIP, up);
        lips_dragged += realign_moved_lip(t, &gray, &shape, &reference, (&LOWER_LIP, &LOWER_FIXED));
        n += 1.0;
    }
    let k = flagged.len().max(1) as f64;
    println!(
        "carphone, {} flagged frames {flagged:?}: other lip points' mean distance to dlib's \
         {:.2} -> {:.2} px (cascade's own spread {:.2} px); lower lip dragged up 0.1 eye \
         distance on {n} frames (all but {DESIGN_FRAME}), midline corrected: {}",
        flagged.len(),
        near.0 / k,
        near.1 / k,
        near.2 / k,
        lips_dragged.line(n)
    );
    assert!(
        lips_dragged.fall() >= 0.5,
        "a dragged lower lip's error fell by only {:.0} %",
        100.0 * lips_dragged.fall()
    );
    assert!(
        near.1 - near.0 <= near.2,
        "nearly right frames got worse by {:.2} px, more than the cascade's spread {:.2} px",
        (near.1 - near.0) / k,
        near.2 / k
    );
}

/// A tracker's error that lasts: `lip` dragged by `drag` on `span` frames from `first` on
/// (as dlib's lower lip lies on the tongue over carphone's frames 55–63), its midline `fixed`
/// corrected to `reference` on `first` (held there exactly), and the correction propagated.
/// Sums over the dragged frames after `first` (the lip's 8 points against `reference`: the
/// tracker's, then after propagation, a frame the walk did not reach counting as the
/// tracker's) and over the frames after the drag that the walk changed (any change is harm:
/// against the cascade's own spread there).
#[derive(Clone, Copy, Debug, Default)]
struct Carried {
    dragged_before: f64,
    dragged_after: f64,
    dragged_frames: usize,
    /// Dragged frames the walk did not reach.
    dragged_missed: usize,
    past_before: f64,
    past_after: f64,
    past_spread: f64,
    /// Frames after the drag that the walk changed.
    past_frames: usize,
    /// Walks that ended on a lost patch.
    lost: usize,
}

impl std::ops::AddAssign for Carried {
    fn add_assign(&mut self, o: Self) {
        self.dragged_before += o.dragged_before;
        self.dragged_after += o.dragged_after;
        self.dragged_frames += o.dragged_frames;
        self.dragged_missed += o.dragged_missed;
        self.past_before += o.past_before;
        self.past_after += o.past_after;
        self.past_spread += o.past_spread;
        self.past_frames += o.past_frames;
        self.lost += o.lost;
    }
}

impl Carried {
    fn fall(&self) -> f64 {
        1.0 - self.dragged_after / self.dragged_before
    }

    fn line(&self) -> String {
        let n = self.dragged_frames.max(1) as f64;
        let k = self.past_frames.max(1) as f64;
        format!(
            "dragged frames after the corrected one: lip {:.2} -> {:.2} px ({:.0} % less) on {} \
             frames ({} not reached); frames after the drag changed: {} (lip {:.2} -> {:.2} px, \
             cascade's own spread {:.2} px); walks ended on a lost or parted patch: {}",
            self.dragged_before / n,
            self.dragged_after / n,
            100.0 * self.fall(),
            self.dragged_frames,
            self.dragged_missed,
            self.past_frames,
            self.past_before / k,
            self.past_after / k,
            self.past_spread / k,
            self.lost
        )
    }
}

/// [`Carried`] for one lasting error (above). `tracked` and `reference` are every frame's
/// points; `span` frames are dragged from `first`; at most `span + 10` frames are walked.
#[allow(clippy::too_many_arguments)]
fn propagate_dragged_lip(
    t: &Tracker,
    frames: &FrameSource,
    tracked: &[Vec<Vector2<f64>>],
    reference: &[Vec<Vector2<f64>>],
    first: usize,
    span: usize,
    (lip, fixed): (&[usize], &[usize]),
    drag: Vector2<f64>,
) -> (Carried, PropagationEnd) {
    let end = (first + span).min(tracked.len());
    let shapes: Vec<Vec<Vector2<f64>>> = (0..tracked.len())
        .map(|f| {
            if (first..end).contains(&f) {
                dragged(&tracked[f], lip, drag)
            } else {
                tracked[f].clone()
            }
        })
        .collect();
    let held: Vec<(usize, Vector2<f64>)> =
        fixed.iter().map(|&i| (i, reference[first][i])).collect();
    let image = gray_of(frames, first).unwrap();
    let start = CorrectedFrame { image: image.view(), tracked: &shapes[first], held: &held };
    let walk = (first + 1..tracked.len()).map(|f| NextFrame {
        frame: f,
        image: gray_of(frames, f).unwrap(),
        tracked: Some(shapes[f].clone()),
    });
    let opts = PropagateOptions { max_frames: span + 10, ..PropagateOptions::default() };
    let p = propagate_realignment(&t.predictor, t.shape_prior(), &start, walk, &opts);
    let mut c = Carried::default();
    for f in first + 1..end {
        let after = p.shapes.get(f - first - 1).unwrap_or(&shapes[f]);
        c.dragged_before += mean_error(&shapes[f], &reference[f], lip);
        c.dragged_after += mean_error(after, &reference[f], lip);
        c.dragged_frames += 1;
        c.dragged_missed += usize::from(f - first > p.shapes.len());
    }
    for (k, after) in p.shapes.iter().enumerate().skip(end - first - 1) {
        let f = first + 1 + k;
        let gray = gray_of(frames, f).unwrap();
        c.past_before += mean_error(&shapes[f], &reference[f], lip);
        c.past_after += mean_error(after, &reference[f], lip);
        c.past_spread += cascade_spread(t, &gray, &shapes[f], lip);
        c.past_frames += 1;
    }
    c.lost =
        usize::from(matches!(p.end, PropagationEnd::Lost { .. } | PropagationEnd::Parted { .. }));
    (c, p.end)
}

/// How many frames a demo error is made to last in the propagation test.
const DEMO_SPAN: usize = 6;

/// Demo seeds the propagation was not tuned on (it was tuned on the default seed, seed 7301
/// and carphone; `docs/tracking.md`).
const PROPAGATION_SEEDS: [u64; 3] = [7307, 7308, 7309];

/// Propagation against the truth: each of the demo's injected errors (held-out seeds) made a
/// lip dragged by the error's displacement for [`DEMO_SPAN`] frames, its midline corrected on
/// the first and propagated. The lip's error on the dragged frames after the corrected one
/// must fall by half, the walk must stop (the tracker is right again after the drag), and the
/// frames after the drag it changed must not get worse by more than the cascade's own spread.
/// `LIPMAP_PROPAGATION_SEEDS=0,7301` runs it on the tuning seeds instead (0: the default).
#[test]
fn propagating_a_correction_follows_the_lip_and_stops_when_the_tracker_is_right() {
    let Some(t) = tracker() else { return };
    let dir = tempfile::tempdir().unwrap();
    let seeds: Vec<u64> = match std::env::var("LIPMAP_PROPAGATION_SEEDS") {
        Ok(v) => v.split(',').map(|s| s.trim().parse().unwrap()).collect(),
        Err(_) => PROPAGATION_SEEDS.to_vec(),
    };
    let (mut sum, mut cases, mut late) = (Carried::default(), 0, Vec::new());
    for &seed in &seeds {
        let defaults = DemoOptions::default();
        let opts = DemoOptions {
            seed: if seed == 0 { defaults.seed } else { seed },
            out_dir: dir.path().join(format!("demo{seed}")),
            sentences: 4,
            side_view: false,
            write_model: false,
            ..defaults
        };
        let out = generate(&opts).unwrap();
        for clip in &out.speakers[0].clips {
            let truth = read_track(&clip.true_csv).unwrap();
            let mut tracked = read_track(&clip.tracked_csv).unwrap();
            let frames =
                FrameSource::open(clip.front_dir.as_ref().unwrap(), &FrameOptions::default())
                    .unwrap();
            // The demo's own errors undone: only the lasting drag is to be wrong.
            for err in &clip.injected_errors {
                let pts = &mut tracked.frames[err.frame].points;
                match err.other {
                    Some(o) => pts.swap(err.point, o),
                    None => {
                        pts[err.point].x -= err.dx;
                        pts[err.point].y -= err.dy;
                    }
                }
            }
            let n = tracked.frames.len();
            let tracked_pts: Vec<_> = (0..n).map(|f| points(&tracked, f)).collect();
            let truth_pts: Vec<_> = (0..n).map(|f| points(&truth, f)).collect();
            for err in &clip.injected_errors {
                let f = err.frame;
                let d = match err.other {
                    None => Vector2::new(err.dx, err.dy),
                    Some(o) => Vector2::new(0.0, truth_pts[f][o].y - truth_pts[f][err.point].y),
                };
                let (lip, fixed) =
                    if UPPER_LIP.contains(&err.point) || [48, 60].contains(&err.point) {
                        (UPPER_LIP, UPPER_FIXED)
                    } else {
                        (LOWER_LIP, LOWER_FIXED)
                    };
                let (c, end) = propagate_dragged_lip(
                    t,
                    &frames,
                    &tracked_pts,
                    &truth_pts,
                    f,
                    DEMO_SPAN,
                    (&lip, &fixed),
                    d,
                );
                println!(
                    "seed {seed} {} frame {f} (lip moved {:.0},{:.0} px for {DEMO_SPAN} frames): \
                     {}; {end:?}",
                    clip.name,
                    d.x,
                    d.y,
                    c.line()
                );
                if matches!(end, PropagationEnd::MaxFrames) || c.past_frames > 2 {
                    late.push((seed, f, end));
                }
                sum += c;
                cases += 1;
            }
        }
    }
    assert!(cases >= 12, "too few injected errors to judge: {cases}");
    println!("seeds {seeds:?}, {cases} errors: {}", sum.line());
    assert!(sum.fall() >= 0.5, "the dragged lip's error fell by only {:.0} %", 100.0 * sum.fall());
    assert!(
        sum.past_after - sum.past_before <= sum.past_spread,
        "frames after the drag got worse by more than the cascade's spread: {}",
        sum.line()
    );
    assert!(late.len() * 4 <= cases, "walks that did not stop soon after the drag: {late:?}");
}

/// Propagation on the real clip against dlib's tracks: lipmap's lower lip dragged up onto the
/// tongue by 0.1 eye distance for 8 frames (the length of dlib's own error there) from every
/// tenth frame (the design frame 57 left out), its midline corrected to dlib's on the first.
/// Then the design case as the TUI makes it (frame 57, points 58 and 67 moved 2 and 5 px
/// down): which frames change, by how much, and where the walk stops.
#[test]
fn propagating_a_carphone_correction_stops_where_the_tracker_is_right() {
    let Some(Carphone { tracker: t, dlib, shift, frames, ours }) = carphone() else { return };
    let n = frames.len();
    let tracked: Vec<_> = (0..n).map(|f| points(&ours.track, f)).collect();
    let reference: Vec<Vec<Vector2<f64>>> =
        (0..n).map(|f| points(&dlib, f).iter().map(|p| p + shift).collect()).collect();
    let mut sum = Carried::default();
    for first in (5..n - 10).step_by(10).filter(|f| !(DESIGN_FRAME - 8..=DESIGN_FRAME).contains(f))
    {
        let up = Vector2::new(0.0, -0.1 * (reference[first][36] - reference[first][45]).norm());
        let (c, end) = propagate_dragged_lip(
            t,
            &frames,
            &tracked,
            &reference,
            first,
            8,
            (&LOWER_LIP, &LOWER_FIXED),
            up,
        );
        println!("carphone from frame {first}: {}; {end:?}", c.line());
        sum += c;
    }
    println!("carphone, lower lip dragged for 8 frames: {}", sum.line());
    assert!(sum.fall() >= 0.5, "the dragged lip's error fell by only {:.0} %", 100.0 * sum.fall());

    // The design case: no lasting drag, the user's own fix of frame 57.
    let f = DESIGN_FRAME;
    let moved = [(57, 2.0), (66, 5.0)];
    let held: Vec<(usize, Vector2<f64>)> =
        moved.iter().map(|&(i, dy)| (i, tracked[f][i] + Vector2::new(0.0, dy))).collect();
    let image = gray_of(&frames, f).unwrap();
    let start = CorrectedFrame { image: image.view(), tracked: &tracked[f], held: &held };
    let walk = (f + 1..n).map(|g| NextFrame {
        frame: g,
        image: gray_of(&frames, g).unwrap(),
        tracked: Some(tracked[g].clone()),
    });
    let p = propagate_realignment(
        &t.predictor,
        t.shape_prior(),
        &start,
        walk,
        &PropagateOptions::default(),
    );
    for (k, shape) in p.shapes.iter().enumerate() {
        let g = f + 1 + k;
        let lower: Vec<f64> = LOWER_LIP.iter().map(|&i| shape[i].y - tracked[g][i].y).collect();
        println!(
            "carphone {f} -> frame {g}: lower lip moved {} px down; face {:.3} eye distances",
            lower.iter().map(|d| format!("{d:.1}")).collect::<Vec<_>>().join(","),
            lipmap::track::tracker::shape_disagreement(&tracked[g], shape)
        );
    }
    println!("carphone {f}: {} frames re-aligned, {:?}", p.shapes.len(), p.end);
    assert!(
        !matches!(p.end, PropagationEnd::MaxFrames | PropagationEnd::ClipEnd),
        "the walk did not stop: {:?}",
        p.end
    );
}

/// The photos with human landmarks, from lipmap's own tracking of them: a lip dragged by 0.1
/// eye distance (lower lip up, upper lip down) and its two midline points corrected to the
/// human ones; and the points as tracked, the two lip points farthest from the human ones
/// corrected (must not get worse by more than the cascade's own spread).
/// `LIPMAP_REALIGN_PHOTOS=a.jpg,b.png` runs it on other photos, each with its `.pts` beside it.
#[test]
fn realigning_the_photos_from_two_human_points() {
    let Some(t) = tracker() else { return };
    let lips: Vec<usize> = (48..68).collect();
    let (mut lips_dragged, mut near) = (LipFigures::default(), (0.0, 0.0, 0.0));
    // Other photos with iBUG-68 `.pts` beside them can be given (held-out checks).
    let photos: Vec<std::path::PathBuf> = match std::env::var("LIPMAP_REALIGN_PHOTOS") {
        Ok(list) => list.split(',').map(std::path::PathBuf::from).collect(),
        Err(_) => {
            let shared = ["takeo.ppm", "einstein.jpg"]
                .map(|name| lipmap::testdata::shared(&format!("data/images/{name}")));
            let Some(found) = shared.into_iter().collect::<Option<Vec<_>>>() else { return };
            found
        }
    };
    for photo in &photos {
        let name = photo.file_name().unwrap().to_string_lossy();
        let human = points(&read_track(&photo.with_extension("pts")).unwrap(), 0);
        let gray = image(photo);
        let ft = FaceTracker {
            predictor: &t.predictor,
            detector: Some(&t.detector),
            options: t.options.clone(),
        };
        let eye = (human[36] - human[45]).norm();
        let mut tracked = ft.track_frame(gray.view(), None).expect("a face").points;
        if mean_error(&tracked, &human, &(0..68).collect::<Vec<_>>()) > eye {
            // The detector's face is someone else's: the user draws a box on the annotated
            // one (the box of the human landmarks stands for it).
            let face = box_from_shape(&t.predictor.mean_shape, &human).unwrap();
            tracked = ft.fit_in_box(gray.view(), face, StartKind::Given).points;
        }
        for (lip, fixed, drag) in [
            (&LOWER_LIP, &LOWER_FIXED, Vector2::new(0.0, -0.1 * eye)),
            (&UPPER_LIP, &UPPER_FIXED, Vector2::new(0.0, 0.1 * eye)),
        ] {
            let shape = dragged(&tracked, lip, drag);
            let r = realign_moved_lip(t, &gray, &shape, &human, (lip, fixed));
            println!("{name}: lip of {fixed:?} dragged {:.1} px: {}", drag.y, r.line(1.0));
            lips_dragged += r;
        }
        let (b, a, spread) = realign_near_right(t, &gray, &tracked, &human, &lips);
        println!(
            "{name}: as tracked, two farthest lip points corrected: other lip points {b:.2} -> \
             {a:.2} px (cascade's own spread {spread:.2} px)"
        );
        near = (near.0 + b, near.1 + a, near.2 + spread);
    }
    println!(
        "photos, {} dragged lips: {}",
        2 * photos.len(),
        lips_dragged.line(2.0 * photos.len() as f64)
    );
    assert!(lips_dragged.fall() >= 0.5, "dragged lips: {lips_dragged:?}");
    assert!(near.1 - near.0 <= near.2, "as tracked: {near:?}");
}

/// The session use cases the TUI's key and `lipmap propagate` call: a demo clip whose tracked
/// lower lip is dragged on one frame; the user corrects its midline; the frame re-aligned in
/// memory brings the other lower-lip points toward the truth without changing the session,
/// and `propagate_session_correction` stores them (marked interpolated) and saves.
#[test]
fn session_realignment_moves_the_lip_and_propagate_saves_it() {
    use lipmap::landmarks::{LandmarkPoint, PointSource};
    use lipmap::session::{Clip, FramesRef, Session, View};
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
    let tracked = Some(ours.track.frames[f].clone());
    let job = TrackJob::Realign { landmarks: landmarks.clone(), tracked, image: None };
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
    let job = TrackJob::Realign { landmarks, tracked: None, image: None };
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
    // 115 parts clearly; 116 (0.023 eye distances) parts within the clip's own spread of
    // the self-check, a doubt that flags no frame by itself (docs/flags.md).
    assert!(rerun.contains(&115), "labelled tracker error at frame 115 not flagged");
    // A real, correctly tracked fast opening, and most of the clip, pass.
    assert!(!rerun.contains(&76), "frame 76 flagged by the self-check");
    assert!(
        rerun.len() * 10 < ours.track.len(),
        "{} frames flagged by the self-check",
        rerun.len()
    );
}
