//! A clip's cached fits on disk: `NAME.lipmap.d/CLIP.HASH.fits`, in the container of
//! [`super::binary`]. The JSON header holds, per cache entry (one per fit
//! settings, oldest first), the settings, the context hash, the clip-input hash of clip fits
//! and the number of frames; the records follow entry by entry, frames ascending:
//!
//! ```text
//! frame        u32      0-based frame number
//! input        u8 + UTF-8  hash of the landmarks the fit was made from (16 hex digits)
//! flags        u8       1 failed
//! pose         7 f64    yaw, pitch, roll (degrees), scale, tx, ty, reprojection RMS (px)
//! counts       u16 u16  identity and expression coefficients
//! coefficients f64 …    identity, then expression
//! residuals    u8       residual slots (0 or 68), then when > 0: a 9-byte bit set of the
//!                       points with a residual and two f64 (x, y) per point in it
//! failed       u16 + UTF-8  why the frame failed, when flag 1
//! ```
//!
//! Every number is finite: fits are made storable before they are cached
//! ([`super::cache::storable_fit`]).

use super::SessionError;
use super::binary::{Kind, Reader, Writer, mask_has};
use super::cache::{CachedFrame, FitCacheEntry};
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::{MAX_FRAME, N_LANDMARKS};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// The newest fits file version this build reads and the one it writes.
pub const VERSION: u16 = 1;

/// Most coefficients of one kind a cached fit may hold (the largest public models have a
/// few hundred).
pub const MAX_COEFFICIENTS: usize = 4096;

/// Longest failure reason kept, in bytes.
pub const MAX_REASON_BYTES: usize = 4096;

const FAILED: u8 = 1;

/// The smallest record: frame, empty input, flags, pose, counts, no residuals.
const MIN_RECORD_BYTES: u64 = 4 + 1 + 1 + 7 * 8 + 4 + 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    entries: Vec<EntryHead>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryHead {
    settings: FitSettings,
    context: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    clip_input: Option<String>,
    frames: u64,
}

/// Writes the cache `entries` of one clip to `out`; returns the checksum (the file's name).
/// The fits must be storable ([`super::cache::storable_fit`]).
///
/// # Errors
/// The writer's I/O error.
pub fn write_fits(out: impl Write, entries: &[FitCacheEntry]) -> std::io::Result<u64> {
    let header = Header {
        entries: entries
            .iter()
            .map(|e| EntryHead {
                settings: e.settings.clone(),
                context: e.context.clone(),
                clip_input: e.clip_input.clone(),
                frames: e.frames.len() as u64,
            })
            .collect(),
    };
    let head = serde_json::to_vec(&header).map_err(std::io::Error::other)?;
    let mut w = Writer::start(out, Kind::Fits, VERSION, &head)?;
    for c in entries.iter().flat_map(|e| &e.frames) {
        let f = &c.fit;
        w.u32(u32::try_from(f.frame).unwrap_or(u32::MAX))?;
        w.short_str(&c.input)?;
        w.u8(if f.failed.is_some() { FAILED } else { 0 })?;
        for v in [f.yaw, f.pitch, f.roll, f.scale, f.tx, f.ty, f.reproj_rms_px] {
            w.f64(v)?;
        }
        w.u16(u16::try_from(f.identity.len()).unwrap_or(u16::MAX))?;
        w.u16(u16::try_from(f.expression.len()).unwrap_or(u16::MAX))?;
        for v in f.identity.iter().chain(&f.expression) {
            w.f64(*v)?;
        }
        w.u8(u8::try_from(f.residuals.len()).unwrap_or(u8::MAX))?;
        if !f.residuals.is_empty() {
            w.mask(|i| f.residuals.get(i).is_some_and(Option::is_some))?;
            for [x, y] in f.residuals.iter().flatten() {
                w.f64(*x)?;
                w.f64(*y)?;
            }
        }
        if let Some(why) = &f.failed {
            let b = why.as_bytes();
            let n = floor_char_boundary(why, MAX_REASON_BYTES);
            w.u16(n as u16)?;
            w.bytes(&b[..n])?;
        }
    }
    w.finish()
}

/// The largest index ≤ `max` that is a char boundary of `s`.
fn floor_char_boundary(s: &str, max: usize) -> usize {
    (0..=max.min(s.len())).rev().find(|&i| s.is_char_boundary(i)).unwrap_or(0)
}

/// Reads the fits file at `path`, expecting `entries` cache entries (what the session says
/// it holds).
///
/// # Errors
/// `Invalid` naming the file, the record and the field at fault: another kind of file, a
/// newer version, a header that disagrees with the session, settings out of bounds, frames
/// out of order, coefficient counts past [`MAX_COEFFICIENTS`] or disagreeing within an entry,
/// non-finite numbers, a bad checksum.
pub fn read_fits(path: &Path, entries: usize) -> Result<Vec<FitCacheEntry>, SessionError> {
    let (mut r, _version, head) = Reader::open(path, Kind::Fits, VERSION)?;
    let h: Header = r.header(&head)?;
    if h.entries.len() != entries {
        return Err(r.fault(
            "header",
            &format!("holds {} cache entries where the session says {entries}", h.entries.len()),
        ));
    }
    let total = h.entries.iter().fold(0u64, |t, e| t.saturating_add(e.frames));
    r.check_count("frames", total, MIN_RECORD_BYTES)?;
    let mut out = Vec::with_capacity(h.entries.len());
    for (k, e) in h.entries.into_iter().enumerate() {
        super::bounds::check_fit_settings(&e.settings)
            .map_err(|m| r.fault(&format!("header: entry {k}: settings"), &m))?;
        let mut frames: Vec<CachedFrame> = Vec::with_capacity(e.frames as usize);
        for n in 0..e.frames {
            r.set_record(format!("entry {k} record {n}"));
            let c = read_record(&mut r)?;
            if frames.last().is_some_and(|l| c.fit.frame <= l.fit.frame) {
                return Err(r.fault("frame", "is out of order or repeated"));
            }
            frames.push(c);
        }
        let entry = FitCacheEntry {
            settings: e.settings,
            context: e.context,
            clip_input: e.clip_input,
            frames,
        };
        super::bounds::check_settings_frames(&entry).map_err(|m| SessionError::Invalid {
            path: path.to_path_buf(),
            message: format!("entry {k}: {m}"),
        })?;
        out.push(entry);
    }
    r.finish()?;
    Ok(out)
}

fn read_record(r: &mut Reader) -> Result<CachedFrame, SessionError> {
    let frame = r.u32("frame")? as usize;
    if frame > MAX_FRAME {
        return Err(r.fault("frame", &format!("{frame} is past the largest frame ({MAX_FRAME})")));
    }
    let input = r.short_str("input")?;
    let flags = r.u8("flags")?;
    if flags & !FAILED != 0 {
        return Err(r.fault("flags", &format!("unknown flags {flags:#04x}")));
    }
    let mut pose = [0.0; 7];
    r.f64s(&mut pose, "pose")?;
    let n_id = usize::from(r.u16("identity count")?);
    let n_ex = usize::from(r.u16("expression count")?);
    for (n, what) in [(n_id, "identity count"), (n_ex, "expression count")] {
        if n > MAX_COEFFICIENTS {
            return Err(r.fault(what, &format!("{n} is more than {MAX_COEFFICIENTS}")));
        }
    }
    let mut identity = vec![0.0; n_id];
    r.f64s(&mut identity, "identity")?;
    let mut expression = vec![0.0; n_ex];
    r.f64s(&mut expression, "expression")?;
    let slots = usize::from(r.u8("residual count")?);
    if slots > N_LANDMARKS {
        return Err(r.fault("residual count", &format!("{slots} is more than {N_LANDMARKS}")));
    }
    let mut residuals = vec![None; slots];
    if slots > 0 {
        let m = r.mask("residual points")?;
        if (slots..72).any(|i| mask_has(&m, i)) {
            return Err(r.fault("residual points", &format!("name a point past {}", slots - 1)));
        }
        for (i, slot) in residuals.iter_mut().enumerate() {
            if mask_has(&m, i) {
                let mut xy = [0.0; 2];
                r.f64s(&mut xy, "residuals")?;
                *slot = Some(xy);
            }
        }
    }
    let failed = if flags & FAILED != 0 {
        let n = usize::from(r.u16("failed")?);
        if n > MAX_REASON_BYTES {
            return Err(r.fault("failed", &format!("{n} bytes is more than {MAX_REASON_BYTES}")));
        }
        let mut b = vec![0u8; n];
        r.fill(&mut b, "failed")?;
        Some(String::from_utf8(b).map_err(|_| r.fault("failed", "is not UTF-8 text"))?)
    } else {
        None
    };
    let [yaw, pitch, roll, scale, tx, ty, reproj_rms_px] = pose;
    let fit = FrameFit {
        frame,
        yaw,
        pitch,
        roll,
        scale,
        tx,
        ty,
        identity,
        expression,
        reproj_rms_px,
        residuals,
        failed,
    };
    Ok(CachedFrame { input, fit })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(frame: usize, failed: bool) -> CachedFrame {
        let mut residuals = vec![None; N_LANDMARKS];
        residuals[48] = Some([0.5, -0.25]);
        residuals[67] = Some([1e-300, 3.0]);
        let fit = FrameFit {
            frame,
            yaw: 1.5,
            pitch: -2.0,
            roll: 0.1,
            scale: 0.003,
            tx: 120.0,
            ty: 99.5,
            identity: vec![0.1, -0.2, 0.3],
            expression: vec![0.7],
            reproj_rms_px: 1.25,
            residuals,
            failed: failed.then(|| "too few landmarks: ünïcode".to_string()),
        };
        CachedFrame { input: format!("{frame:016x}"), fit }
    }

    fn entries() -> Vec<FitCacheEntry> {
        let clip_fit = FitSettings { clip: true, ..FitSettings::default() };
        vec![
            FitCacheEntry {
                settings: FitSettings::default(),
                context: "0123456789abcdef".into(),
                clip_input: None,
                frames: vec![fit(0, false), fit(1, true), fit(7, false)],
            },
            FitCacheEntry {
                settings: clip_fit,
                context: "fedcba9876543210".into(),
                clip_input: Some("00000000000000ff".into()),
                frames: vec![],
            },
        ]
    }

    fn written(dir: &Path, e: &[FitCacheEntry]) -> std::path::PathBuf {
        let p = dir.join("c.fits");
        let mut bytes = Vec::new();
        write_fits(&mut bytes, e).unwrap();
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn cached_fits_round_trip_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let e = entries();
        let p = written(dir.path(), &e);
        assert_eq!(read_fits(&p, 2).unwrap(), e);
    }

    #[test]
    fn hostile_fits_files_are_refused_naming_record_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let p = written(dir.path(), &entries());
        let e = read_fits(&p, 1).unwrap_err().to_string();
        assert!(e.contains("holds 2 cache entries where the session says 1"), "{e}");
        let mut bad = entries();
        bad[0].frames[2].fit.frame = 1;
        let e = read_fits(&written(dir.path(), &bad), 2).unwrap_err().to_string();
        assert!(e.contains("entry 0 record 2: frame: is out of order"), "{e}");
        let mut bad = entries();
        bad[0].frames[0].fit.yaw = f64::INFINITY;
        let e = read_fits(&written(dir.path(), &bad), 2).unwrap_err().to_string();
        assert!(e.contains("entry 0 record 0: pose[0]: is not a finite number"), "{e}");
        let mut bad = entries();
        bad[0].frames[2].fit.identity.push(1.0);
        let e = read_fits(&written(dir.path(), &bad), 2).unwrap_err().to_string();
        assert!(e.contains("entry 0: cached fit of frame 7 has 4 identity"), "{e}");
        let mut bad = entries();
        bad[1].settings.lambda = -1.0;
        let e = read_fits(&written(dir.path(), &bad), 2).unwrap_err().to_string();
        assert!(e.contains("header: entry 1: settings: lambda -1"), "{e}");
    }
}
