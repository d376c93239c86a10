//! Untrusted input end to end: a session file or landmark CSV loaded, then carried through
//! the first steps of `eval` (effective landmarks, per-frame measures, phone frames, the
//! RMSE tables) without a model. The fuzz targets (`fuzz/`) and the hostile-input tests
//! share these entries, so a value that parses but breaks a later step is found too.

use super::evaluate::{Normalisation, evaluate};
use crate::eval::Utterance;
use crate::io::landmark_format::{LandmarkFormat, parse_track};
use crate::landmarks::Track;
use crate::measure::mouth::trajectory_from_track;
use crate::session::Session;
use std::path::Path;

/// Loads the session at `path` and evaluates each clip's video measures against
/// themselves (the head's part needs a model and a fit, which are not untrusted text).
/// Returns how many frames were measured.
///
/// # Errors
/// The load's one-line error.
pub fn session_through_eval(path: &Path) -> Result<usize, String> {
    let session = Session::load(path).map_err(|e| e.to_string())?;
    let mut utterances = Vec::with_capacity(session.clips.len());
    for (i, c) in session.clips.iter().enumerate() {
        let track = session.effective_track(i).map_err(|e| e.to_string())?;
        let alignment = c.alignment.clone().unwrap_or_default();
        utterances.push(utterance_of(&c.name, &track, alignment, c.front.fps));
    }
    Ok(evaluate_all(&utterances))
}

/// Parses lipmap CSV text as `lipmap new` reads a landmark file and evaluates it as a clip
/// at 25 fps. Returns how many frames were measured.
///
/// # Errors
/// The parser's one-line error.
pub fn track_csv_through_eval(text: &str) -> Result<usize, String> {
    let track = parse_track(text, Path::new("landmarks.csv"), LandmarkFormat::LipmapCsv)
        .map_err(|e| e.to_string())?;
    Ok(evaluate_all(&[utterance_of("clip", &track, Default::default(), 25.0)]))
}

fn utterance_of(
    name: &str,
    track: &Track,
    alignment: crate::alignment::Alignment,
    fps: f64,
) -> Utterance {
    let n = track.frames.last().map_or(0, |f| f.frame + 1);
    let video = trajectory_from_track(track, Some(n));
    Utterance { name: name.to_string(), speaker: None, alignment, fps, head: video.clone(), video }
}

fn evaluate_all(utterances: &[Utterance]) -> usize {
    let report = evaluate(utterances, &[], Normalisation::MinMax, 10);
    std::hint::black_box(&report);
    utterances.iter().map(|u| u.video.len()).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD_ROW: &str = "frame,point,x,y\n";

    fn csv_with_frame(frame: &str) -> String {
        let mut s = GOOD_ROW.to_string();
        for p in 0..68 {
            s.push_str(&format!("{frame},{p},{}.5,{}.25\n", 100 + p, 200 + p));
        }
        s
    }

    #[test]
    fn hostile_landmark_csvs_give_one_line_errors() {
        for frame in ["100000000", "4000000000", "18446744073709551615", "-1", "1e3", "NaN"] {
            let err = track_csv_through_eval(&csv_with_frame(frame)).expect_err(frame);
            assert!(err.starts_with("landmarks.csv") && !err.contains('\n'), "{frame}: {err}");
        }
        let far = csv_with_frame("7").replacen("7,0,100.5", "7,0,1e300", 1);
        let err = track_csv_through_eval(&far).expect_err("a coordinate of 1e300");
        assert!(err.starts_with("landmarks.csv") && err.contains("1e300"), "{err}");
        assert_eq!(track_csv_through_eval(&csv_with_frame("7")), Ok(8));
    }

    #[test]
    fn hostile_sessions_give_one_line_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.lipmap.json");
        let xy: Vec<String> = (0..136).map(|i| format!("{}.5", 100 + i)).collect();
        let clip = |frame: &str, fps: &str, extra: &str| {
            format!(
                r#"{{"schema_version": {v}, "clips": [{{"name": "a",
                "front": {{"source": {{"kind": "images", "dir": "f"}}, "fps": {fps}}},
                "tracked": [{{"frame": {frame}, "xy": [{xy}]}}]{extra}}}]}}"#,
                v = crate::session::CURRENT_SCHEMA,
                xy = xy.join(",")
            )
        };
        let hostile = [
            ("tracked frame", clip("4000000000", "25", "")),
            ("fps", clip("3", "1e20", "")),
            ("fps", clip("3", "1e-300", "")),
            (
                "correction of frame",
                clip(
                    "3",
                    "25",
                    r#", "corrections": {"points": {"1000000000000": {"4": {"x": 1, "y": 2, "visible": true}}}}"#,
                ),
            ),
            ("reviewed frame", clip("3", "25", r#", "corrections": {"reviewed": [99999999999]}"#)),
            (
                "end before its start",
                clip(
                    "3",
                    "25",
                    r#", "alignment": {"phones": [{"start": 2, "end": 1, "label": "AA"}]}"#,
                ),
            ),
            (
                "end past",
                clip(
                    "3",
                    "25",
                    r#", "alignment": {"phones": [{"start": 0, "end": 1e12, "label": "AA"}]}"#,
                ),
            ),
        ];
        for (field, text) in hostile {
            std::fs::write(&path, text).unwrap();
            let err = session_through_eval(&path).expect_err(field);
            assert!(err.contains("s.lipmap.json") && err.contains(field), "{field}: {err}");
            assert!(!err.contains('\n'), "one line: {err}");
        }
        std::fs::write(&path, clip("3", "25", "")).unwrap();
        assert_eq!(session_through_eval(&path), Ok(4));
    }
}
