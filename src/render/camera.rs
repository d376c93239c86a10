//! The virtual camera of the rasteriser: a scaled orthographic pose (the fitter's convention,
//! `u = s·(r1·X + tx)`, `v = H − s·(r2·X + ty)`) plus front and side (profile) views.
//!
//! Depth is `r3·X`: larger means nearer the camera (the camera looks along −z of its own
//! frame, as in eos), so the z-buffer keeps the largest depth. A *view* rotation is applied
//! after the head's own pose: the front view is the identity, the side view turns the head by
//! −90° about y so that its profile faces image right and its right cheek faces the camera.

use crate::fit::camera::{OrthoPose, rotation_from_yaw_pitch_roll_deg, yaw_pitch_roll_deg};
use crate::math::{Matrix3, Point2, Point3, Real, Vector3};

/// Which side of the head the camera looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum View {
    /// Looking at the face along −z of the model (the fitter's view).
    #[default]
    Front,
    /// Looking at the head's right cheek (along +x of the model); the face looks image right.
    Side,
}

impl View {
    /// The rotation from head space to camera space that this view adds after the head pose.
    pub fn rotation(self) -> Matrix3 {
        match self {
            View::Front => Matrix3::identity(),
            // Ry(+90°): model +z (forward) becomes camera +x (image right); model −x (the
            // right cheek) becomes camera +z, i.e. nearest the camera.
            View::Side => rotation_from_yaw_pitch_roll_deg(90.0, 0.0, 0.0),
        }
    }
}

/// A scaled orthographic camera for an image of `width`×`height` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Model-to-camera rotation (rows r1, r2, r3), scale in px per model unit and translation
    /// in model units: exactly the fitter's pose.
    pub pose: OrthoPose,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// A camera from the head pose in degrees (`R = Ry(yaw)·Rx(pitch)·Rz(roll)`, as eos),
    /// the scale (px per model unit) and the translation (model units).
    pub fn from_pose_deg(
        yaw: Real,
        pitch: Real,
        roll: Real,
        scale: Real,
        t: [Real; 2],
        width: u32,
        height: u32,
    ) -> Self {
        let r = rotation_from_yaw_pitch_roll_deg(yaw, pitch, roll);
        Self { pose: OrthoPose { r, s: scale, tx: t[0], ty: t[1] }, width, height }
    }

    /// A camera that sees the head posed by `head` (model → head rotation) from `view`, with
    /// the model point `centre` at the image centre and `scale` px per model unit.
    ///
    /// `pitch_deg` is an extra nod of the head (about model x) applied before the view: for
    /// the side view this is the virtual pitch a user tunes to match a real profile camera.
    pub fn looking_at(
        view: View,
        head: &Matrix3,
        pitch_deg: Real,
        centre: &Point3,
        scale: Real,
        width: u32,
        height: u32,
    ) -> Self {
        let nod = rotation_from_yaw_pitch_roll_deg(0.0, pitch_deg, 0.0);
        let r = view.rotation() * nod * head;
        let c = r * centre.coords;
        // Solve s·(c.x + tx) = W/2 and H − s·(c.y + ty) = H/2 for tx, ty.
        let tx = 0.5 * width as Real / scale - c.x;
        let ty = 0.5 * height as Real / scale - c.y;
        Self { pose: OrthoPose { r, s: scale, tx, ty }, width, height }
    }

    /// A front or side camera that fits the points' bounding box into the image with a
    /// margin (fraction of the image kept free on each side, e.g. 0.05). `None` when the
    /// points are empty, non-finite or all coincide.
    pub fn fit_to_points(
        view: View,
        pitch_deg: Real,
        points: &[Point3],
        margin: Real,
        width: u32,
        height: u32,
    ) -> Option<Self> {
        if points.is_empty() || width == 0 || height == 0 {
            return None;
        }
        let nod = rotation_from_yaw_pitch_roll_deg(0.0, pitch_deg, 0.0);
        let r = view.rotation() * nod;
        let (mut lo, mut hi) =
            (Vector3::repeat(Real::INFINITY), Vector3::repeat(Real::NEG_INFINITY));
        for p in points {
            let c = r * p.coords;
            if !c.iter().all(|v| v.is_finite()) {
                return None;
            }
            lo = lo.inf(&c);
            hi = hi.sup(&c);
        }
        let extent = hi - lo;
        let free = (1.0 - 2.0 * margin.clamp(0.0, 0.45)).max(0.1);
        let sx = free * width as Real / extent.x;
        let sy = free * height as Real / extent.y;
        let scale = match (extent.x > 1e-12, extent.y > 1e-12) {
            (true, true) => sx.min(sy),
            (true, false) => sx,
            (false, true) => sy,
            (false, false) => return None,
        };
        let mid = (lo + hi) * 0.5;
        // `mid` is already in camera space; the centre point in model space is r⁻¹·mid.
        let centre = Point3::from(r.transpose() * mid);
        Some(Self::looking_at(view, &Matrix3::identity(), pitch_deg, &centre, scale, width, height))
    }

    /// Pixel position (x right, y down) of a model-space point.
    pub fn project(&self, p: &Point3) -> Point2 {
        self.pose.project(p, self.height as Real)
    }

    /// Pixel position and depth (larger = nearer) of a model-space point.
    pub fn project_with_depth(&self, p: &Point3) -> (Point2, Real) {
        let c = self.pose.r * p.coords;
        let s = self.pose.s;
        (Point2::new(s * (c.x + self.pose.tx), self.height as Real - s * (c.y + self.pose.ty)), c.z)
    }

    /// (yaw, pitch, roll) in degrees of the whole model-to-camera rotation.
    pub fn yaw_pitch_roll_deg(&self) -> (Real, Real, Real) {
        yaw_pitch_roll_deg(&self.pose.r)
    }

    /// The unit vector, in model space, pointing from the scene towards the camera.
    pub fn towards_camera(&self) -> Vector3 {
        self.pose.r.row(2).transpose()
    }
}

/// Pixel positions of `points` under a scaled orthographic pose in an image `image_height`
/// tall: `u = s·(r1·X + tx)`, `v = H − s·(r2·X + ty)`, the fitter's convention.
pub fn project_points(pose: &OrthoPose, points: &[Point3], image_height: Real) -> Vec<Point2> {
    points.iter().map(|p| pose.project(p, image_height)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looking_at_puts_the_centre_in_the_image_centre() {
        let head = rotation_from_yaw_pitch_roll_deg(3.0, -2.0, 1.0);
        let c = Point3::new(1.0, -20.0, 80.0);
        for view in [View::Front, View::Side] {
            let cam = Camera::looking_at(view, &head, 4.0, &c, 2.0, 720, 480);
            let p = cam.project(&c);
            assert!((p.x - 360.0).abs() < 1e-9 && (p.y - 240.0).abs() < 1e-9, "{view:?} {p}");
        }
    }

    #[test]
    fn side_view_shows_the_face_pointing_right_and_the_right_cheek_nearest() {
        let cam = Camera::looking_at(
            View::Side,
            &Matrix3::identity(),
            0.0,
            &Point3::origin(),
            1.0,
            100,
            100,
        );
        let (front, _) = cam.project_with_depth(&Point3::new(0.0, 0.0, 10.0));
        let (top, _) = cam.project_with_depth(&Point3::new(0.0, 10.0, 0.0));
        let (_, d_right) = cam.project_with_depth(&Point3::new(-10.0, 0.0, 0.0));
        let (_, d_left) = cam.project_with_depth(&Point3::new(10.0, 0.0, 0.0));
        assert!(front.x > 55.0, "nose side goes right: {front}");
        assert!(top.y < 45.0, "up goes up: {top}");
        assert!(d_right > d_left);
    }

    #[test]
    fn fit_to_points_keeps_everything_inside() {
        let pts = vec![Point3::new(-50.0, -80.0, 0.0), Point3::new(50.0, 90.0, 100.0)];
        let cam = Camera::fit_to_points(View::Front, 0.0, &pts, 0.05, 720, 480).unwrap();
        for p in &pts {
            let q = cam.project(p);
            assert!((0.0..=720.0).contains(&q.x) && (0.0..=480.0).contains(&q.y), "{q}");
        }
        assert!(Camera::fit_to_points(View::Front, 0.0, &[], 0.05, 10, 10).is_none());
    }
}
