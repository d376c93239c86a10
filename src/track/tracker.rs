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
//! above [`TrackOptions::redetect_disagreement`] the detector is run again near the face
//! (over the whole image when nothing is found there and the run agrees with itself no
//! better than a shape fitted into texture: after a cut).
//!
//! Start at [`FaceTracker::track_frame`]; [`agreement_confidence`] maps the disagreement to
//! the frame's confidence that the flags read.

use super::cascade::{CascadeStart, GrayImage, GrayView, run_cascade};
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
    /// Roll angles (degrees) the image is also scanned at when looking for a face.
    pub roll_degrees: Vec<f64>,
    /// Smallest face looked for, as a fraction of the image's shorter side (never below the
    /// detector's window). A face smaller than 1/12 of the frame's height has a mouth of a
    /// few pixels, too small to measure lips on; the finest scales it leaves out hold most
    /// of the windows a scan evaluates (the scan's cost falls with the square of the
    /// smallest size).
    pub min_face_fraction: f64,
}

impl Default for TrackOptions {
    fn default() -> Self {
        Self {
            detect: DetectOptions::default(),
            mapping: BoxMapping { scale: 0.864, dx: 0.0, dy: 0.042 },
            redetect_disagreement: 0.05,
            zero_confidence_disagreement: 0.1,
            roll_degrees: vec![-15.0, 15.0],
            min_face_fraction: 1.0 / 12.0,
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
    let scale = shape_scale(a);
    let mean = a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64;
    if scale > 1e-9 { mean / scale } else { f64::INFINITY }
}

/// The scale [`shape_disagreement`] is measured in: the outer eye-corner distance (points
/// 36–45) of a 68-point shape, else the diagonal of its extent (0 for an empty shape).
pub fn shape_scale(a: &[Vector2<f64>]) -> f64 {
    if a.len() == 68 {
        return (a[36] - a[45]).norm();
    }
    let Some(&first) = a.first() else { return 0.0 };
    let (mut lo, mut hi) = (first, first);
    for p in a {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (hi - lo).norm()
}

/// Times the cascade is re-run from the box of its own result after starting from a
/// detection (the start the detector's box gives is rougher than the previous frame's).
pub const DETECTION_REFITS: usize = 2;

/// Most detections a frame's cascade is tried in when looking for the face.
pub const MAX_CANDIDATES: usize = 12;

/// `image` turned by `angle` radians about its centre (bilinear; outside reads 0).
fn rotate_about_centre(image: GrayView<'_>, angle: f64) -> GrayImage {
    let (w, h) = (image.width, image.height);
    let c = Vector2::new((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let (sin, cos) = angle.sin_cos();
    let mut pixels = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            // The source of output pixel (x, y) is it turned back by −angle.
            let d = Vector2::new(x as f64, y as f64) - c;
            let s = c + Vector2::new(cos * d.x + sin * d.y, -sin * d.x + cos * d.y);
            let (x0, y0) = (s.x.floor(), s.y.floor());
            if x0 < 0.0 || y0 < 0.0 || x0 + 1.0 >= w as f64 || y0 + 1.0 >= h as f64 {
                continue;
            }
            let (tx, ty) = (s.x - x0, s.y - y0);
            let (xi, yi) = (x0 as usize, y0 as usize);
            let p = |xx: usize, yy: usize| f64::from(image.pixels[yy * w + xx]);
            let v = (p(xi, yi) * (1.0 - tx) + p(xi + 1, yi) * tx) * (1.0 - ty)
                + (p(xi, yi + 1) * (1.0 - tx) + p(xi + 1, yi + 1) * tx) * ty;
            pixels[y * w + x] = v.round() as u8;
        }
    }
    GrayImage { width: w, height: h, pixels }
}

/// A point of `image` turned by `angle` (as [`rotate_about_centre`]) turned back.
fn turn_back(image: GrayView<'_>, p: Vector2<f64>, angle: f64) -> Vector2<f64> {
    let c = Vector2::new((image.width as f64 - 1.0) / 2.0, (image.height as f64 - 1.0) / 2.0);
    let (sin, cos) = angle.sin_cos();
    let d = p - c;
    c + Vector2::new(cos * d.x + sin * d.y, -sin * d.x + cos * d.y)
}

/// A predictor, a detector and the settings, tracking one clip at a time.
pub struct FaceTracker<'a> {
    pub predictor: &'a ShapePredictor,
    pub detector: Option<&'a HaarCascade>,
    pub options: TrackOptions,
}

impl FaceTracker<'_> {
    /// The faces the detector finds in `image` (windows within `region` when given), as the
    /// predictor's boxes, best supported first within each roll angle; empty without a
    /// detector. The frontal cascades miss a head rolled by more than ~10°, so the image is
    /// also scanned turned by each of [`TrackOptions::roll_degrees`] and the hits turned
    /// back (boxes stay upright: the cascade's similarity warp takes up the roll).
    pub fn detect(&self, image: GrayView<'_>, region: Option<FaceBox>) -> Vec<FaceBox> {
        let Some(cascade) = self.detector else { return Vec::new() };
        // Looking near a known face scans only the region's pixels: the whole image at three
        // roll angles costs more than the rest of a frame's tracking.
        if let Some(r) = region {
            let x0 = r.left.floor().max(0.0) as usize;
            let y0 = r.top.floor().max(0.0) as usize;
            let x1 = ((r.left + r.width).ceil().max(0.0) as usize).min(image.width);
            let y1 = ((r.top + r.height).ceil().max(0.0) as usize).min(image.height);
            if x1 <= x0 || y1 <= y0 {
                return Vec::new();
            }
            let (w, h) = (x1 - x0, y1 - y0);
            let mut pixels = Vec::with_capacity(w * h);
            for y in y0..y1 {
                pixels.extend_from_slice(&image.pixels[y * image.width + x0..y * image.width + x1]);
            }
            let crop = GrayImage { width: w, height: h, pixels };
            let inner = FaceTracker {
                predictor: self.predictor,
                detector: self.detector,
                options: self.options.clone(),
            };
            return inner
                .detect(crop.view(), None)
                .into_iter()
                .map(|b| FaceBox { left: b.left + x0 as f64, top: b.top + y0 as f64, ..b })
                .collect();
        }
        let mut out = Vec::new();
        for &deg in std::iter::once(&0.0).chain(&self.options.roll_degrees) {
            let turned;
            let (view, angle) = if deg == 0.0 {
                (image, 0.0)
            } else {
                turned = rotate_about_centre(image, deg.to_radians());
                (turned.view(), deg.to_radians())
            };
            let smallest = self.options.min_face_fraction * image.width.min(image.height) as f64;
            let min_size = self.options.detect.min_size.unwrap_or(0.0).max(smallest);
            let opts = DetectOptions {
                region: None,
                min_size: Some(min_size),
                ..self.options.detect.clone()
            };
            for d in detect_faces(cascade, view, &opts) {
                let b = self.options.mapping.apply(&d.face);
                let c = turn_back(
                    image,
                    Vector2::new(b.left + b.width / 2.0, b.top + b.height / 2.0),
                    angle,
                );
                let inside = region.is_none_or(|r| {
                    c.x >= r.left
                        && c.y >= r.top
                        && c.x <= r.left + r.width
                        && c.y <= r.top + r.height
                });
                if inside {
                    out.push(FaceBox { left: c.x - b.width / 2.0, top: c.y - b.height / 2.0, ..b });
                }
            }
        }
        out
    }

    /// The cascade's fit in the detected boxes (at most [`MAX_CANDIDATES`] tried): the
    /// largest face among the fits that agree with their own re-run (a false detection on
    /// texture gives a shape the re-run does not reproduce), else the best agreeing fit.
    /// `None` without a face.
    pub fn detect_and_fit(
        &self,
        image: GrayView<'_>,
        region: Option<FaceBox>,
    ) -> Option<TrackedFrame> {
        let fits: Vec<TrackedFrame> = self
            .detect(image, region)
            .into_iter()
            .take(MAX_CANDIDATES)
            .map(|face| self.fit_in_box(image, face, StartKind::Detected))
            .collect();
        let limit = self.options.redetect_disagreement;
        let largest_agreeing = fits
            .iter()
            .filter(|t| t.disagreement <= limit)
            .max_by(|a, b| a.face.width.total_cmp(&b.face.width));
        largest_agreeing
            .or_else(|| fits.iter().min_by(|a, b| a.disagreement.total_cmp(&b.disagreement)))
            .cloned()
    }

    /// Runs the cascade from `face`, then again from the box of its result, `refits` times
    /// (at least once); returns the last run (the box's fixed point is where dlib's
    /// detector box would have put it) and the last two runs' disagreement. A detection
    /// box is a rougher start than the previous frame's, so it gets [`DETECTION_REFITS`].
    pub fn fit_in_box(&self, image: GrayView<'_>, face: FaceBox, start: StartKind) -> TrackedFrame {
        let refits = if start == StartKind::Previous { 1 } else { DETECTION_REFITS };
        let mut face = face;
        let mut last = run_cascade(self.predictor, image, &face, &CascadeStart::default());
        let mut disagreement = f64::INFINITY;
        for _ in 0..refits.max(1) {
            face = box_from_shape(&self.predictor.mean_shape, &last).unwrap_or(face);
            let next = run_cascade(self.predictor, image, &face, &CascadeStart::default());
            disagreement = shape_disagreement(&last, &next);
            last = next;
        }
        TrackedFrame {
            points: last,
            face,
            start,
            disagreement,
            confidence: agreement_confidence(
                disagreement,
                self.options.zero_confidence_disagreement,
            ),
        }
    }

    /// The landmarks of `image`, from the previous frame's when given, else from a
    /// detection; looks for the face again when the run from the previous frame disagrees
    /// with its re-run: near the previous face, then, when nothing better is there and the
    /// run's confidence is 0, over the whole image. `None` when there is no previous frame
    /// and no face is found.
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
                let again = self
                    .detect_and_fit(image, Some(near))
                    .filter(|d| d.disagreement < t.disagreement);
                // Nothing better near the last face and the run from it is no face at all
                // (a cut, the next of unrelated photos): look over the whole image.
                let again = match again {
                    None if t.disagreement > self.options.zero_confidence_disagreement => {
                        self.detect_and_fit(image, None).filter(|d| d.disagreement < t.disagreement)
                    }
                    found => found,
                };
                Some(again.unwrap_or(t))
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
    fn a_point_turned_with_the_image_turns_back_to_where_it_was() {
        // Odd sides put a pixel exactly at the centre of the turn.
        let px: Vec<u8> = (0..41 * 31).map(|i| (i % 251) as u8).collect();
        let img = GrayView { width: 41, height: 31, pixels: &px };
        let turned = rotate_about_centre(img, 0.3);
        assert!(turned.pixels[15 * 41 + 20].abs_diff(px[15 * 41 + 20]) <= 1, "centre");
        let c = Vector2::new(20.0, 15.0);
        let p = Vector2::new(25.0, 18.0);
        let (sin, cos) = 0.3f64.sin_cos();
        let d = p - c;
        let q = c + Vector2::new(cos * d.x - sin * d.y, sin * d.x + cos * d.y);
        assert!((turn_back(img, q, 0.3) - p).norm() < 1e-9);
    }

    #[test]
    fn disagreement_is_in_eye_distances() {
        let mut a = vec![Vector2::new(0.0, 0.0); 68];
        a[45] = Vector2::new(10.0, 0.0);
        let b: Vec<Vector2<f64>> = a.iter().map(|p| p + Vector2::new(1.0, 0.0)).collect();
        assert!((shape_disagreement(&a, &b) - 0.1).abs() < 1e-12);
    }
}
