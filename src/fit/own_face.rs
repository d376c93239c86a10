//! The head's own face as the frame a map is suggested from: the head drawn from straight in
//! front of its face (axes from the hand labels), and dlib's 68-point shape predictor (the
//! tracker's, [`crate::track`]) run on that drawing with the hand labels *held* on their
//! vertices' projections.
//!
//! Matching a video frame instead ([`super::map_suggest`] with the session's tracked points)
//! places every landmark where the *speaker's* face has it, carried onto the head by the
//! labels' warp: a small, turned face (carphone's is 31 px across the eyes, a pixel about
//! 3 mm) of another person, whose lips, eyes and brows are not the head's. The drawing is
//! the head itself, frontal and large ([`EYE_SPAN_PX`] across the outer eye corners), so the
//! trees read the head's own eye fissures, nostrils, lip contour and jaw outline from its
//! shading. The predictor was trained on photographs; a shaded drawing of bare geometry is
//! not one, and the held labels keep its points where the user put them while the trees move
//! the others to agree with them and with the drawing (the re-alignment of
//! [`crate::track::realign`], Kazemi & Sullivan 2014 with held points: our departure).
//! Of its result only the nose and the lips are the trees' reading of the drawing; the eyes,
//! brows and jaw, which bare geometry does not show, are its mean shape on the labels
//! ([`FROM_MEAN_SHAPE`]).
//!
//! Start with [`own_face_landmarks`]; its result goes to [`super::map_suggest::suggest_map`]
//! as the frame, with its pose.

use super::camera::OrthoPose;
use super::suggest::{SuggestError, SuggestHead};
use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS};
use crate::math::{Point3, Real, Vector3};
use crate::model::LandmarkMap;
use crate::render::{Camera, RenderOptions, render_mesh_with_depth};
use crate::track::{CascadeStart, GrayImage, ShapePredictor, box_from_shape, run_cascade};
use crate::transfer::HeadFrame;
use nalgebra::{Matrix2, Vector2};

/// The drawing's outer eye-corner distance in pixels: the size of a face in dlib's training
/// photographs (300-W faces are 100–400 px across), and a pixel of about half a millimetre
/// on an adult head.
pub const EYE_SPAN_PX: Real = 180.0;
/// Labels needed: as many as a pose from a frame needs ([`super::suggest::MIN_LABELS_FOR_POSE`]),
/// so the user is asked for the same whichever the suggestions are matched to (the face's
/// axes need points above and below the nose and the nose; the mean shape's similarity four
/// numbers).
pub const MIN_LABELS: usize = super::suggest::MIN_LABELS_FOR_POSE;

/// The landmarks (0-based iBUG ranges) taken from the predictor's mean shape placed on the
/// labels rather than from its trees: the jaw (1–17), the brows (18–27) and the eyes
/// (37–48). A drawing of bare geometry has no brow hair, no iris and no lid margin, and the
/// face's outline is the background's edge: on the faces the method was chosen on (menpo3d's
/// `james` scan with human landmarks, SFM identities 1–10) the trees put the eyes 4–8 mm up
/// onto the lid crease, the brows 8–14 mm off and the jaw 8–18 mm off in 2D, while the mean
/// shape on the six labels is nearer for all three (docs/labelling.md). The jaw's points
/// only give where along the jaw each lies ([`super::jaw_contour`] puts them on the
/// outline), so for the jaw this is the prior of where annotators put them relative to the
/// other landmarks. The nose and the lips, which shading does show, stay the trees'.
const FROM_MEAN_SHAPE: [std::ops::Range<usize>; 3] = [0..17, 17..27, 36..48];

/// The head's face as the predictor sees it.
#[derive(Clone, Debug)]
pub struct OwnFace {
    /// 68 points on the drawing (pixels, y down), every one visible; the labelled ones on
    /// their vertices' projections.
    pub landmarks: FrameLandmarks,
    /// The drawing's camera (head units → pixels).
    pub pose: OrthoPose,
    pub image_height: Real,
}

/// Draws `head` from the front of its face and runs `predictor` on the drawing with the
/// landmarks `labels` maps held on their vertices.
///
/// # Errors
/// `TooFewLabels` below [`MIN_LABELS`] labels on the head; `Pose` when the labels do not
/// give the face's axes (points above and below the nose tip, and the nose tip or base) or
/// have no spread; `NoVertices`; `NoSurface` for a head without triangles to draw.
pub fn own_face_landmarks(
    head: &SuggestHead,
    labels: &LandmarkMap,
    predictor: &ShapePredictor,
) -> Result<OwnFace, SuggestError> {
    let vertices = head.vertices;
    if vertices.is_empty() {
        return Err(SuggestError::NoVertices);
    }
    if head.triangles.is_empty() {
        return Err(SuggestError::NoSurface);
    }
    let labelled: Vec<(usize, Point3)> = labels
        .pairs()
        .filter(|(l, _)| *l < N_LANDMARKS && *l < predictor.num_parts())
        .filter_map(|(l, v)| Some((l, *vertices.get(v)?)))
        .collect();
    if labelled.len() < MIN_LABELS {
        return Err(SuggestError::TooFewLabels(labelled.len()));
    }
    let frame = HeadFrame::from_landmarks(labels, vertices).ok_or_else(|| {
        SuggestError::Pose(
            "the labels do not give the face's axes: label the nose tip and points above \
             (eyes) and below it (mouth, chin)"
                .into(),
        )
    })?;
    // The mean shape (box-normalised, y down) onto the labels seen from the front (head
    // units, y down): scale c and the box's centre in the face plane.
    let mean = &predictor.mean_shape;
    let front = |p: &Point3| {
        let q = frame.local(p);
        Vector2::new(q.x, -q.y)
    };
    let pairs: Vec<(Vector2<Real>, Vector2<Real>)> =
        labelled.iter().map(|(l, p)| (mean[*l].cast::<Real>(), front(p))).collect();
    let (scale_rotation, offset) =
        similarity(&pairs).ok_or_else(|| SuggestError::Pose("the labels have no spread".into()))?;
    let c = scale_rotation.column(0).norm();
    let eye_span = c * (mean[36] - mean[45]).cast::<Real>().norm();
    if !(eye_span.is_finite() && eye_span > 0.0) {
        return Err(SuggestError::Pose("the labels have no spread".into()));
    }
    let s = EYE_SPAN_PX / eye_span;
    // The box's centre in the face plane, and an image twice the box's side around it.
    let centre = scale_rotation * Vector2::new(0.5, 0.5) + offset;
    let side = (2.0 * c * s).ceil().clamp(64.0, 4096.0);
    let (width, height) = (side as u32, side as u32);
    // u = s·(x + tx) puts the centre mid-image; v = H − s·(y + ty), with y = −centre.y.
    let pose = OrthoPose {
        r: frame.axes,
        s,
        tx: 0.5 * side / s - centre.x,
        ty: 0.5 * side / s + centre.y,
    };
    let camera = Camera { pose, width, height };
    let options = RenderOptions {
        // A dark surround and a light from the front and above: the drawing's contrast is
        // the head's own shading (creases, fissures, the outline), nothing else.
        background: [0, 0, 0],
        light: Vector3::new(0.0, 0.3, 1.0),
        ambient: 0.2,
    };
    let drawn =
        render_mesh_with_depth(vertices, head.triangles, &[[200, 200, 200]], &camera, &options)
            .map_err(|e| SuggestError::Pose(format!("the head cannot be drawn: {e}")))?;
    let gray = GrayImage::from_rgb(width as usize, height as usize, drawn.image.as_raw());
    let image_height = Real::from(height);
    let held: Vec<(usize, Vector2<Real>)> = labelled
        .iter()
        .map(|(l, p)| {
            let q = pose.project(p, image_height);
            (*l, Vector2::new(q.x, q.y))
        })
        .collect();
    let start: Vec<Vector2<Real>> = mean
        .iter()
        .map(|m| {
            let q = scale_rotation * m.cast::<Real>() + offset;
            let p = pose.project(
                &Point3::from(frame.axes.transpose() * Vector3::new(q.x, -q.y, 0.0)),
                image_height,
            );
            Vector2::new(p.x, p.y)
        })
        .collect();
    let face = box_from_shape(mean, &start)
        .ok_or_else(|| SuggestError::Pose("the labels have no spread".into()))?;
    let mut shape = run_cascade(
        predictor,
        gray.view(),
        &face,
        &CascadeStart { shape: Some(&start), held: &held, carry: None },
    );
    // What the drawing cannot show is taken from the mean shape on the labels, not from the
    // trees: see [`FROM_MEAN_SHAPE`].
    let n = shape.len().min(start.len());
    for l in FROM_MEAN_SHAPE.into_iter().flatten().filter(|&l| l < n) {
        shape[l] = start[l];
    }
    for &(l, p) in &held {
        shape[l] = p;
    }
    let points = shape.iter().map(|p| LandmarkPoint::tracked(p.x, p.y)).collect();
    Ok(OwnFace { landmarks: FrameLandmarks::new(0, points), pose, image_height })
}

/// The least-squares similarity `y ≈ c·R·x + t` over the pairs (x, y) (Umeyama 1991 in its
/// 2D closed form, as [`crate::track::similarity`]): `(c·R, t)`, `None` without spread.
fn similarity(pairs: &[(Vector2<Real>, Vector2<Real>)]) -> Option<(Matrix2<Real>, Vector2<Real>)> {
    let n = pairs.len() as Real;
    let mx = pairs.iter().map(|p| p.0).sum::<Vector2<Real>>() / n;
    let my = pairs.iter().map(|p| p.1).sum::<Vector2<Real>>() / n;
    let (mut sxx, mut dot, mut cross) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        let (x, y) = (x - mx, y - my);
        sxx += x.norm_squared();
        dot += x.dot(&y);
        cross += x.x * y.y - x.y * y.x;
    }
    if !(sxx > 0.0 && sxx.is_finite()) {
        return None;
    }
    let (a, b) = (dot / sxx, cross / sxx);
    let sr = Matrix2::new(a, -b, b, a);
    Some((sr, my - sr * mx))
}
