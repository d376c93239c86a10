//! Reading an OpenCV Haar cascade (`haarcascade_frontalface_alt2.xml` and its siblings in
//! Debian's `opencv-data`, `/usr/share/opencv4/haarcascades/`) into a [`HaarCascade`].
//!
//! The format is OpenCV's "new" cascade XML (`<cascade type_id="opencv-cascade-classifier">`
//! with `<stageType>BOOST</stageType>` and `<featureType>HAAR</featureType>`): the window
//! size, then stages (a threshold and weak classifiers: `internalNodes` as groups of four —
//! left, right, feature index, threshold, where a child ≤ 0 is leaf −child — and their
//! `leafValues`), then the features (up to three weighted rectangles `x y w h weight`).
//! Tilted (45°) features are refused: no frontal-face cascade of OpenCV uses them.
//!
//! Hostile input: the file is capped, XML nesting and element counts are bounded, every
//! index is checked against what it names, and every error is one line naming the file and
//! the line (or the field).

use crate::io::error::{FormatError, Location};
use quick_xml::events::Event;
use std::path::Path;

/// Where Debian's `opencv-data` installs the frontal-face cascade lipmap uses by default.
pub const DEBIAN_CASCADE_PATH: &str =
    "/usr/share/opencv4/haarcascades/haarcascade_frontalface_alt2.xml";

/// Largest cascade file read (OpenCV's largest face cascade is 2.7 MB).
pub const MAX_CASCADE_BYTES: u64 = 64 << 20;

/// Largest window side accepted, in pixels (OpenCV's face cascades use 20 or 24).
pub const MAX_WINDOW: u32 = 256;

/// Most XML elements read (OpenCV's largest face cascade has ~100,000).
const MAX_ELEMENTS: usize = 4_000_000;

/// One weighted rectangle of a Haar feature, in window pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HaarRect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
    pub weight: f32,
}

/// A decision-tree node: `value < threshold · σ·area` goes `left`, else `right`; a child
/// `≤ 0` is the leaf `−child` of the weak classifier.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HaarNode {
    pub left: i32,
    pub right: i32,
    pub feature: u32,
    pub threshold: f32,
}

/// A weak classifier: a small tree and its leaf values.
#[derive(Clone, Debug, PartialEq)]
pub struct WeakClassifier {
    pub nodes: Vec<HaarNode>,
    pub leaves: Vec<f32>,
}

/// A boosted stage: the window passes when its classifiers' leaf sum is ≥ `threshold`.
#[derive(Clone, Debug, PartialEq)]
pub struct HaarStage {
    pub threshold: f32,
    pub classifiers: Vec<WeakClassifier>,
}

/// A Viola–Jones cascade of boosted Haar-feature stages.
#[derive(Clone, Debug, PartialEq)]
pub struct HaarCascade {
    /// Window size `[width, height]` in pixels.
    pub window: [u32; 2],
    pub stages: Vec<HaarStage>,
    pub features: Vec<Vec<HaarRect>>,
}

/// Reads a cascade file.
///
/// # Errors
/// The file cannot be read, or is not a cascade lipmap can evaluate (naming line or field).
pub fn read_haar_cascade(path: &Path) -> Result<HaarCascade, FormatError> {
    let bytes = crate::io::input::read_input_capped(path, MAX_CASCADE_BYTES)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        FormatError::new(path, Location::Offset(e.valid_up_to() as u64), "not UTF-8 text")
    })?;
    parse_haar_cascade(text, path)
}

/// An element of the XML tree: its name, its text and its children, and the line it starts.
#[derive(Debug, Default)]
struct Element {
    name: String,
    text: String,
    line: usize,
    children: Vec<Element>,
}

impl Element {
    fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }
}

/// Parses cascade XML text; `path` names it in errors.
///
/// # Errors
/// Malformed XML, a missing or non-numeric field, an unsupported stage or feature type,
/// a feature index or rectangle out of range, each naming the line.
pub fn parse_haar_cascade(text: &str, path: &Path) -> Result<HaarCascade, FormatError> {
    let root = parse_tree(text, path)?;
    let cascade = root.child("cascade").ok_or_else(|| {
        FormatError::whole(
            path,
            "no <cascade> element under <opencv_storage> (not an OpenCV cascade in the \
                 format of OpenCV 2.4 and later)",
        )
    })?;
    // A child's text and the line of its tag, so that a bad number names its own line.
    let need = |e: &Element, name: &str| -> Result<(String, usize), FormatError> {
        e.child(name).map(|c| (c.text.trim().to_string(), c.line)).ok_or_else(|| {
            FormatError::at_line(path, e.line, format!("<{}> has no <{name}>", e.name))
        })
    };
    for (field, want) in [("stageType", "BOOST"), ("featureType", "HAAR")] {
        let (got, _) = need(cascade, field)?;
        if got != want {
            return Err(FormatError::at_field(
                path,
                field,
                format!("`{got}`, but lipmap evaluates only {want} cascades"),
            ));
        }
    }
    let dim = |field: &str| -> Result<u32, FormatError> {
        let (v, _) = need(cascade, field)?;
        v.parse::<u32>().ok().filter(|v| (3..=MAX_WINDOW).contains(v)).ok_or_else(|| {
            FormatError::at_field(
                path,
                field,
                format!("`{v}` is not a window side of 3 to {MAX_WINDOW}"),
            )
        })
    };
    let window = [dim("width")?, dim("height")?];

    let features_el = cascade
        .child("features")
        .ok_or_else(|| FormatError::at_line(path, cascade.line, "<cascade> has no <features>"))?;
    let mut features = Vec::with_capacity(features_el.children.len());
    for f in &features_el.children {
        if f.child("tilted").is_some_and(|t| t.text.trim() != "0") {
            return Err(FormatError::at_line(
                path,
                f.line,
                "a tilted (45°) feature, which lipmap does not evaluate",
            ));
        }
        let rects_el = f
            .child("rects")
            .ok_or_else(|| FormatError::at_line(path, f.line, "a feature without <rects>"))?;
        if rects_el.children.is_empty() || rects_el.children.len() > 3 {
            return Err(FormatError::at_line(
                path,
                rects_el.line,
                format!("{} rectangles in a feature (1 to 3 allowed)", rects_el.children.len()),
            ));
        }
        let mut rects = Vec::with_capacity(rects_el.children.len());
        for r in &rects_el.children {
            let v = numbers(&r.text, 5, path, r.line)?;
            let int = |x: f64| {
                (x >= 0.0 && x.fract() == 0.0 && x <= f64::from(MAX_WINDOW)).then_some(x as u32)
            };
            let (Some(x), Some(y), Some(w), Some(h)) = (int(v[0]), int(v[1]), int(v[2]), int(v[3]))
            else {
                return Err(FormatError::at_line(
                    path,
                    r.line,
                    "a rectangle with a negative, fractional or huge side",
                ));
            };
            if x + w > window[0] || y + h > window[1] || w == 0 || h == 0 {
                return Err(FormatError::at_line(
                    path,
                    r.line,
                    format!(
                        "rectangle {x} {y} {w} {h} is not inside the {}×{} window",
                        window[0], window[1]
                    ),
                ));
            }
            rects.push(HaarRect { x, y, w, h, weight: v[4] as f32 });
        }
        features.push(rects);
    }

    let stages_el = cascade
        .child("stages")
        .ok_or_else(|| FormatError::at_line(path, cascade.line, "<cascade> has no <stages>"))?;
    if stages_el.children.is_empty() {
        return Err(FormatError::at_line(path, stages_el.line, "a cascade without stages"));
    }
    let mut stages = Vec::with_capacity(stages_el.children.len());
    for s in &stages_el.children {
        let (threshold_text, threshold_line) = need(s, "stageThreshold")?;
        let threshold = numbers(&threshold_text, 1, path, threshold_line)?[0] as f32;
        let weak = s.child("weakClassifiers").ok_or_else(|| {
            FormatError::at_line(path, s.line, "a stage without <weakClassifiers>")
        })?;
        let mut classifiers = Vec::with_capacity(weak.children.len());
        for c in &weak.children {
            let (nodes_text, nodes_line) = need(c, "internalNodes")?;
            let (leaves_text, leaves_line) = need(c, "leafValues")?;
            let nv = numbers_any(&nodes_text, path, nodes_line)?;
            let leaves: Vec<f32> = numbers_any(&leaves_text, path, leaves_line)?
                .into_iter()
                .map(|v| v as f32)
                .collect();
            if nv.is_empty() || nv.len() % 4 != 0 || leaves.is_empty() {
                return Err(FormatError::at_line(
                    path,
                    c.line,
                    "internalNodes must be groups of 4 numbers, with at least one leaf value",
                ));
            }
            let n_nodes = nv.len() / 4;
            let mut nodes = Vec::with_capacity(n_nodes);
            for q in nv.chunks_exact(4) {
                let child_ok = |v: f64| {
                    v.fract() == 0.0
                        && ((v > 0.0 && v < n_nodes as f64)
                            || (v <= 0.0 && -v < leaves.len() as f64))
                };
                let feature_ok = q[2].fract() == 0.0 && q[2] >= 0.0 && q[2] < features.len() as f64;
                if !child_ok(q[0]) || !child_ok(q[1]) || !feature_ok {
                    return Err(FormatError::at_line(
                        path,
                        nodes_line,
                        format!(
                            "node `{} {} {} …` names a child or feature that does not exist ({n_nodes} nodes, {} leaves, {} features)",
                            q[0],
                            q[1],
                            q[2],
                            leaves.len(),
                            features.len()
                        ),
                    ));
                }
                nodes.push(HaarNode {
                    left: q[0] as i32,
                    right: q[1] as i32,
                    feature: q[2] as u32,
                    threshold: q[3] as f32,
                });
            }
            // Children must point forward so that evaluation always ends.
            if nodes.iter().enumerate().any(|(i, n)| {
                (n.left > 0 && n.left as usize <= i) || (n.right > 0 && n.right as usize <= i)
            }) {
                return Err(FormatError::at_line(
                    path,
                    c.line,
                    "a tree node points back to itself or an earlier node",
                ));
            }
            classifiers.push(WeakClassifier { nodes, leaves });
        }
        stages.push(HaarStage { threshold, classifiers });
    }
    Ok(HaarCascade { window, stages, features })
}

/// Exactly `n` finite numbers separated by whitespace.
fn numbers(text: &str, n: usize, path: &Path, line: usize) -> Result<Vec<f64>, FormatError> {
    let v = numbers_any(text, path, line)?;
    if v.len() != n {
        return Err(FormatError::at_line(
            path,
            line,
            format!("{} numbers where {n} are needed", v.len()),
        ));
    }
    Ok(v)
}

/// Finite numbers separated by whitespace.
fn numbers_any(text: &str, path: &Path, line: usize) -> Result<Vec<f64>, FormatError> {
    text.split_whitespace()
        .map(|t| {
            t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                FormatError::at_line(
                    path,
                    line,
                    format!("`{}` is not a number", crate::io::pts::shorten(t)),
                )
            })
        })
        .collect()
}

/// The XML as a tree of elements (comments and attributes dropped), bounded in depth and
/// size.
fn parse_tree(text: &str, path: &Path) -> Result<Element, FormatError> {
    let mut reader = quick_xml::Reader::from_str(text);
    // Offsets arrive in order: count newlines forward from the last one (counting from the
    // start each time made a large file quadratic).
    let counted = std::cell::Cell::new((0usize, 1usize));
    let line_at = |offset: u64| {
        let end = (offset as usize).min(text.len());
        let (mut pos, mut line) = counted.get();
        if end < pos {
            (pos, line) = (0, 1);
        }
        line += text.as_bytes()[pos..end].iter().filter(|&&b| b == b'\n').count();
        counted.set((end, line));
        line
    };
    let mut stack = vec![Element::default()];
    let mut count = 0usize;
    loop {
        let at = reader.buffer_position();
        let event = reader.read_event().map_err(|e| {
            FormatError::at_line(
                path,
                line_at(reader.error_position()),
                // quick-xml quotes the offending text, newlines and all: keep one line.
                format!(
                    "malformed XML: {}",
                    e.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
                ),
            )
        })?;
        match event {
            Event::Start(e) => {
                count += 1;
                if stack.len() > 32 || count > MAX_ELEMENTS {
                    return Err(FormatError::at_line(
                        path,
                        line_at(at),
                        "XML nested too deeply or too large",
                    ));
                }
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                stack.push(Element { name, line: line_at(at), ..Default::default() });
            }
            Event::Empty(e) => {
                count += 1;
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                let el = Element { name, line: line_at(at), ..Default::default() };
                if let Some(top) = stack.last_mut() {
                    top.children.push(el);
                }
            }
            Event::Text(t) => {
                let s = t.decode().map_err(|e| {
                    FormatError::at_line(path, line_at(at), format!("bad text: {e}"))
                })?;
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&s);
                }
            }
            Event::End(_) => {
                let done = stack.pop().filter(|_| !stack.is_empty()).ok_or_else(|| {
                    FormatError::at_line(path, line_at(at), "a closing tag without its opening")
                })?;
                if let Some(top) = stack.last_mut() {
                    top.children.push(done);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if stack.len() != 1 {
        return Err(FormatError::whole(path, "the file ends inside an element (truncated?)"));
    }
    let mut top = stack.pop().unwrap_or_default();
    // The document's root (<opencv_storage>) is the one child of the synthetic top.
    Ok(if top.children.len() == 1 { top.children.remove(0) } else { top })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A 4×4 cascade with one stage and one stump on "left half darker than right half".
    pub(crate) const TINY: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<cascade type_id="opencv-cascade-classifier"><stageType>BOOST</stageType>
  <featureType>HAAR</featureType>
  <height>4</height>
  <width>4</width>
  <stages>
    <_>
      <maxWeakCount>1</maxWeakCount>
      <stageThreshold>0.5</stageThreshold>
      <weakClassifiers>
        <_>
          <internalNodes>
            0 -1 0 -0.1</internalNodes>
          <leafValues>
            1.0 -1.0</leafValues></_></weakClassifiers></_></stages>
  <features>
    <_>
      <rects>
        <_>
          0 0 2 4 1.</_>
        <_>
          2 0 2 4 -1.</_></rects></_></features></cascade>
</opencv_storage>
"#;

    #[test]
    fn a_small_cascade_reads_as_written() {
        let c = parse_haar_cascade(TINY, Path::new("c.xml")).unwrap();
        assert_eq!(c.window, [4, 4]);
        assert_eq!(c.stages.len(), 1);
        assert_eq!(
            c.stages[0].classifiers[0].nodes[0],
            HaarNode { left: 0, right: -1, feature: 0, threshold: -0.1 }
        );
        assert_eq!(c.features[0][1], HaarRect { x: 2, y: 0, w: 2, h: 4, weight: -1.0 });
    }

    proptest::proptest! {
        /// Mutated cascades give a one-line error or a cascade that scans an image.
        #[test]
        fn mutated_cascades_give_an_error_or_a_usable_cascade(
            edits in proptest::collection::vec((0usize..2000, 32u8..127), 1..6),
        ) {
            let mut bytes = TINY.as_bytes().to_vec();
            for (at, b) in edits {
                let i = at % bytes.len();
                bytes[i] = b;
            }
            let text = String::from_utf8(bytes).expect("ASCII");
            match parse_haar_cascade(&text, Path::new("c.xml")) {
                Ok(c) => {
                    let px = [9u8; 24 * 24];
                    let img = crate::track::GrayView { width: 24, height: 24, pixels: &px };
                    let opts = crate::track::DetectOptions { min_neighbors: 0, ..Default::default() };
                    let _ = crate::track::detect_faces(&c, img, &opts);
                }
                Err(e) => proptest::prop_assert!(!e.to_string().contains('\n'), "{}", e),
            }
        }
    }

    #[test]
    fn bad_cascades_are_one_line_errors_naming_the_file_and_line() {
        for (from, to, want) in [
            ("0 -1 0 -0.1", "0 -1 3 -0.1", "c.xml:13: node"),
            ("2 0 2 4 -1.", "3 0 2 4 -1.", "c.xml:22: rectangle 3 0 2 4"),
            ("<featureType>HAAR", "<featureType>LBP", "c.xml: field `featureType`: `LBP`"),
            ("0.5</stageThreshold>", "x</stageThreshold>", "c.xml:10: `x` is not a number"),
            ("</opencv_storage>", "", "truncated"),
        ] {
            let bad = TINY.replace(from, to);
            let e = parse_haar_cascade(&bad, Path::new("c.xml")).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
