//! iBUG `.pts` landmark files (one frame per file, or a folder of them): read, write, and the
//! natural file-name order that turns a folder into frame numbers. Start at `parse_pts`.
//!
//! The 300-W convention makes `.pts` coordinates 1-based (the centre of the top-left pixel is
//! `1 1`); lipmap is 0-based everywhere, so 1 is subtracted on import and added on export.
//! Export prints each coordinate with Rust's shortest round-trip formatting, so a value that
//! came from text goes back out as the same text. A lipmap value `x` survives the trip
//! `x + 1` → text → `- 1` bit for bit when `x ≥ 1` px (adding 1 is then exact in binary);
//! within 1 px of the origin it may move by one unit in the last place (~1e-16 px).
//! `.pts` has no visibility, confidence or source: every point reads back as visible and
//! tracked.

use super::error::{FormatError, Location, Result};
use crate::landmarks::ibug::N_LANDMARKS;
use crate::landmarks::track::{FrameLandmarks, LandmarkPoint, Track};
use std::cmp::Ordering;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The 300-W offset between `.pts` (1-based) and lipmap (0-based) pixel coordinates.
const PTS_ORIGIN: f64 = 1.0;

/// Parses the text of one `.pts` file into exactly `N_LANDMARKS` 0-based points.
///
/// `path` is used only in error messages. The header lines (`version: 1`, `n_points: 68`)
/// are optional; `{` and `}` are required; comments are not part of the format.
///
/// # Errors
/// A `FormatError` naming the line (and column for a bad number) when the braces are
/// missing, a line is not two finite numbers, `n_points` disagrees with the points listed,
/// or there are not exactly 68 points.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let mut text = String::from("version: 1\nn_points: 68\n{\n");
/// for i in 0..68 { text += &format!("{} 10.5\n", i + 1); }
/// text += "}\n";
/// let pts = lipmap::io::pts::parse_pts(&text, Path::new("a.pts")).unwrap();
/// assert_eq!((pts[3].x, pts[3].y), (3.0, 9.5));
/// ```
pub fn parse_pts(text: &str, path: &Path) -> Result<Vec<LandmarkPoint>> {
    let text = crate::io::input::without_bom(text);
    let mut declared: Option<(usize, usize)> = None; // (n_points, line)
    let mut points: Vec<LandmarkPoint> = Vec::with_capacity(N_LANDMARKS);
    let mut state = State::Header;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        last_line = line_no;
        let line = raw.trim();
        match state {
            State::Header => {
                if line.is_empty() {
                    continue;
                }
                if line == "{" {
                    state = State::Body;
                } else if let Some(v) = line.strip_prefix("version:") {
                    let v = v.trim();
                    if v.parse::<f64>().is_err() {
                        return Err(FormatError::at_line(
                            path,
                            line_no,
                            format!("bad version `{v}`, expected a number"),
                        ));
                    }
                } else if let Some(n) = line.strip_prefix("n_points:") {
                    let n = n.trim();
                    let count = n.parse::<usize>().map_err(|_| {
                        FormatError::at_line(
                            path,
                            line_no,
                            format!("bad n_points `{n}`, expected a whole number"),
                        )
                    })?;
                    declared = Some((count, line_no));
                } else {
                    return Err(FormatError::at_line(
                        path,
                        line_no,
                        format!("unexpected `{}` before `{{`", shorten(line)),
                    ));
                }
            }
            State::Body => {
                if line.is_empty() {
                    continue;
                }
                if line == "}" {
                    state = State::Done;
                    check_count(&points, declared, path, line_no)?;
                    continue;
                }
                if points.len() == N_LANDMARKS {
                    return Err(FormatError::at_line(
                        path,
                        line_no,
                        format!("more than {N_LANDMARKS} points"),
                    ));
                }
                let (x, y) = parse_xy(raw, path, line_no)?;
                points.push(LandmarkPoint::tracked(x - PTS_ORIGIN, y - PTS_ORIGIN));
            }
            State::Done => {
                if !line.is_empty() {
                    return Err(FormatError::at_line(
                        path,
                        line_no,
                        format!("unexpected `{}` after `}}`", shorten(line)),
                    ));
                }
            }
        }
    }
    match state {
        State::Header => Err(FormatError::at_line(path, last_line.max(1), "no `{` found")),
        State::Body => Err(FormatError::at_line(
            path,
            last_line.max(1),
            format!("file ends without `}}` after {} points", points.len()),
        )),
        State::Done => Ok(points),
    }
}

#[derive(Clone, Copy)]
enum State {
    Header,
    Body,
    Done,
}

fn check_count(
    points: &[LandmarkPoint],
    declared: Option<(usize, usize)>,
    path: &Path,
    line_no: usize,
) -> Result<()> {
    if let Some((n, n_line)) = declared
        && n != points.len()
    {
        return Err(FormatError::at_line(
            path,
            n_line,
            format!("n_points is {n} but {} points are listed", points.len()),
        ));
    }
    if points.len() != N_LANDMARKS {
        return Err(FormatError::at_line(
            path,
            line_no,
            format!("expected {N_LANDMARKS} points, found {}", points.len()),
        ));
    }
    Ok(())
}

/// Two finite numbers separated by whitespace; the error names the 1-based column.
fn parse_xy(raw: &str, path: &Path, line_no: usize) -> Result<(f64, f64)> {
    let mut fields = Vec::with_capacity(2);
    let mut rest = raw;
    let mut offset = 0;
    while fields.len() < 3 {
        let start = rest.len() - rest.trim_start().len();
        rest = &rest[start..];
        offset += start;
        if rest.is_empty() {
            break;
        }
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        fields.push((&rest[..end], offset));
        rest = &rest[end..];
        offset += end;
    }
    if fields.len() != 2 {
        return Err(FormatError::at_line(
            path,
            line_no,
            format!("expected `x y`, found `{}`", shorten(raw.trim())),
        ));
    }
    let num = |(s, col): (&str, usize), axis: &str| -> Result<f64> {
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(FormatError::new(
                path,
                Location::LineColumn(line_no, raw[..col].chars().count() + 1),
                format!("bad {axis} coordinate `{}`", shorten(s)),
            )),
        }
    };
    Ok((num(fields[0], "x")?, num(fields[1], "y")?))
}

/// At most 40 characters of `s`, so a binary file does not flood the error line.
pub(crate) fn shorten(s: &str) -> String {
    const MAX: usize = 40;
    let clean: String = s.chars().map(|c| if c.is_control() { '?' } else { c }).collect();
    if clean.chars().count() <= MAX {
        clean
    } else {
        let mut t: String = clean.chars().take(MAX).collect();
        t.push('…');
        t
    }
}

/// Reads one `.pts` file as frame `frame`.
///
/// # Errors
/// I/O failures and everything `parse_pts` rejects, naming `path`.
pub fn read_pts(path: &Path, frame: usize) -> Result<FrameLandmarks> {
    let text = super::input::read_input_string(path)?;
    Ok(FrameLandmarks::new(frame, parse_pts(&text, path)?))
}

/// The `.pts` files of a folder in natural name order (`2.pts` before `10.pts`).
///
/// # Errors
/// When the folder cannot be listed or holds no `.pts` file.
pub fn list_pts_folder(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| FormatError::io(dir, e))?;
    let mut files = Vec::new();
    for entry in entries {
        let p = entry.map_err(|e| FormatError::io(dir, e))?.path();
        if p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("pts")) {
            files.push(p);
        }
    }
    if files.is_empty() {
        return Err(FormatError::whole(dir, "no .pts files in this folder"));
    }
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Reads a folder of `.pts` files as a track; frame number = position in natural name order.
///
/// # Errors
/// The first file that fails to parse, or an empty/unreadable folder.
pub fn read_pts_folder(dir: &Path) -> Result<Track> {
    let files = list_pts_folder(dir)?;
    let frames = files.iter().enumerate().map(|(i, p)| read_pts(p, i)).collect::<Result<_>>()?;
    Ok(Track::new(frames))
}

/// The `.pts` text of one frame (1-based coordinates, shortest round-trip decimals).
/// Points not visible are written at their stored position: the format cannot mark them.
pub fn format_pts(frame: &FrameLandmarks) -> String {
    let mut s = format!("version: 1\nn_points: {}\n{{\n", frame.points.len());
    for p in &frame.points {
        let _ = writeln!(s, "{} {}", p.x + PTS_ORIGIN, p.y + PTS_ORIGIN);
    }
    s.push_str("}\n");
    s
}

/// Writes one frame as a `.pts` file.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_pts(frame: &FrameLandmarks, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_pts(frame).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

/// File name used for frame `frame` in a `.pts` folder; zero-padded so every tool's sort
/// order (natural or plain) gives the same sequence.
pub fn pts_file_name(frame: usize) -> String {
    format!("frame_{frame:06}.pts")
}

/// Writes every frame of `track` into `dir` (created if needed) as `frame_NNNNNN.pts`.
/// Reading the folder back numbers frames by position, so gaps in frame numbers close up.
///
/// # Errors
/// I/O failures, naming the file.
pub fn write_pts_folder(track: &Track, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| FormatError::io(dir, e))?;
    for f in &track.frames {
        write_pts(f, &dir.join(pts_file_name(f.frame)))?;
    }
    Ok(())
}

/// Natural order of names: digit runs compare by value (`img2` < `img10`), the rest by
/// character; ties (`01` vs `1`) fall back to plain string order so the sort is total.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut ai, mut bi) = (a.char_indices().peekable(), b.char_indices().peekable());
    loop {
        match (ai.peek().copied(), bi.peek().copied()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some((ia, ca)), Some((ib, cb))) => {
                if ca.is_ascii_digit() && cb.is_ascii_digit() {
                    let ea =
                        a[ia..].find(|c: char| !c.is_ascii_digit()).map_or(a.len(), |e| ia + e);
                    let eb =
                        b[ib..].find(|c: char| !c.is_ascii_digit()).map_or(b.len(), |e| ib + e);
                    let (da, db) =
                        (a[ia..ea].trim_start_matches('0'), b[ib..eb].trim_start_matches('0'));
                    let ord = da.len().cmp(&db.len()).then_with(|| da.cmp(db));
                    if ord != Ordering::Equal {
                        return ord;
                    }
                    while ai.peek().is_some_and(|&(i, _)| i < ea) {
                        ai.next();
                    }
                    while bi.peek().is_some_and(|&(i, _)| i < eb) {
                        bi.next();
                    }
                } else {
                    if ca != cb {
                        return ca.cmp(&cb);
                    }
                    ai.next();
                    bi.next();
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_text(n: usize) -> String {
        let mut t = String::from("version: 1\nn_points: 68\n{\n");
        for i in 0..n {
            t += &format!("{}.25 {}.75\n", i + 1, 2 * i + 1);
        }
        t + "}\n"
    }

    #[test]
    fn parses_and_shifts_to_zero_based() {
        let pts = parse_pts(&sample_text(68), Path::new("a.pts")).unwrap();
        assert_eq!(pts.len(), 68);
        assert_eq!((pts[0].x, pts[0].y), (0.25, 0.75));
        assert_eq!((pts[67].x, pts[67].y), (67.25, 134.75));
    }

    #[test]
    fn sixty_seven_points_names_the_closing_line() {
        let t = sample_text(67).replace("n_points: 68\n", "");
        let e = parse_pts(&t, Path::new("a.pts")).unwrap_err();
        assert_eq!(e.to_string(), "a.pts:70: expected 68 points, found 67");
    }

    #[test]
    fn bad_number_names_line_and_column() {
        let t = sample_text(68).replace("5.25 9.75", "5.25 9,75");
        let e = parse_pts(&t, Path::new("a.pts")).unwrap_err();
        assert_eq!(e.to_string(), "a.pts:8:6: bad y coordinate `9,75`");
    }

    #[test]
    fn format_round_trips_exactly() {
        let text = sample_text(68);
        let pts = parse_pts(&text, Path::new("a.pts")).unwrap();
        let out = format_pts(&FrameLandmarks::new(0, pts));
        assert_eq!(out, text);
    }

    #[test]
    fn shift_is_exact_away_from_the_origin() {
        let xs = [1.0, 1.5 + 1e-9, 63.333, 175.999_999_9, 1023.25, 0.1, 0.7];
        let f = FrameLandmarks::new(
            0,
            xs.iter().cycle().take(68).map(|&x| LandmarkPoint::tracked(x, x)).collect(),
        );
        let back = parse_pts(&format_pts(&f), Path::new("a.pts")).unwrap();
        for (p, q) in f.points.iter().zip(&back) {
            if p.x >= 1.0 {
                assert_eq!(p.x, q.x);
            } else {
                assert!((p.x - q.x).abs() <= f64::EPSILON, "{} vs {}", p.x, q.x);
            }
        }
    }

    #[test]
    fn natural_order() {
        let mut v = vec!["f10.pts", "f2.pts", "f1.pts", "f02.pts", "g.pts"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["f1.pts", "f02.pts", "f2.pts", "f10.pts", "g.pts"]);
    }
}
