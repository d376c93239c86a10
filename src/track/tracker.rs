//! Tracking a face through a clip: a detector finds the face on the first frame, each next
//! frame starts from the box of the previous frame's landmarks, and the cascade's agreement
//! with its own re-run tells when to look for the face again.
//!
//! The predictor was trained from boxes a detector drew, so every run starts from a box:
//! a detection mapped onto the box dlib's detector would draw ([`BoxMapping`]), or the box
//! that best places the mean shape on the previous frame's landmarks
//! ([`box_from_shape`]). The self-check re-runs the cascade from the box of its own result:
//! on a face it has locked onto, that run lands where the first did; when the start was off
//! (fast motion, a cut, an occlusion) the two disagree, the frame's confidence drops, and
//! above [`TrackOptions::redetect_disagreement`] the detector is run again near the face.
//!
//! Start at [`FaceTracker::track_frame`]; [`agreement_confidence`] maps the disagreement to
//! the frame's confidence that the flags read.

use super::cascade::{CascadeStart, GrayView, run_cascade};
use super::haar_file::HaarCascade;
use super::predictor_file::ShapePredictor;
use super::similarity::{FaceBox, box_from_shape};
use super::viola_jones::{DetectOptions, detect_faces};
use nalgebra::Vector2;

/// How a Viola–Jones box maps onto the box dlib's detector draws (the predictor's training
/// boxes): same centre shifted by `dy` of the box's side, side scaled by `scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxMapping {
    pub scale: f64,
    pub dx: f64,
    pub dy: f64,
}

impl BoxMapping {
    /// The predictor's box for a detection.
    pub fn apply(&self, b: &FaceBox) -> FaceBox {
        let (cx, cy) = (
            b.left + b.width / 2.0 + self.dx * b.width,
            b.top + b.height / 2.0 + self.dy * b.height,
        );
        let (w, h) = (b.width * self.scale, b.height * self.scale);
        FaceBox { left: cx - w / 2.0, top: cy - h / 2.0, width: w, height: h }
    }
}

/// Tracking settings.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackOptions {
    pub detect: DetectOptions,
    /// Detection → predictor box. Default: the median over carphone's frames where both
    /// OpenCV's `frontalface_alt2` and dlib's HOG detector found the face (70 frames): side
    /// × 0.864, centre 0.042 of the side lower (`docs/tracking.md`).
    pub mapping: BoxMapping,
    /// Above this disagreement (in eye-corner distances, 36–45) between the cascade and its
    /// re-run, the face is looked for again.
    pub redetect_disagreement: f64,
    /// The disagreement at which the frame's confidence reaches 0 (linear from 1 at 0).
    pub zero_confidence_disagreement: f64,
}

impl Default for TrackOptions {
    fn default() -> Self {
        Self {
            detect: DetectOptions::default(),
            mapping: BoxMapping { scale: 0.864, dx: 0.0, dy: 0.042 },
            redetect_disagreement: 0.05,
            zero_confidence_disagreement: 0.1,
        }
    }
}

/// Where a frame's cascade started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartKind {
    /// From a detection on this frame.
    Detected,
    /// From the previous frame's landmarks.
    Previous,
    /// From a box the caller gave.
    Given,
}

/// One frame's landmarks and how far to trust them.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackedFrame {
    /// The shape in image pixels (x right, y down, 0-based pixel centres).
    pub points: Vec<Vector2<f64>>,
    /// The box the cascade ran in.
    pub face: FaceBox,
    pub start: StartKind,
    /// Mean distance between the cascade's result and its re-run from its own box, in
    /// eye-corner distances.
    pub disagreement: f64,
    /// `1 − disagreement / zero_confidence_disagreement`, clamped to [0, 1].
    pub confidence: f32,
}

/// The confidence a disagreement maps to (1 at 0, 0 at `zero_at` and beyond).
pub fn agreement_confidence(disagreement: f64, zero_at: f64) -> f32 {
    if !disagreement.is_finite() || zero_at <= 0.0 {
        return 0.0;
    }
    (1.0 - disagreement / zero_at).clamp(0.0, 1.0) as f32
}

/// Mean point distance between two shapes over the first's outer eye-corner distance
/// (points 36 and 45 of iBUG-68; the shape's own bounding-box diagonal for other layouts).
pub fn shape_disagreement(a: &[Vector2<f64>], b: &[Vector2<f64>]) -> f64 {
    if a.is_empty() || a.len() != b.len() {
        return f64::INFINITY;
    }
    let scale = if a.len() == 68 {
        (a[36] - a[45]).norm()
    } else {
        let (mut lo, mut hi) = (a[0], a[0]);
        for p in a {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (hi - lo).norm()
    };
    let mean = a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64;
    if scale > 1e-9 { mean / scale } else { f64::INFINITY }
}

/// Most detections a frame's cascade is tried in when looking for the face.
pub const MAX_CANDIDATES: usize = 5;

/// A predictor, a detector and the settings, tracking one clip at a time.
pub struct FaceTracker<'a> {
    pub predictor: &'a ShapePredictor,
    pub detector: Option<&'a HaarCascade>,
    pub options: TrackOptions,
}

impl FaceTracker<'_> {
    /// The faces the detector finds in `image` (within `region` when given), as the
    /// predictor's boxes, best supported first; empty without a detector.
    pub fn detect(&self, image: GrayView<'_>, region: Option<FaceBox>) -> Vec<FaceBox> {
        let Some(cascade) = self.detector else { return Vec::new() };
        let opts = DetectOptions { region, ..self.options.detect.clone() };
        detect_faces(cascade, image, &opts)
            .into_iter()
            .map(|d| self.options.mapping.apply(&d.face))
            .collect()
    }

    /// The cascade's fit in the detected box where it agrees best with its own re-run (at
    /// most [`MAX_CANDIDATES`] detections tried): a false detection on texture gives a
    /// shape the re-run does not reproduce, a face one it does. `None` without a face.
    pub fn detect_and_fit(&self, image: GrayView<'_>, region: Option<FaceBox>) -> Option<TrackedFrame> {
        self.detect(image, region)
            .into_iter()
            .take(MAX_CANDIDATES)
            .map(|face| self.fit_in_box(image, face, StartKind::Detected))
            .min_by(|a, b| a.disagreement.total_cmp(&b.disagreement))
    }

    /// Runs the cascade from `face` and re-runs it from the box of its result; returns the
    /// re-run (the box's fixed point is where dlib's detector box would have put it) and
    /// the two runs' disagreement.
    pub fn fit_in_box(&self, image: GrayView<'_>, face: FaceBox, start: StartKind) -> TrackedFrame {
        let first = run_cascade(self.predictor, image, &face, &CascadeStart::default());
        let refit = box_from_shape(&self.predictor.mean_shape, &first).unwrap_or(face);
        let second = run_cascade(self.predictor, image, &refit, &CascadeStart::default());
        let disagreement = shape_disagreement(&first, &second);
        TrackedFrame {
            points: second,
            face: refit,
            start,
            disagreement,
            confidence: agreement_confidence(
                disagreement,
                self.options.zero_confidence_disagreement,
            ),
        }
    }

    /// The landmarks of `image`, from the previous frame's when given, else from a
    /// detection; looks for the face again (near the previous one) when the run from the
    /// previous frame disagrees with its re-run. `None` when there is no previous frame and
    /// no face is found.
    pub fn track_frame(
        &self,
        image: GrayView<'_>,
        previous: Option<&TrackedFrame>,
    ) -> Option<TrackedFrame> {
        let from_previous = previous.and_then(|p| {
            let face = box_from_shape(&self.predictor.mean_shape, &p.points)?;
            Some(self.fit_in_box(image, face, StartKind::Previous))
        });
        match from_previous {
            Some(t) if t.disagreement <= self.options.redetect_disagreement => Some(t),
            Some(t) => {
                let near = FaceBox {
                    left: t.face.left - t.face.width,
                    top: t.face.top - t.face.height,
                    width: 3.0 * t.face.width,
                    height: 3.0 * t.face.height,
                };
                let again = self.detect_and_fit(image, Some(near));
                match again {
                    Some(d) if d.disagreement < t.disagreement => Some(d),
                    _ => Some(t),
                }
            }
            None => self.detect_and_fit(image, None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confidence_falls_linearly_with_disagreement() {
        assert_eq!(agreement_confidence(0.0, 0.1), 1.0);
        assert!((agreement_confidence(0.02, 0.1) - 0.8).abs() < 1e-6);
        assert_eq!(agreement_confidence(0.5, 0.1), 0.0);
        assert_eq!(agreement_confidence(f64::NAN, 0.1), 0.0);
    }

    #[test]
    fn a_mapped_box_keeps_its_centre_shifted_and_scales_its_side() {
        let m = BoxMapping { scale: 0.5, dx: 0.0, dy: 0.1 };
        let b = m.apply(&FaceBox { left: 0.0, top: 0.0, width: 100.0, height: 100.0 });
        assert_eq!(b, FaceBox { left: 25.0, top: 35.0, width: 50.0, height: 50.0 });
    }

    #[test]
    fn disagreement_is_in_eye_distances() {
        let mut a = vec![Vector2::new(0.0, 0.0); 68];
        a[45] = Vector2::new(10.0, 0.0);
        let b: Vec<Vector2<f64>> = a.iter().map(|p| p + Vector2::new(1.0, 0.0)).collect();
        assert!((shape_disagreement(&a, &b) - 0.1).abs() < 1e-12);
    }
}
