//! Cached fit results, keyed by the `FitSettings` that made them and by hashes of their
//! inputs, so a changed correction makes only the frames it touches stale.
//!
//! Keys: `context` hashes what every frame of a fit shares (model and blendshapes paths,
//! landmark map); each cached frame stores the hash of its own effective landmarks
//! restricted to the fit's landmark set (correcting a jaw point does not stale an F4 fit).
//! A clip fit (one identity for the whole clip) depends on every frame, so it also stores a
//! hash over all frames and goes stale as a whole. Hashes are 64-bit FNV-1a over exact bit
//! patterns, written as 16 hex digits: stable across builds and platforms, unlike std's
//! `DefaultHasher`.

use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::{FrameLandmarks, LandmarkSet};
use serde::{Deserialize, Serialize};

/// Cached entries kept per clip; older settings are dropped first.
pub const MAX_CACHED_SETTINGS_PER_CLIP: usize = 8;

/// 64-bit FNV-1a.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }

    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    /// A length-prefixed string, so `("ab","c")` and `("a","bc")` differ.
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64).bytes(s.as_bytes())
    }

    pub fn finish(&self) -> u64 {
        self.0
    }

    pub fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Hash of the parts of `frame` a fit with landmark set `set` reads.
pub fn frame_input_hash(frame: &FrameLandmarks, set: LandmarkSet) -> String {
    let mut h = Fnv64::default();
    feed_frame(&mut h, frame, set);
    h.hex()
}

fn feed_frame(h: &mut Fnv64, frame: &FrameLandmarks, set: LandmarkSet) {
    h.u64(frame.frame as u64).u64(u64::from(frame.success));
    for (i, p) in frame.points.iter().enumerate().filter(|(i, _)| set.contains(*i)) {
        h.u64(i as u64).u64(u64::from(p.visible));
        if p.visible {
            h.u64(p.x.to_bits()).u64(p.y.to_bits());
            h.u64(p.confidence.map_or(u64::MAX, |c| u64::from(c.to_bits())));
        }
    }
    // Only when set, so that the hash of a frame whose lips do not meet is what it was before
    // the fit took contacts into account (its cached fit stays valid). The tag names the
    // rule the contact is weighed by (against the tracker's own noise), so fits cached under
    // the earlier rule (against the assumed noise) go stale.
    if let Some(c) = frame.lip_contact_px {
        h.str("lip contact against the tracker's noise").u64(c.to_bits());
    }
}

/// Hash of every frame, for fits that couple the frames of a clip.
pub fn clip_input_hash<'a>(
    frames: impl IntoIterator<Item = &'a FrameLandmarks>,
    set: LandmarkSet,
) -> String {
    let mut h = Fnv64::default();
    let mut n = 0u64;
    for f in frames {
        feed_frame(&mut h, f, set);
        n += 1;
    }
    h.u64(n);
    h.hex()
}

/// One frame's cached fit and the hash of the landmarks it was made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CachedFrame {
    pub input: String,
    pub fit: FrameFit,
}

/// The fits of one clip under one set of settings and one model/map context.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitCacheEntry {
    pub settings: FitSettings,
    /// Hash of the model, blendshapes and landmark map references.
    pub context: String,
    /// Hash of all frames, for clip fits (`settings.clip`); `None` for per-frame fits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_input: Option<String>,
    /// Ascending by frame.
    pub frames: Vec<CachedFrame>,
}

impl FitCacheEntry {
    pub fn frame(&self, frame: usize) -> Option<&CachedFrame> {
        self.frames.binary_search_by_key(&frame, |c| c.fit.frame).ok().map(|i| &self.frames[i])
    }

    /// Adds or replaces frames, keeping the order.
    pub fn merge(&mut self, new: Vec<CachedFrame>) {
        for c in new {
            match self.frames.binary_search_by_key(&c.fit.frame, |x| x.fit.frame) {
                Ok(i) => self.frames[i] = c,
                Err(i) => self.frames.insert(i, c),
            }
        }
    }
}

/// A fit as it can be stored in JSON: non-finite numbers (which JSON cannot hold and which
/// would make the session unloadable) become 0 and the frame is marked failed.
pub fn storable_fit(mut fit: FrameFit) -> FrameFit {
    let mut bad = false;
    let mut fix = |v: &mut f64| {
        if !v.is_finite() {
            *v = 0.0;
            bad = true;
        }
    };
    for v in [
        &mut fit.yaw,
        &mut fit.pitch,
        &mut fit.roll,
        &mut fit.scale,
        &mut fit.tx,
        &mut fit.ty,
        &mut fit.reproj_rms_px,
    ] {
        fix(v);
    }
    fit.identity.iter_mut().for_each(&mut fix);
    fit.expression.iter_mut().for_each(&mut fix);
    for r in fit.residuals.iter_mut() {
        if r.is_some_and(|xy| !(xy[0].is_finite() && xy[1].is_finite())) {
            *r = None;
            bad = true;
        }
    }
    if bad && fit.is_usable() {
        fit.failed = Some("non-finite values in the fit".into());
    }
    fit
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{LandmarkPoint, N_LANDMARKS};

    #[test]
    fn fnv_matches_reference_vectors() {
        assert_eq!(Fnv64::default().finish(), 0xcbf29ce484222325);
        assert_eq!(Fnv64::default().bytes(b"a").finish(), 0xaf63dc4c8601ec8c);
        assert_eq!(Fnv64::default().bytes(b"foobar").finish(), 0x85944171f73967e8);
    }

    #[test]
    fn hash_ignores_points_outside_the_set() {
        let pts: Vec<_> = (0..N_LANDMARKS).map(|i| LandmarkPoint::tracked(i as f64, 1.0)).collect();
        let a = FrameLandmarks::new(0, pts);
        let mut jaw = a.clone();
        jaw.points[3].x += 1.0;
        let mut lip = a.clone();
        lip.points[62].y += 1e-9;
        assert_eq!(frame_input_hash(&a, LandmarkSet::F4), frame_input_hash(&jaw, LandmarkSet::F4));
        assert_ne!(frame_input_hash(&a, LandmarkSet::F5), frame_input_hash(&jaw, LandmarkSet::F5));
        assert_ne!(frame_input_hash(&a, LandmarkSet::F1), frame_input_hash(&lip, LandmarkSet::F1));
    }
}
