//! A clip's tracked landmarks on disk: `NAME.lipmap.d/CLIP.HASH.track`, in the container of
//! [`super::binary`]. Header `{"frames": N, "points": 68}`, then one record per frame,
//! frames ascending:
//!
//! ```text
//! frame        u32      0-based frame number (≤ landmarks::MAX_FRAME)
//! flags        u8       1 success, 2 timestamp, 4 confidence, 8 hidden,
//!                       16 point confidences, 32 point sources
//! timestamp    f64      when flag 2
//! confidence   f32      when flag 4
//! xy           136 f64  x0, y0, …, x67, y67 in image pixels
//! hidden       9 bytes  bit set of points not visible, when flag 8
//! point conf.  9 bytes  bit set of points with a confidence, then one f32 each, when flag 16
//! sources      68 u8    0 tracked, 1 corrected, 2 interpolated, when flag 32
//! ```
//!
//! Coordinates stay `f64`: the fit cache hashes their exact bits, so a session's cached fits
//! stay valid through a save and load (as in the JSON form, which prints the shortest
//! round-tripping decimal). About 1.1 KB per frame against 2.7 KB of JSON.

use super::SessionError;
use super::binary::{Kind, MASK_BYTES, Reader, Writer, mask_has};
use crate::landmarks::{
    FrameLandmarks, LandmarkPoint, MAX_FRAME, N_LANDMARKS, PointNo, PointSource, Track,
};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// The newest track file version this build reads and the one it writes.
pub const VERSION: u16 = 1;

const SUCCESS: u8 = 1;
const TIMESTAMP: u8 = 2;
const CONFIDENCE: u8 = 4;
const HIDDEN: u8 = 8;
const POINT_CONFIDENCE: u8 = 16;
const SOURCES: u8 = 32;
const RERUN: u8 = 64;
const KNOWN_FLAGS: u8 = 127;

/// The smallest record: frame, flags and the coordinates.
const MIN_RECORD_BYTES: u64 = 4 + 1 + 16 * N_LANDMARKS as u64;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    frames: u64,
    points: u64,
}

fn source_code(s: PointSource) -> u8 {
    match s {
        PointSource::Tracked => 0,
        PointSource::Corrected => 1,
        PointSource::Interpolated => 2,
    }
}

fn source_of(code: u8) -> Option<PointSource> {
    match code {
        0 => Some(PointSource::Tracked),
        1 => Some(PointSource::Corrected),
        2 => Some(PointSource::Interpolated),
        _ => None,
    }
}

/// Writes `track` to `out`; returns the checksum (the file's name). The track must have
/// passed [`super::bounds::check_tracked_frame`] frame by frame.
///
/// # Errors
/// The writer's I/O error.
pub fn write_track(out: impl Write, track: &Track) -> std::io::Result<u64> {
    let header = Header { frames: track.len() as u64, points: N_LANDMARKS as u64 };
    let head = serde_json::to_vec(&header).map_err(std::io::Error::other)?;
    let mut w = Writer::start(out, Kind::Track, VERSION, &head)?;
    for f in &track.frames {
        let any = |p: fn(&LandmarkPoint) -> bool| f.points.iter().any(p);
        let mut flags = 0;
        for (on, flag) in [
            (f.success, SUCCESS),
            (f.timestamp.is_some(), TIMESTAMP),
            (f.confidence.is_some(), CONFIDENCE),
            (any(|p| !p.visible), HIDDEN),
            (any(|p| p.confidence.is_some()), POINT_CONFIDENCE),
            (any(|p| p.source != PointSource::Tracked), SOURCES),
            (f.rerun_disagreement.is_some(), RERUN),
        ] {
            if on {
                flags |= flag;
            }
        }
        w.u32(u32::try_from(f.frame).unwrap_or(u32::MAX))?;
        w.u8(flags)?;
        if let Some(t) = f.timestamp {
            w.f64(t)?;
        }
        if let Some(c) = f.confidence {
            w.f32(c)?;
        }
        if let Some(d) = f.rerun_disagreement {
            w.f32(d)?;
        }
        for p in &f.points {
            w.f64(p.x)?;
            w.f64(p.y)?;
        }
        if flags & HIDDEN != 0 {
            w.mask(|i| f.points.get(i).is_some_and(|p| !p.visible))?;
        }
        if flags & POINT_CONFIDENCE != 0 {
            w.mask(|i| f.points.get(i).is_some_and(|p| p.confidence.is_some()))?;
            for c in f.points.iter().filter_map(|p| p.confidence) {
                w.f32(c)?;
            }
        }
        if flags & SOURCES != 0 {
            for p in &f.points {
                w.u8(source_code(p.source))?;
            }
        }
    }
    w.finish()
}

/// Reads the track file at `path`, expecting `frames` frames (what the session says it
/// holds).
///
/// # Errors
/// `Invalid` naming the file, the record (frame) and the field at fault: another kind of
/// file, a newer version, a header that disagrees with the session, frames out of order or
/// past [`MAX_FRAME`], coordinates out of bounds, unknown flags, a bad checksum.
pub fn read_track(path: &Path, frames: usize) -> Result<Track, SessionError> {
    let (mut r, _version, head) = Reader::open(path, Kind::Track, VERSION)?;
    let h: Header = r.header(&head)?;
    if h.points != N_LANDMARKS as u64 {
        return Err(r.fault("header", &format!("{} points per frame, not {N_LANDMARKS}", h.points)));
    }
    if h.frames != frames as u64 {
        return Err(r.fault(
            "header",
            &format!("holds {} frames where the session says {frames}", h.frames),
        ));
    }
    r.check_count("frames", h.frames, MIN_RECORD_BYTES)?;
    let mut out = Vec::with_capacity(frames);
    let mut xy = [0.0; 2 * N_LANDMARKS];
    for k in 0..frames {
        r.set_record(format!("frame record {k}"));
        let frame = r.u32("frame")? as usize;
        r.set_record(format!("frame record {k} (frame {frame})"));
        if frame > MAX_FRAME {
            return Err(r.fault("frame", &format!("is past the largest frame ({MAX_FRAME})")));
        }
        if out.last().is_some_and(|l: &FrameLandmarks| frame <= l.frame) {
            return Err(r.fault("frame", "is out of order or repeated"));
        }
        let flags = r.u8("flags")?;
        if flags & !KNOWN_FLAGS != 0 {
            return Err(r.fault("flags", &format!("unknown flags {flags:#04x}")));
        }
        let timestamp = if flags & TIMESTAMP != 0 { Some(r.f64("timestamp")?) } else { None };
        let confidence = if flags & CONFIDENCE != 0 { Some(r.f32("confidence")?) } else { None };
        let rerun_disagreement =
            if flags & RERUN != 0 { Some(r.f32("rerun_disagreement")?) } else { None };
        r.f64s(&mut xy, "xy")?;
        let mut points: Vec<LandmarkPoint> =
            xy.chunks_exact(2).map(|p| LandmarkPoint::tracked(p[0], p[1])).collect();
        if flags & HIDDEN != 0 {
            let m = r.mask("hidden")?;
            for (i, p) in points.iter_mut().enumerate() {
                p.visible = !mask_has(&m, i);
            }
            refuse_bits_past_68(&r, &m, "hidden")?;
        }
        if flags & POINT_CONFIDENCE != 0 {
            let m = r.mask("point confidence")?;
            refuse_bits_past_68(&r, &m, "point confidence")?;
            for (i, p) in points.iter_mut().enumerate() {
                if mask_has(&m, i) {
                    p.confidence = Some(r.f32("point confidence")?);
                }
            }
        }
        if flags & SOURCES != 0 {
            for (i, p) in points.iter_mut().enumerate() {
                let code = r.u8("sources")?;
                p.source = source_of(code).ok_or_else(|| {
                    r.fault("sources", &format!("point {}: unknown source {code}", PointNo(i)))
                })?;
            }
        }
        let f = FrameLandmarks {
            frame,
            timestamp,
            confidence,
            success: flags & SUCCESS != 0,
            rerun_disagreement,
            points,
            lip_contact_px: None,
        };
        super::bounds::check_tracked_frame(&f).map_err(|m| r.fault("points", &m))?;
        out.push(f);
    }
    r.finish()?;
    Ok(Track { frames: out })
}

fn refuse_bits_past_68(r: &Reader, m: &[u8; MASK_BYTES], field: &str) -> Result<(), SessionError> {
    if (N_LANDMARKS..MASK_BYTES * 8).any(|i| mask_has(m, i)) {
        return Err(r.fault(field, "names a point past 68"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track() -> Track {
        let mut frames = Vec::new();
        for f in [0, 1, 5] {
            let pts: Vec<_> = (0..N_LANDMARKS)
                .map(|i| LandmarkPoint::tracked(i as f64 * 1.25 + f as f64, 0.1 * i as f64))
                .collect();
            frames.push(FrameLandmarks::new(f, pts));
        }
        frames[1].timestamp = Some(0.04);
        frames[1].confidence = Some(0.9);
        frames[1].success = false;
        frames[1].rerun_disagreement = Some(0.015);
        frames[2].points[3].visible = false;
        frames[2].points[67].confidence = Some(0.5);
        frames[2].points[10].source = PointSource::Corrected;
        Track { frames }
    }

    fn written(dir: &Path, t: &Track) -> std::path::PathBuf {
        let p = dir.join("c.track");
        let mut bytes = Vec::new();
        write_track(&mut bytes, t).unwrap();
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn a_track_round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let t = track();
        let p = written(dir.path(), &t);
        assert_eq!(read_track(&p, 3).unwrap(), t);
        let bytes = std::fs::read(&p).unwrap();
        // Frame, flags and 136 coordinates: 1.1 KB a frame.
        assert!(bytes.len() < 3 * 1200, "{}", bytes.len());
    }

    #[test]
    fn hostile_track_files_are_refused_naming_record_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let p = written(dir.path(), &track());
        let e = read_track(&p, 4).unwrap_err().to_string();
        assert!(e.contains("holds 3 frames where the session says 4"), "{e}");
        let mut bad = track();
        bad.frames[2].frame = 1;
        let p = written(dir.path(), &bad);
        let e = read_track(&p, 3).unwrap_err().to_string();
        assert!(e.contains("frame record 2 (frame 1): frame: is out of order"), "{e}");
        let mut far = track();
        far.frames[0].points[4].x = 1e300;
        let p = written(dir.path(), &far);
        let e = read_track(&p, 3).unwrap_err().to_string();
        assert!(e.contains("frame record 0 (frame 0): points: point 5 (1e300"), "{e}");
        let mut past = track();
        past.frames[2].frame = MAX_FRAME + 1;
        let p = written(dir.path(), &past);
        let e = read_track(&p, 3).unwrap_err().to_string();
        assert!(e.contains("is past the largest frame"), "{e}");
    }
}
