//! How the demo's head moves while it speaks, and the front and side cameras that film it.

use crate::math::{Point3, Vector3};
use crate::render::{Camera, View};
use rand::Rng;
use rand::rngs::StdRng;

/// The pose of the head in one frame: rotation angles (degrees) and translation (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HeadMotion {
    pub yaw: f64,
    pub pitch: f64,
    pub roll: f64,
    pub t: Vector3,
}

/// Smooth head motion: a few degrees and about a millimetre, as a seated reader moves.
pub(super) fn head_motion(rng: &mut StdRng, n_frames: usize, fps: f64) -> Vec<HeadMotion> {
    let mut wave = |amp: f64, freq: f64| {
        let a = amp * rng.random_range(0.6..1.0);
        let f = freq * rng.random_range(0.8..1.25);
        let phase = rng.random_range(0.0..std::f64::consts::TAU);
        move |t: f64| a * (std::f64::consts::TAU * f * t + phase).sin()
    };
    // Pitch and forward motion (z) are kept smaller than the rest: in the side view they
    // shift the lips relative to a reference line set once per clip, and a real profile
    // recording would be rejected if the head moved that much.
    let (yaw, pitch, roll) = (wave(2.5, 0.35), wave(0.8, 0.5), wave(1.5, 0.27));
    let (tx, ty, tz) = (wave(1.0, 0.3), wave(0.8, 0.45), wave(0.4, 0.25));
    (0..n_frames)
        .map(|f| {
            let t = f as f64 / fps;
            HeadMotion {
                yaw: yaw(t),
                pitch: pitch(t),
                roll: roll(t),
                t: Vector3::new(tx(t), ty(t), tz(t)),
            }
        })
        .collect()
}

/// Model point (mm) put at the image centre, and pixels per mm at 480 rows.
const FRONT_CENTRE: [f64; 3] = [0.0, -5.0, 70.0];
const SIDE_CENTRE: [f64; 3] = [0.0, 0.0, 60.0];
const FRONT_PX_PER_MM_AT_480: f64 = 1.75;
const SIDE_PX_PER_MM_AT_480: f64 = 2.0;
/// Side frames: a dark plain background so a threshold separates the face's silhouette.
pub const SIDE_BACKGROUND: [u8; 3] = [22, 26, 34];

/// The front and side cameras of a frame.
pub(super) fn frame_cameras(m: &HeadMotion, width: u32, height: u32) -> (Camera, Camera) {
    let r = crate::fit::camera::rotation_from_yaw_pitch_roll_deg(m.yaw, m.pitch, m.roll);
    let k = height as f64 / 480.0;
    let mut front = Camera::looking_at(
        View::Front,
        &r,
        0.0,
        &Point3::from(FRONT_CENTRE),
        FRONT_PX_PER_MM_AT_480 * k,
        width,
        height,
    );
    front.pose.tx += m.t.x;
    front.pose.ty += m.t.y;
    let mut side = Camera::looking_at(
        View::Side,
        &r,
        0.0,
        &Point3::from(SIDE_CENTRE),
        SIDE_PX_PER_MM_AT_480 * k,
        width,
        height,
    );
    let ts = View::Side.rotation() * m.t;
    side.pose.tx += ts.x;
    side.pose.ty += ts.y;
    (front, side)
}
