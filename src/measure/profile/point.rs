//! P per frame and per clip: a frame's [`ProfilePoint`] (P from the reference line,
//! normalised by the nose length), clip extraction in parallel, and a rendered head measured
//! as a video frame. Start at [`extract_protrusion_with`] or [`measure_render`].

use super::lip::{LipProfile, measure_lip_profile};
use super::nose::resolve_nose_length;
#[cfg(doc)]
use super::propose_setup;
use super::{NoseLength, ProfileError, ProfileSetup, Rigid2};
use crate::landmarks::PointSource;
use crate::math::{Point2, Real};
use image::{GrayImage, RgbImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One frame's protrusion, as stored per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfilePoint {
    pub frame: usize,
    /// The upper lip's foremost point (image px); `None` when the frame failed.
    pub upper_lip_px: Option<Point2>,
    /// Signed distance from the reference line, forward positive (px).
    pub p_px: Option<Real>,
    /// `p_px` / nose length; `None` without a nose length.
    pub p_norm: Option<Real>,
    #[serde(default)]
    pub source: PointSource,
    /// This frame → anchor frame (head motion), when the setup follows the head; a
    /// corrected point of this frame is measured through it too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Rigid2>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl ProfilePoint {
    /// A measurement at `point` (image px): P from the setup's line (after `motion` into the
    /// anchor frame, when given), normalised by `nose_px`.
    pub fn at(
        frame: usize,
        point: Point2,
        setup: &ProfileSetup,
        nose_px: Option<Real>,
        source: PointSource,
        motion: Option<Rigid2>,
    ) -> Self {
        let moved = motion.map_or(point, |m| m * point);
        match setup.reference_line.signed_distance(moved, setup.facing) {
            Some(p) => Self {
                frame,
                upper_lip_px: Some(point),
                p_px: Some(p),
                p_norm: nose_px.map(|l| p / l),
                source,
                motion,
                failed: None,
            },
            None => Self::failure(frame, &ProfileError::BadReferenceLine),
        }
    }

    /// A failed frame, saying why.
    pub fn failure(frame: usize, error: &ProfileError) -> Self {
        Self {
            frame,
            upper_lip_px: None,
            p_px: None,
            p_norm: None,
            source: PointSource::Tracked,
            motion: None,
            failed: Some(error.to_string()),
        }
    }

    pub(super) fn measured(frame: usize, m: &LipProfile, nose_px: Option<Real>) -> Self {
        Self {
            frame,
            upper_lip_px: Some(m.upper_lip_px),
            p_px: Some(m.p_px),
            p_norm: nose_px.map(|l| m.p_px / l),
            source: PointSource::Tracked,
            motion: m.motion,
            failed: None,
        }
    }
}

/// Measures frame number `frame`: never fails, a bad frame is flagged in `failed`.
pub fn measure_frame(
    frame: usize,
    image: &GrayImage,
    setup: &ProfileSetup,
    nose_px: Option<Real>,
) -> ProfilePoint {
    match measure_lip_profile(image, setup) {
        Ok(m) => ProfilePoint::measured(frame, &m, nose_px),
        Err(e) => ProfilePoint::failure(frame, &e),
    }
}

/// Measures the rendered side view of a fitted head exactly as a video frame, so head and
/// speaker are measured alike. A nose length `FromProfile` is found on the render itself.
/// Give it a setup made on a render of the head (e.g. [`propose_setup`] on the neutral
/// render): an anchor captured on the speaker's video would register the head's profile to
/// the speaker's.
///
/// # Errors
/// As [`measure_lip_profile`] and [`resolve_nose_length`].
pub fn measure_render(
    render: &RgbImage,
    setup: &ProfileSetup,
) -> Result<ProfilePoint, ProfileError> {
    let gray = image::imageops::grayscale(render);
    let nose = resolve_nose_length(setup, &gray)?;
    let m = measure_lip_profile(&gray, setup)?;
    Ok(ProfilePoint::measured(0, &m, nose))
}

/// Measures a clip's frames (numbered from 0 in iteration order) in parallel. A nose length
/// `FromProfile` is found once, on the first frame; if that fails, every point says why and
/// `p_norm` stays `None`.
pub fn extract_protrusion<I>(frames: I, setup: &ProfileSetup) -> Vec<ProfilePoint>
where
    I: Iterator<Item = GrayImage> + Send,
{
    let mut frames = frames.enumerate().peekable();
    let nose = match frames.peek() {
        Some((_, first)) => resolve_nose_length(setup, first),
        None => return Vec::new(),
    };
    let mut out: Vec<ProfilePoint> =
        frames.par_bridge().map(|(i, img)| measure_with_nose(i, &img, setup, &nose)).collect();
    out.sort_by_key(|p| p.frame);
    out
}

/// Measures frames `0..n_frames` fetched by `fetch` (e.g. decoding from disk) in parallel;
/// a frame that cannot be fetched is flagged with the fetch error.
pub fn extract_protrusion_with<F>(
    n_frames: usize,
    fetch: F,
    setup: &ProfileSetup,
) -> Vec<ProfilePoint>
where
    F: Fn(usize) -> Result<GrayImage, String> + Sync,
{
    let nose = match setup.nose {
        NoseLength::FromProfile => (0..n_frames)
            .find_map(|i| fetch(i).ok())
            .map_or(Err(ProfileError::NoseNotFound), |img| resolve_nose_length(setup, &img)),
        _ => resolve_nose_length(setup, &GrayImage::new(1, 1)),
    };
    (0..n_frames)
        .into_par_iter()
        .map(|i| match fetch(i) {
            Ok(img) => measure_with_nose(i, &img, setup, &nose),
            Err(e) => ProfilePoint {
                failed: Some(e),
                ..ProfilePoint::failure(i, &ProfileError::NoseNotFound)
            },
        })
        .collect()
}

fn measure_with_nose(
    frame: usize,
    image: &GrayImage,
    setup: &ProfileSetup,
    nose: &Result<Option<Real>, ProfileError>,
) -> ProfilePoint {
    let mut p = measure_frame(frame, image, setup, nose.clone().ok().flatten());
    if let (Err(e), None) = (nose, &p.failed) {
        p.failed = Some(format!("nose length: {e}"));
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::synthetic::{face, lip_apex, mouth_setup};

    #[test]
    fn a_point_is_measured_from_the_line_and_normalised() {
        let setup = mouth_setup();
        let p = ProfilePoint::at(
            3,
            Point2::new(112.0, 145.0),
            &setup,
            Some(40.0),
            PointSource::Corrected,
            None,
        );
        assert_eq!((p.p_px, p.p_norm, p.failed), (Some(12.0), Some(0.3), None));
        // Through a head motion of 2 px back: the point sits 2 px nearer the line.
        let motion = Rigid2::new(nalgebra::Vector2::new(-2.0, 0.0), 0.0);
        let p = ProfilePoint::at(
            3,
            Point2::new(112.0, 145.0),
            &setup,
            None,
            PointSource::Corrected,
            Some(motion),
        );
        assert_eq!((p.p_px, p.p_norm), (Some(10.0), None));
    }

    #[test]
    fn clips_are_measured_in_order_and_failures_say_why() {
        let mut setup = mouth_setup();
        setup.nose = NoseLength::Px(40.0);
        let points = extract_protrusion_with(
            3,
            |i| if i == 1 { Err("unreadable".to_string()) } else { Ok(face()) },
            &setup,
        );
        let (_, x) = lip_apex();
        assert_eq!(points.iter().map(|p| p.frame).collect::<Vec<_>>(), vec![0, 1, 2]);
        assert!((points[0].p_norm.unwrap() - (x - 100.0) / 40.0).abs() < 0.002);
        assert_eq!(points[1].failed.as_deref(), Some("unreadable"));
        let same = extract_protrusion([face(), face(), face()].into_iter(), &setup);
        assert_eq!(same[0], points[0]);
        assert_eq!(same[2], points[2]);
    }

    #[test]
    fn a_nose_that_cannot_be_found_fails_the_normalisation_only() {
        let mut setup = mouth_setup();
        setup.nose = NoseLength::FromProfile;
        setup.crop.y = 90; // above the nose tip: no tip above the crop
        setup.crop.height = 105;
        let p = measure_with_nose(0, &face(), &setup, &resolve_nose_length(&setup, &face()));
        assert!(p.failed.unwrap().starts_with("nose length: "));
    }
}
