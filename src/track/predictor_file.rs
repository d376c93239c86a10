//! Reading dlib's serialized shape predictor (`shape_predictor_68_face_landmarks.dat`, Debian
//! `libdlib-data`): the mean shape, the cascade's regression forests and each stage's feature
//! pixels, into a [`ShapePredictor`].
//!
//! The layout follows dlib's own serialization (davisking/dlib `dlib/serialize.h`,
//! `dlib/float_details.h`, `dlib/matrix/matrix.h`, `dlib/image_processing/shape_predictor.h`),
//! read there and written anew here:
//! - an integer is one control byte (its low nibble the byte count 1–8, bit 7 the sign for
//!   signed types) and that many little-endian magnitude bytes;
//! - a float is two integers, a 64-bit mantissa and a 16-bit exponent (value = m·2^e; the
//!   exponents 32000–32002 mean ±∞ and NaN, refused here); dlib's pre-2013 ASCII floats are
//!   refused too (no predictor in circulation uses them);
//! - a matrix is −rows, −cols and its values row by row; a `std::vector` is its length and
//!   its items;
//! - the predictor is: version (1), the mean shape (a 136×1 matrix for 68 points, normalised
//!   to the face box: (0,0) its top-left, (1,1) its bottom-right), the forests (one vector of
//!   trees per cascade stage; a tree is its splits — feature indices a, b and a threshold —
//!   then its leaves, one 136×1 shape increment each), the feature pixels' anchor points
//!   (one vector per stage) and their offsets from those anchors (two floats each).
//!
//! Hostile input: every count is checked against what the rest of the file could hold before
//! anything is allocated for it, trees must be complete binary trees whose split indices
//! name existing feature pixels and whose leaves have the mean shape's length, and every
//! error is one line naming the file, the byte offset and the field.

use crate::io::error::{FormatError, Location};
use nalgebra::Vector2;
use std::path::Path;

/// Where Debian's `libdlib-data` installs the 68-point predictor.
pub const DEBIAN_PREDICTOR_PATH: &str = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";

/// Largest predictor file read (dlib's 68-point model is 99.7 MB).
pub const MAX_PREDICTOR_BYTES: u64 = 1 << 30;

/// Most points a shape may have (iBUG-68 has 68; dlib's largest public model 194).
pub const MAX_PARTS: usize = 4096;

/// Most cascade stages (dlib's default is 10; 15 in its 68-point model).
pub const MAX_STAGES: usize = 1000;

/// Deepest tree read (dlib's default depth is 4; 2^20 leaves is far past any trained model).
pub const MAX_TREE_DEPTH: u32 = 20;

/// One split node: go left when `pixel[a] − pixel[b] > threshold`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub a: u32,
    pub b: u32,
    pub threshold: f32,
}

/// A complete binary regression tree: `splits` in breadth-first order (node i's children are
/// 2i+1 and 2i+2) and `2^depth` leaves, each a shape increment of `2·parts` values stored one
/// after another in `leaves`.
#[derive(Clone, Debug, PartialEq)]
pub struct Tree {
    pub splits: Vec<Split>,
    pub leaves: Vec<f32>,
}

/// One tree of a [`Forest`], borrowed: its splits and its leaves, as in [`Tree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeRef<'a> {
    pub splits: &'a [Split],
    pub leaves: &'a [f32],
}

/// The regression trees of one stage stored one after another: all their splits in one
/// buffer, all their leaves in another. Every run of the cascade walks a stage's trees in
/// order, so this reads each buffer front to back; one allocation per tree scattered the
/// trees over the predictor's 100 MB, and every tree then cost a cache and TLB miss before
/// its first split could be compared (the cascade's time was mostly those misses).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Forest {
    splits: Vec<Split>,
    leaves: Vec<f32>,
    /// Per tree, where its splits and its leaves end (each starts where the previous ends).
    ends: Vec<(usize, usize)>,
}

impl Forest {
    /// Appends a tree.
    pub fn push(&mut self, tree: &Tree) {
        self.splits.extend_from_slice(&tree.splits);
        self.leaves.extend_from_slice(&tree.leaves);
        self.ends.push((self.splits.len(), self.leaves.len()));
    }

    /// Number of trees.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// The trees in order.
    pub fn iter(&self) -> impl Iterator<Item = TreeRef<'_>> {
        let starts = std::iter::once((0, 0)).chain(self.ends.iter().copied());
        starts.zip(&self.ends).map(|((s0, l0), &(s1, l1))| TreeRef {
            splits: &self.splits[s0..s1],
            leaves: &self.leaves[l0..l1],
        })
    }

    /// Every leaf of every tree, one after another (a [`TreeRef`]'s `leaves` is a slice of
    /// it), for callers that index leaves by their offset in the stage.
    pub fn all_leaves(&self) -> &[f32] {
        &self.leaves
    }

    /// Owned copies of the trees (to edit, then collect back).
    pub fn to_trees(&self) -> Vec<Tree> {
        self.iter().map(|t| Tree { splits: t.splits.to_vec(), leaves: t.leaves.to_vec() }).collect()
    }
}

impl FromIterator<Tree> for Forest {
    fn from_iter<I: IntoIterator<Item = Tree>>(iter: I) -> Self {
        let mut f = Forest::default();
        for t in iter {
            f.push(&t);
        }
        f
    }
}

/// One stage of the cascade: the feature pixels (each an anchor point of the mean shape and
/// an offset from it, in the box-normalised frame) and the forest evaluated on them.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    pub anchors: Vec<u32>,
    pub offsets: Vec<Vector2<f32>>,
    pub trees: Forest,
}

/// dlib's ensemble-of-regression-trees shape predictor (Kazemi & Sullivan 2014), as read.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapePredictor {
    /// The mean shape in the box-normalised frame ((0,0) top-left, (1,1) bottom-right).
    pub mean_shape: Vec<Vector2<f32>>,
    pub stages: Vec<Stage>,
}

impl ShapePredictor {
    /// Number of points of a shape (68 for iBUG-68).
    pub fn num_parts(&self) -> usize {
        self.mean_shape.len()
    }
}

/// Reads a shape predictor file.
///
/// # Errors
/// The file cannot be read, is over [`MAX_PREDICTOR_BYTES`], or is not a valid predictor
/// (naming the byte offset and the field).
pub fn read_shape_predictor(path: &Path) -> Result<ShapePredictor, FormatError> {
    let bytes = crate::io::input::read_input_capped(path, MAX_PREDICTOR_BYTES)?;
    parse_shape_predictor(&bytes, path)
}

/// Parses the bytes of a shape predictor file; `path` names it in errors.
///
/// # Errors
/// A `FormatError` at the byte offset of the first field that is truncated, out of range or
/// inconsistent with the rest.
pub fn parse_shape_predictor(bytes: &[u8], path: &Path) -> Result<ShapePredictor, FormatError> {
    let mut r = Reader { bytes, pos: 0, path };
    let at = r.pos;
    let version = r.signed("version", 4)?;
    if version != 1 {
        return Err(r.error_at(
            at,
            "version",
            format!("{version}, but only version 1 of dlib's shape predictor is known"),
        ));
    }
    let mean = r.column_vector("initial_shape")?;
    if mean.is_empty() || mean.len() % 2 != 0 || mean.len() / 2 > MAX_PARTS {
        return Err(r.error_at(
            at,
            "initial_shape",
            format!("{} values, not an even count of 2 to {}", mean.len(), 2 * MAX_PARTS),
        ));
    }
    let mean_shape: Vec<Vector2<f32>> =
        mean.chunks_exact(2).map(|p| Vector2::new(p[0], p[1])).collect();
    let n_values = mean.len();

    let n_stages = r.count("forests", MAX_STAGES, 1)?;
    let mut forests = Vec::with_capacity(n_stages);
    for s in 0..n_stages {
        let field = format!("forests[{s}]");
        // A tree is at least an empty split list and one leaf of `n_values` floats (≥ 2 bytes
        // each).
        let n_trees = r.count(&field, usize::MAX, 2 + 2 * n_values)?;
        let mut trees = Forest::default();
        for t in 0..n_trees {
            trees.push(&r.tree(&format!("{field}[{t}]"), n_values)?);
        }
        forests.push(trees);
    }

    let n_anchor_sets = r.count("anchor_idx", MAX_STAGES, 1)?;
    if n_anchor_sets != n_stages {
        return Err(r.error_here(
            "anchor_idx",
            format!("{n_anchor_sets} stages of feature pixels for {n_stages} forests"),
        ));
    }
    let mut anchors = Vec::with_capacity(n_stages);
    for s in 0..n_stages {
        let field = format!("anchor_idx[{s}]");
        let n = r.count(&field, usize::MAX, 2)?;
        let mut idx = Vec::with_capacity(n);
        for _ in 0..n {
            let at = r.pos;
            let i = r.unsigned(&field, 8)?;
            if i >= mean_shape.len() as u64 {
                return Err(r.error_at(
                    at,
                    &field,
                    format!("anchor point {i}, but the shape has {} points", mean_shape.len()),
                ));
            }
            idx.push(i as u32);
        }
        anchors.push(idx);
    }

    let n_delta_sets = r.count("deltas", MAX_STAGES, 1)?;
    if n_delta_sets != n_stages {
        return Err(r.error_here(
            "deltas",
            format!("{n_delta_sets} stages of pixel offsets for {n_stages} forests"),
        ));
    }
    let mut stages = Vec::with_capacity(n_stages);
    for (s, (trees, anchors)) in forests.into_iter().zip(anchors).enumerate() {
        let field = format!("deltas[{s}]");
        let n = r.count(&field, usize::MAX, 4)?;
        if n != anchors.len() {
            return Err(r.error_here(
                &field,
                format!("{n} pixel offsets for {} anchor points", anchors.len()),
            ));
        }
        let mut offsets = Vec::with_capacity(n);
        for _ in 0..n {
            let x = r.float(&field)?;
            let y = r.float(&field)?;
            offsets.push(Vector2::new(x, y));
        }
        if let Some((t, split)) = trees.iter().enumerate().find_map(|(t, tree)| {
            tree.splits.iter().find(|sp| sp.a.max(sp.b) as usize >= n).map(|sp| (t, sp))
        }) {
            return Err(r.error_here(
                &format!("forests[{s}][{t}]"),
                format!(
                    "a split compares feature pixels {} and {}, but stage {s} has {n}",
                    split.a, split.b
                ),
            ));
        }
        stages.push(Stage { anchors, offsets, trees });
    }
    Ok(ShapePredictor { mean_shape, stages })
}

/// A cursor over the file's bytes that names the file in its errors.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl Reader<'_> {
    fn error_at(&self, at: usize, field: &str, message: impl Into<String>) -> FormatError {
        FormatError::new(
            self.path,
            Location::Offset(at as u64),
            format!("field `{field}`: {}", message.into()),
        )
    }

    fn error_here(&self, field: &str, message: impl Into<String>) -> FormatError {
        self.error_at(self.pos, field, message)
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn byte(&mut self, field: &str) -> Result<u8, FormatError> {
        let b = *self
            .bytes
            .get(self.pos)
            .ok_or_else(|| self.error_here(field, "the file ends here (truncated?)"))?;
        self.pos += 1;
        Ok(b)
    }

    /// `size` magnitude bytes, little-endian, after a control byte at `at`.
    fn magnitude(
        &mut self,
        at: usize,
        field: &str,
        size: usize,
        max: usize,
    ) -> Result<u64, FormatError> {
        if size == 0 || size > max {
            return Err(self.error_at(
                at,
                field,
                format!("an integer of {size} bytes where 1 to {max} are allowed"),
            ));
        }
        if self.remaining() < size {
            return Err(self.error_here(field, "the file ends inside an integer (truncated?)"));
        }
        let v = self.bytes[self.pos..self.pos + size]
            .iter()
            .rev()
            .fold(0u64, |acc, &b| (acc << 8) | u64::from(b));
        self.pos += size;
        Ok(v)
    }

    /// An unsigned integer of at most `max` bytes (dlib masks out bits 4–6 of the control
    /// byte and keeps bit 7, which makes a "negative" unsigned value an error).
    fn unsigned(&mut self, field: &str, max: usize) -> Result<u64, FormatError> {
        let at = self.pos;
        let control = self.byte(field)? & 0x8F;
        self.magnitude(at, field, usize::from(control), max)
    }

    /// A signed integer of at most `max` bytes.
    fn signed(&mut self, field: &str, max: usize) -> Result<i64, FormatError> {
        let at = self.pos;
        let control = self.byte(field)?;
        let m = self.magnitude(at, field, usize::from(control & 0x0F), max)?;
        let v = i64::try_from(m).map_err(|_| self.error_at(at, field, "integer out of range"))?;
        Ok(if control & 0x80 != 0 { -v } else { v })
    }

    /// A vector length, at most `max` and at most what the remaining bytes could hold at
    /// `min_item_bytes` per item.
    fn count(
        &mut self,
        field: &str,
        max: usize,
        min_item_bytes: usize,
    ) -> Result<usize, FormatError> {
        let at = self.pos;
        let n = self.unsigned(field, 8)?;
        let room = self.remaining() / min_item_bytes.max(1);
        if n > max as u64 || n > room as u64 {
            return Err(self.error_at(
                at,
                field,
                format!("{n} items, more than the rest of the file can hold"),
            ));
        }
        Ok(n as usize)
    }

    /// A finite float in dlib's portable encoding, as dlib's `float` conversion gives it.
    fn float(&mut self, field: &str) -> Result<f32, FormatError> {
        let at = self.pos;
        let first = *self
            .bytes
            .get(self.pos)
            .ok_or_else(|| self.error_here(field, "the file ends here (truncated?)"))?;
        if first & 0x70 != 0 {
            return Err(self.error_at(
                at,
                field,
                "a float in dlib's old text encoding, which lipmap does not read",
            ));
        }
        let mantissa = self.signed(field, 8)?;
        let exponent = self.signed(field, 2)?;
        if exponent >= 32000 {
            return Err(self.error_at(at, field, "an infinite or NaN value"));
        }
        // dlib rounds the mantissa to the float type first, then scales by 2^e.
        let v = f64::from(mantissa as f32) * 2f64.powi(exponent as i32);
        let v = v as f32;
        if !v.is_finite() {
            return Err(self.error_at(at, field, "a value too large for a 32-bit float"));
        }
        Ok(v)
    }

    /// A column vector (dlib `matrix<float,0,1>`) of floats.
    fn column_vector(&mut self, field: &str) -> Result<Vec<f32>, FormatError> {
        let at = self.pos;
        let rows = self.signed(field, 8)?.unsigned_abs();
        let cols = self.signed(field, 8)?.unsigned_abs();
        if cols != 1 && rows != 0 {
            return Err(self.error_at(at, field, format!("a {rows}×{cols} matrix, not a column")));
        }
        if rows > (self.remaining() / 2) as u64 {
            return Err(self.error_at(
                at,
                field,
                format!("{rows} values, more than the rest of the file can hold"),
            ));
        }
        (0..rows).map(|_| self.float(field)).collect()
    }

    /// One regression tree whose leaves each hold `n_values` floats.
    fn tree(&mut self, field: &str, n_values: usize) -> Result<Tree, FormatError> {
        let at = self.pos;
        // A split is three numbers of at least two bytes each.
        let n_splits = self.count(&format!("{field}.splits"), (1 << MAX_TREE_DEPTH) - 1, 6)?;
        if !(n_splits + 1).is_power_of_two() {
            return Err(self.error_at(
                at,
                &format!("{field}.splits"),
                format!("{n_splits} splits, not a complete binary tree (2^depth − 1)"),
            ));
        }
        let mut splits = Vec::with_capacity(n_splits);
        for _ in 0..n_splits {
            let f = format!("{field}.splits");
            let a = self.unsigned(&f, 8)?;
            let b = self.unsigned(&f, 8)?;
            let threshold = self.float(&f)?;
            let (Ok(a), Ok(b)) = (u32::try_from(a), u32::try_from(b)) else {
                return Err(self.error_here(&f, "a feature pixel index out of range"));
            };
            splits.push(Split { a, b, threshold });
        }
        let leaves_field = format!("{field}.leaf_values");
        let at = self.pos;
        let n_leaves = self.count(&leaves_field, 1 << MAX_TREE_DEPTH, 2 + 2 * n_values)?;
        if n_leaves != n_splits + 1 {
            return Err(self.error_at(
                at,
                &leaves_field,
                format!("{n_leaves} leaves for {n_splits} splits (a complete tree has one more)"),
            ));
        }
        let mut leaves = Vec::with_capacity(n_leaves * n_values);
        for _ in 0..n_leaves {
            let at = self.pos;
            let v = self.column_vector(&leaves_field)?;
            if v.len() != n_values {
                return Err(self.error_at(
                    at,
                    &leaves_field,
                    format!("a leaf of {} values, but shapes have {n_values}", v.len()),
                ));
            }
            leaves.extend_from_slice(&v);
        }
        Ok(Tree { splits, leaves })
    }
}

/// Writing in dlib's encoding, for building small predictors in tests and fuzz seeds.
#[cfg(any(test, feature = "test-fixtures"))]
pub mod encode {
    use super::ShapePredictor;

    /// An unsigned integer as dlib writes it.
    pub fn unsigned(out: &mut Vec<u8>, mut v: u64) {
        let mut buf = Vec::new();
        loop {
            buf.push((v & 0xFF) as u8);
            v >>= 8;
            if v == 0 {
                break;
            }
        }
        out.push(buf.len() as u8);
        out.extend(buf);
    }

    /// A signed integer as dlib writes it.
    pub fn signed(out: &mut Vec<u8>, v: i64) {
        let start = out.len();
        unsigned(out, v.unsigned_abs());
        if v < 0 {
            out[start] |= 0x80;
        }
    }

    /// A float as dlib writes it (mantissa with trailing zero bytes shifted off, exponent).
    pub fn float(out: &mut Vec<u8>, v: f32) {
        let (mut mantissa, mut exponent) = if v == 0.0 {
            (0i64, 0i64)
        } else {
            let bits = v.to_bits();
            let sign = if bits >> 31 == 1 { -1 } else { 1 };
            let exp = ((bits >> 23) & 0xFF) as i64;
            let frac = (bits & 0x7F_FFFF) as i64;
            let (m, e) = if exp == 0 { (frac, -149) } else { (frac | 0x80_0000, exp - 150) };
            (sign * m, e)
        };
        while mantissa != 0 && mantissa & 0xFF == 0 {
            mantissa >>= 8;
            exponent += 8;
        }
        signed(out, mantissa);
        signed(out, exponent);
    }

    fn column(out: &mut Vec<u8>, values: &[f32]) {
        signed(out, -(values.len() as i64));
        signed(out, -1);
        for &v in values {
            float(out, v);
        }
    }

    /// The whole predictor in dlib's layout.
    pub fn predictor(p: &ShapePredictor) -> Vec<u8> {
        let mut out = Vec::new();
        signed(&mut out, 1);
        let mean: Vec<f32> = p.mean_shape.iter().flat_map(|v| [v.x, v.y]).collect();
        column(&mut out, &mean);
        unsigned(&mut out, p.stages.len() as u64);
        for s in &p.stages {
            unsigned(&mut out, s.trees.len() as u64);
            for t in s.trees.iter() {
                unsigned(&mut out, t.splits.len() as u64);
                for sp in t.splits {
                    unsigned(&mut out, u64::from(sp.a));
                    unsigned(&mut out, u64::from(sp.b));
                    float(&mut out, sp.threshold);
                }
                let n = mean.len();
                unsigned(&mut out, (t.leaves.len() / n.max(1)) as u64);
                for leaf in t.leaves.chunks(n.max(1)) {
                    column(&mut out, leaf);
                }
            }
        }
        unsigned(&mut out, p.stages.len() as u64);
        for s in &p.stages {
            unsigned(&mut out, s.anchors.len() as u64);
            for &a in &s.anchors {
                unsigned(&mut out, u64::from(a));
            }
        }
        unsigned(&mut out, p.stages.len() as u64);
        for s in &p.stages {
            unsigned(&mut out, s.offsets.len() as u64);
            for o in &s.offsets {
                float(&mut out, o.x);
                float(&mut out, o.y);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny two-point, one-stage predictor with one depth-1 tree.
    pub(crate) fn tiny() -> ShapePredictor {
        ShapePredictor {
            mean_shape: vec![Vector2::new(0.25, 0.5), Vector2::new(0.75, 0.5)],
            stages: vec![Stage {
                anchors: vec![0, 1],
                offsets: vec![Vector2::new(-0.125, 0.0), Vector2::new(0.1, -3.5e-7)],
                trees: [Tree {
                    splits: vec![Split { a: 0, b: 1, threshold: 12.5 }],
                    leaves: vec![0.01, 0.0, -0.01, 0.0, -0.02, 0.5, 0.02, -1e-3],
                }]
                .into_iter()
                .collect(),
            }],
        }
    }

    #[test]
    fn what_is_written_in_dlibs_encoding_reads_back_identically() {
        let p = tiny();
        let bytes = encode::predictor(&p);
        assert_eq!(parse_shape_predictor(&bytes, Path::new("t.dat")).unwrap(), p);
    }

    #[test]
    fn integers_and_floats_decode_as_dlib_writes_them() {
        // 300 = 0x012C: two bytes, little-endian; −5: sign bit on the control byte.
        let mut out = Vec::new();
        encode::unsigned(&mut out, 300);
        encode::signed(&mut out, -5);
        assert_eq!(out, [2, 0x2C, 0x01, 0x81, 5]);
        let mut r = Reader { bytes: &out, pos: 0, path: Path::new("x") };
        assert_eq!(r.unsigned("a", 8).unwrap(), 300);
        assert_eq!(r.signed("b", 8).unwrap(), -5);
        for v in [0.0f32, 1.0, -0.375, 1e-30, 3.4e38, 0.1] {
            let mut out = Vec::new();
            encode::float(&mut out, v);
            let mut r = Reader { bytes: &out, pos: 0, path: Path::new("x") };
            assert_eq!(r.float("f").unwrap(), v);
        }
    }

    #[test]
    fn every_truncation_is_a_one_line_error_naming_the_file_and_a_field() {
        let bytes = encode::predictor(&tiny());
        for n in 0..bytes.len() {
            let e = parse_shape_predictor(&bytes[..n], Path::new("sp.dat")).unwrap_err();
            let msg = e.to_string();
            assert!(msg.starts_with("sp.dat: byte "), "{msg}");
            assert!(msg.contains("field `"), "{msg}");
            assert!(!msg.contains('\n'), "{msg}");
        }
    }

    #[test]
    fn a_huge_count_is_refused_before_anything_is_allocated() {
        let mut bytes = Vec::new();
        encode::signed(&mut bytes, 1);
        encode::signed(&mut bytes, -2);
        encode::signed(&mut bytes, -1);
        encode::float(&mut bytes, 0.5);
        encode::float(&mut bytes, 0.5);
        encode::unsigned(&mut bytes, 1);
        encode::unsigned(&mut bytes, u64::MAX);
        let e = parse_shape_predictor(&bytes, Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("field `forests[0]`"), "{e}");
    }

    #[test]
    fn inconsistent_trees_and_indices_are_refused_naming_the_field() {
        let with_tree = |edit: &dyn Fn(&mut Tree)| {
            let mut p = tiny();
            let mut trees = p.stages[0].trees.to_trees();
            edit(&mut trees[0]);
            p.stages[0].trees = trees.into_iter().collect();
            p
        };
        let p = with_tree(&|t| t.splits[0].b = 7);
        let e = parse_shape_predictor(&encode::predictor(&p), Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("forests[0][0]"), "{e}");
        let mut p = tiny();
        p.stages[0].anchors[1] = 2;
        let e = parse_shape_predictor(&encode::predictor(&p), Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("anchor_idx[0]"), "{e}");
        let p = with_tree(&|t| t.leaves.truncate(6));
        let e = parse_shape_predictor(&encode::predictor(&p), Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("leaf_values"), "{e}");
        let mut bytes = encode::predictor(&tiny());
        bytes[1] = 2;
        let e = parse_shape_predictor(&bytes, Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("field `version`: 2"), "{e}");
    }

    proptest::proptest! {
        /// What the fuzz target checks, on mutations of a valid file: an error or a
        /// predictor whose cascade runs.
        #[test]
        fn mutated_files_give_an_error_or_a_runnable_predictor(
            edits in proptest::collection::vec((0usize..1000, proptest::num::u8::ANY), 1..6),
        ) {
            let mut bytes = encode::predictor(&tiny());
            for (at, b) in edits {
                let i = at % bytes.len();
                bytes[i] = b;
            }
            if let Ok(p) = parse_shape_predictor(&bytes, Path::new("m.dat")) {
                let px = [7u8; 64];
                let img = crate::track::GrayView { width: 8, height: 8, pixels: &px };
                let face = crate::track::FaceBox { left: 1.0, top: 1.0, width: 5.0, height: 5.0 };
                let out = crate::track::run_cascade(&p, img, &face, &Default::default());
                proptest::prop_assert_eq!(out.len(), p.num_parts());
            }
        }
    }

    #[test]
    fn non_finite_floats_are_refused() {
        let mut bytes = Vec::new();
        encode::signed(&mut bytes, 1);
        encode::signed(&mut bytes, -2);
        encode::signed(&mut bytes, -1);
        encode::signed(&mut bytes, 0);
        encode::signed(&mut bytes, 32002);
        let e = parse_shape_predictor(&bytes, Path::new("sp.dat")).unwrap_err();
        assert!(e.to_string().contains("NaN"), "{e}");
    }
}
