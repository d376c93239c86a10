//! Synthetic side views for the unit tests: a face silhouette whose forward edge is a known
//! function of the row, drawn with exact anti-aliasing (each pixel's gray level is the share
//! of it the face covers), so every step's output has a known answer.

use super::{Facing, ProfileSetup, Rect, ReferenceLine};
use image::{GrayImage, Luma};

pub(super) const FACE: u8 = 200;
pub(super) const BACKGROUND: u8 = 40;
pub(super) const WIDTH: u32 = 200;
pub(super) const HEIGHT: u32 = 240;

fn bump(y: f64, centre: f64, sigma: f64) -> f64 {
    (-0.5 * ((y - centre) / sigma).powi(2)).exp()
}

/// The forward edge (px, facing right) of a profile: forehead at x = 100, a nasion dip at
/// row 70, the nose tip at row 110 (x ≈ 130), the subnasale concavity near row 133, the
/// upper lip's apex at row 145 (x ≈ 112), the stomion, the lower lip at row 170, the chin.
pub(super) fn face_edge(y: f64) -> f64 {
    100.0 - 4.0 * bump(y, 70.0, 6.0)
        + 30.0 * bump(y, 110.0, 9.0)
        + 12.0 * bump(y, 145.0, 5.0)
        + 10.0 * bump(y, 170.0, 5.0)
}

/// Rows of the upper lip's apex and its x, found by dense sampling of [`face_edge`].
pub(super) fn lip_apex() -> (f64, f64) {
    (1350..1550)
        .map(|k| k as f64 / 10.0)
        .map(|y| (y, face_edge(y)))
        .fold((0.0, f64::MIN), |a, b| if b.1 > a.1 { b } else { a })
}

/// A `WIDTH` × `HEIGHT` image, face (gray `face`) left of `edge(row)`, background right of it,
/// mirrored when `facing` is left. Pixel `i` covers `[i − 0.5, i + 0.5)`.
pub(super) fn draw(edge: impl Fn(f64) -> f64, facing: Facing, face: u8, back: u8) -> GrayImage {
    GrayImage::from_fn(WIDTH, HEIGHT, |x, y| {
        let forward = match facing {
            Facing::Right => x,
            Facing::Left => WIDTH - 1 - x,
        };
        let coverage = (edge(y as f64) - (forward as f64 - 0.5)).clamp(0.0, 1.0);
        let v = back as f64 + (face as f64 - back as f64) * coverage;
        Luma([v.round() as u8])
    })
}

/// [`draw`] of [`face_edge`] facing right, face bright on a dark background.
pub(super) fn face() -> GrayImage {
    draw(face_edge, Facing::Right, FACE, BACKGROUND)
}

/// A setup for [`face`]: the mouth crop (rows 125..195, columns 60..160) and a vertical line
/// at x = 100.
pub(super) fn mouth_setup() -> ProfileSetup {
    ProfileSetup::new(Rect::new(60, 125, 100, 70), ReferenceLine::vertical(100.0), Facing::Right)
}
