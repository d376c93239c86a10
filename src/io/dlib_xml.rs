//! dlib imglab XML landmarks (`<images><image file=…><box …><part name='00' x=… y=…/>`):
//! read and write. Start at `parse_dlib_xml`.
//!
//! One `<image>` is one frame, numbered by order of appearance. Only the first `<box>` of an
//! image is read (lipmap follows one face). Part names are iBUG ids `00`..`67`; a part that
//! is absent means the point is not visible. dlib stores whole pixels, so writing rounds
//! each coordinate to the nearest integer and the box to the visible points' bounds.

use super::error::{FormatError, Location, Result};
use super::pts::shorten;
use crate::landmarks::ibug::N_LANDMARKS;
use crate::landmarks::track::{FrameLandmarks, LandmarkPoint, Track};
use quick_xml::events::{BytesStart, Event};
use std::fmt::Write as _;
use std::path::Path;

/// Byte offsets to 1-based line numbers, scanning forward only (offsets arrive in order).
struct LineCounter<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
}

impl LineCounter<'_> {
    fn line_at(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.text.len());
        if offset < self.pos {
            self.pos = 0;
            self.line = 1;
        }
        self.line += self.text.as_bytes()[self.pos..offset].iter().filter(|&&b| b == b'\n').count();
        self.pos = offset;
        self.line
    }
}

/// Parses dlib imglab XML text into a track.
///
/// # Errors
/// Malformed XML, a part name that is not a number in `00..67`, a part given twice, a
/// missing or non-numeric `x`/`y`, or a file without any `<image>`, each naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let xml = "<dataset><images><image file='a.png'><box top='1' left='2' width='3' height='4'>\
///            <part name='48' x='10' y='20'/></box></image></images></dataset>";
/// let t = lipmap::io::dlib_xml::parse_dlib_xml(xml, Path::new("l.xml")).unwrap();
/// assert_eq!(t.frames[0].points[48].x, 10.0);
/// assert!(!t.frames[0].points[0].visible);
/// ```
pub fn parse_dlib_xml(text: &str, path: &Path) -> Result<Track> {
    let mut reader = quick_xml::Reader::from_str(text);
    reader.config_mut().trim_text(true);
    let mut lines = LineCounter { text, pos: 0, line: 1 };
    let mut frames: Vec<FrameLandmarks> = Vec::new();
    // Points of the image being read, and how many <box> elements it has opened so far.
    let mut current: Option<(Vec<Option<LandmarkPoint>>, usize)> = None;
    let mut in_first_box = false;
    loop {
        let before = reader.buffer_position() as usize;
        let event = match reader.read_event() {
            Ok(ev) => ev,
            Err(e) => {
                let line = lines.line_at(reader.error_position() as usize);
                return Err(FormatError::at_line(path, line, format!("bad XML: {e}")));
            }
        };
        let skip = text.get(before..).map_or(0, |t| t.len() - t.trim_start().len());
        let line = lines.line_at(before + skip);
        match event {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let is_empty = matches!(event, Event::Empty(_));
                match e.local_name().as_ref() {
                    b"image" => {
                        if current.is_some() {
                            return Err(FormatError::at_line(path, line, "<image> inside <image>"));
                        }
                        if is_empty {
                            frames.push(finish_frame(frames.len(), vec![None; N_LANDMARKS]));
                        } else {
                            current = Some((vec![None; N_LANDMARKS], 0));
                        }
                    }
                    b"box" => {
                        if let Some((_, boxes)) = current.as_mut() {
                            *boxes += 1;
                            in_first_box = *boxes == 1 && !is_empty;
                        }
                    }
                    b"part" => {
                        if let (true, Some((points, _))) = (in_first_box, current.as_mut()) {
                            let (id, p) = parse_part(e, &reader, path, line)?;
                            if points[id].is_some() {
                                return Err(FormatError::at_line(
                                    path,
                                    line,
                                    format!("part `{id:02}` appears twice in this box"),
                                ));
                            }
                            points[id] = Some(p);
                        }
                    }
                    _ => {}
                }
            }
            Event::End(ref e) => match e.local_name().as_ref() {
                b"box" => in_first_box = false,
                b"image" => {
                    if let Some((points, _)) = current.take() {
                        frames.push(finish_frame(frames.len(), points));
                    }
                }
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
    if current.is_some() {
        let line = lines.line_at(text.len());
        return Err(FormatError::at_line(path, line, "file ends inside an <image>"));
    }
    if frames.is_empty() {
        return Err(FormatError::whole(
            path,
            "no <image> elements: not a dlib imglab landmark file",
        ));
    }
    Ok(Track::new(frames))
}

fn finish_frame(frame: usize, points: Vec<Option<LandmarkPoint>>) -> FrameLandmarks {
    FrameLandmarks::new(
        frame,
        points.into_iter().map(|p| p.unwrap_or(LandmarkPoint::missing())).collect(),
    )
}

/// The iBUG id and position of one `<part name=… x=… y=…/>`.
fn parse_part(
    e: &BytesStart<'_>,
    reader: &quick_xml::Reader<&[u8]>,
    path: &Path,
    line: usize,
) -> Result<(usize, LandmarkPoint)> {
    let (mut name, mut x, mut y) = (None, None, None);
    for attr in e.attributes() {
        let attr =
            attr.map_err(|err| FormatError::at_line(path, line, format!("bad attribute: {err}")))?;
        let value = attr
            .decode_and_unescape_value(reader.decoder())
            .map_err(|err| FormatError::at_line(path, line, format!("bad attribute value: {err}")))?
            .into_owned();
        match attr.key.local_name().as_ref() {
            b"name" => name = Some(value),
            b"x" => x = Some(value),
            b"y" => y = Some(value),
            _ => {}
        }
    }
    let name = name.ok_or_else(|| FormatError::at_line(path, line, "<part> has no `name`"))?;
    let id = match name.trim().parse::<usize>() {
        Ok(id) if id < N_LANDMARKS => id,
        _ => {
            return Err(FormatError::at_line(
                path,
                line,
                format!("part name `{}` is out of range 00..{}", shorten(&name), N_LANDMARKS - 1),
            ));
        }
    };
    let coord = |v: Option<String>, axis: &str| -> Result<f64> {
        let v = v.ok_or_else(|| {
            FormatError::at_line(path, line, format!("part `{id:02}` has no `{axis}`"))
        })?;
        match v.trim().parse::<f64>() {
            Ok(c) if c.is_finite() => Ok(c),
            _ => Err(FormatError::new(
                path,
                Location::Line(line),
                format!("part `{id:02}`: `{axis}` = `{}` is not a number", shorten(&v)),
            )),
        }
    };
    Ok((id, LandmarkPoint::tracked(coord(x, "x")?, coord(y, "y")?)))
}

/// Reads a dlib imglab XML file.
///
/// # Errors
/// I/O failures and everything `parse_dlib_xml` rejects.
pub fn read_dlib_xml(path: &Path) -> Result<Track> {
    let text = super::input::read_input_string(path)?;
    parse_dlib_xml(&text, path)
}

/// Escapes text for a single-quoted XML attribute.
fn escape_attr(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '\'' => out.push_str("&apos;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

/// Image file name used for frame `frame` when the caller gives none.
pub fn default_image_name(frame: usize) -> String {
    format!("frame_{frame:06}.png")
}

/// The imglab XML text of a track; `image_name(frame)` names each `<image file=…>`.
/// Only visible points are written, rounded to whole pixels; frames with no visible point
/// get an `<image>` without a box so frame positions survive a round trip.
pub fn format_dlib_xml_with_names(track: &Track, image_name: &dyn Fn(usize) -> String) -> String {
    let mut s = String::from(
        "<?xml version='1.0' encoding='UTF-8'?>\n<dataset>\n<name>lipmap landmarks</name>\n<images>\n",
    );
    for f in &track.frames {
        let _ = writeln!(s, "  <image file='{}'>", escape_attr(&image_name(f.frame)));
        let visible: Vec<(usize, i64, i64)> = f
            .points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.visible)
            .map(|(i, p)| (i, p.x.round() as i64, p.y.round() as i64))
            .collect();
        if !visible.is_empty() {
            let (l, r) =
                visible.iter().fold((i64::MAX, i64::MIN), |(l, r), p| (l.min(p.1), r.max(p.1)));
            let (t, b) =
                visible.iter().fold((i64::MAX, i64::MIN), |(t, b), p| (t.min(p.2), b.max(p.2)));
            let _ = writeln!(
                s,
                "    <box top='{t}' left='{l}' width='{}' height='{}'>",
                // Saturating: absurd but finite coordinates must not overflow the box size.
                r.saturating_sub(l).saturating_add(1),
                b.saturating_sub(t).saturating_add(1)
            );
            for (i, x, y) in visible {
                let _ = writeln!(s, "      <part name='{i:02}' x='{x}' y='{y}'/>");
            }
            s.push_str("    </box>\n");
        }
        s.push_str("  </image>\n");
    }
    s.push_str("</images>\n</dataset>\n");
    s
}

/// The imglab XML text of a track with default image names (`frame_NNNNNN.png`).
pub fn format_dlib_xml(track: &Track) -> String {
    format_dlib_xml_with_names(track, &default_image_name)
}

/// Writes a track as dlib imglab XML.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_dlib_xml(track: &Track, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_dlib_xml(track).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_rounds_and_keeps_missing() {
        let mut pts: Vec<LandmarkPoint> = (0..N_LANDMARKS)
            .map(|i| LandmarkPoint::tracked(i as f64 + 0.4, 2.0 * i as f64 + 0.6))
            .collect();
        pts[10].visible = false;
        let track = Track::new(vec![
            FrameLandmarks::new(0, pts),
            FrameLandmarks::new(1, vec![LandmarkPoint::missing(); 68]),
        ]);
        let back = parse_dlib_xml(&format_dlib_xml(&track), Path::new("l.xml")).unwrap();
        assert_eq!(back.len(), 2);
        let p = &back.frames[0].points;
        assert_eq!((p[3].x, p[3].y), (3.0, 7.0));
        assert!(!p[10].visible && p[11].visible);
        assert!(back.frames[1].points.iter().all(|p| !p.visible));
    }

    #[test]
    fn extreme_coordinates_write_without_overflow() {
        let xml = "<images><image file='a'><box><part name='00' x='1e300' y='-1e300'/>\
                   <part name='01' x='-1e300' y='1e300'/></box></image></images>";
        let t = parse_dlib_xml(xml, Path::new("l.xml")).unwrap();
        let back = parse_dlib_xml(&format_dlib_xml(&t), Path::new("l.xml")).unwrap();
        assert_eq!(back.frames[0].points[0].x, i64::MAX as f64);
    }

    #[test]
    fn part_out_of_range_names_line() {
        let xml = "<dataset>\n<images>\n<image file='a'>\n<box top='0' left='0' width='1' height='1'>\n<part name='68' x='1' y='2'/>\n</box></image></images></dataset>";
        let e = parse_dlib_xml(xml, Path::new("l.xml")).unwrap_err();
        assert_eq!(e.to_string(), "l.xml:5: part name `68` is out of range 00..67");
    }
}
