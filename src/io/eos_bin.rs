//! Import of eos's cereal binary model files: `sfm_shape_3448.bin`-style morphable models
//! and `expression_blendshapes_3448.bin`-style blendshape lists. Little-endian throughout.
//!
//! Layout (eos `MorphableModel::serialize`, cereal `BinaryArchive`):
//! - model: `u32` version; shape PCA part; colour PCA part; for version < 2 then `u64` n +
//!   n×2 `f64` texture coordinates (the file must end there). A PCA part is three Eigen
//!   matrices (mean 3N×1, orthonormal basis 3N×K, eigenvalues K×1), each `i32` rows, `i32`
//!   cols, rows×cols `f32` column-major; then `u64` T + T×3 `i32` 0-based triangles.
//!   For version ≥ 2 (models with their own expression part) only the shape part is read:
//!   the rest is not needed for fitting and its layout varies between eos releases.
//! - blendshapes: `u64` count; per blendshape `u64` name length, the UTF-8 name, and a
//!   3N×1 matrix as above.
//!
//! Truncation or a bad size is a [`FormatError`] at the byte offset where reading failed.

use crate::io::error::{FormatError, Location, Result};
use crate::math::{DMatrix, DVector};
use crate::model::{Expressions, MorphableModel, PcaModel};
use std::path::Path;

/// Reads an eos morphable model (`.bin`): its shape part becomes the PCA model, its
/// triangles the model's triangles; the colour part and texture coordinates are skipped.
///
/// # Errors
/// Unreadable file, truncation (with the byte offset), inconsistent sizes, or a model that
/// fails [`MorphableModel::validate`].
pub fn read_eos_model(path: &Path) -> Result<MorphableModel> {
    let bytes = super::input::read_input(path)?;
    parse_eos_model(&bytes, path)
}

/// Parses the bytes of an eos model file; `path` is used only in error messages.
///
/// # Errors
/// As [`read_eos_model`].
pub fn parse_eos_model(bytes: &[u8], path: &Path) -> Result<MorphableModel> {
    let mut r = Reader { bytes, pos: 0, path };
    let version = r.u32("version")?;
    let (shape, triangles) = r.pca_part("shape model")?;
    if version < 2 {
        r.pca_part("colour model")?;
        let n = r.u64("texture coordinate count")?;
        r.skip_array(n, 16, "texture coordinates")?;
        r.expect_end()?;
    }
    let model = MorphableModel { shape, expressions: None, triangles };
    model.validate().map_err(|e| FormatError::whole(path, e.to_string()))?;
    Ok(model)
}

/// Reads an eos blendshape file into expression deltas (one column per blendshape).
///
/// # Errors
/// Unreadable file, truncation (with the byte offset), a blendshape that is not a
/// column vector, or blendshapes of different lengths.
pub fn read_eos_blendshapes(path: &Path) -> Result<Expressions> {
    let bytes = super::input::read_input(path)?;
    parse_eos_blendshapes(&bytes, path)
}

/// Parses the bytes of an eos blendshape file; `path` is used only in error messages.
///
/// # Errors
/// As [`read_eos_blendshapes`].
pub fn parse_eos_blendshapes(bytes: &[u8], path: &Path) -> Result<Expressions> {
    let mut r = Reader { bytes, pos: 0, path };
    let count = r.u64("blendshape count")?;
    // Each blendshape takes at least 16 bytes (name length + matrix header).
    if count > (bytes.len() as u64) / 16 {
        return Err(r.error_at(0, format!("blendshape count {count} exceeds the file size")));
    }
    let mut names = Vec::new();
    let mut columns: Vec<DVector> = Vec::new();
    for j in 0..count as usize {
        let len = r.u64("name length")?;
        let at = r.pos;
        let name = r.take(len, "blendshape name")?;
        let name = std::str::from_utf8(name)
            .map_err(|_| r.error_at(at, "blendshape name is not UTF-8"))?
            .to_string();
        let at = r.pos;
        let m = r.matrix(&format!("blendshape `{name}`"))?;
        if m.ncols() != 1 {
            return Err(r.error_at(
                at,
                format!("blendshape `{name}` is {}×{}, not a column", m.nrows(), m.ncols()),
            ));
        }
        if let Some(first) = columns.first()
            && first.len() != m.nrows()
        {
            return Err(r.error_at(
                at,
                format!(
                    "blendshape {j} `{name}` has {} rows, the first has {}",
                    m.nrows(),
                    first.len()
                ),
            ));
        }
        names.push(name);
        columns.push(m.column(0).into_owned());
    }
    r.expect_end()?;
    let rows = columns.first().map_or(0, |c| c.len());
    let mut deltas = DMatrix::zeros(rows, columns.len());
    for (j, c) in columns.iter().enumerate() {
        deltas.column_mut(j).copy_from(c);
    }
    Ok(Expressions { names, deltas })
}

/// A bounds-checked little-endian cursor that reports failures at its byte offset.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn error_at(&self, offset: usize, message: impl Into<String>) -> FormatError {
        FormatError::new(self.path, Location::Offset(offset as u64), message)
    }

    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8]> {
        let left = self.bytes.len() - self.pos;
        if n > left as u64 {
            return Err(self.error_at(
                self.pos,
                format!("truncated: {what} needs {n} bytes, only {left} left"),
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes(b.try_into().expect("4 bytes")))
    }

    fn i32(&mut self, what: &str) -> Result<i32> {
        let b = self.take(4, what)?;
        Ok(i32::from_le_bytes(b.try_into().expect("4 bytes")))
    }

    fn u64(&mut self, what: &str) -> Result<u64> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }

    fn skip_array(&mut self, count: u64, item_bytes: u64, what: &str) -> Result<()> {
        let n = count
            .checked_mul(item_bytes)
            .ok_or_else(|| self.error_at(self.pos, format!("{what}: count {count} overflows")))?;
        self.take(n, what).map(|_| ())
    }

    /// An Eigen `f32` matrix: i32 rows, i32 cols, column-major data, widened to f64.
    fn matrix(&mut self, what: &str) -> Result<DMatrix> {
        let at = self.pos;
        let rows = self.i32(&format!("{what} rows"))?;
        let cols = self.i32(&format!("{what} cols"))?;
        if rows < 0 || cols < 0 {
            return Err(self.error_at(at, format!("{what} has negative size {rows}×{cols}")));
        }
        let (rows, cols) = (rows as usize, cols as usize);
        let data = self.take(rows as u64 * cols as u64 * 4, what)?;
        let values =
            data.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")) as f64);
        Ok(DMatrix::from_iterator(rows, cols, values))
    }

    fn pca_part(&mut self, what: &str) -> Result<(PcaModel, Vec<[u32; 3]>)> {
        let at = self.pos;
        let mean = self.matrix(&format!("{what} mean"))?;
        if mean.ncols() > 1 {
            return Err(self.error_at(
                at,
                format!("{what} mean is {}×{}, not a column", mean.nrows(), mean.ncols()),
            ));
        }
        let at_basis = self.pos;
        let basis = self.matrix(&format!("{what} basis"))?;
        let at_ev = self.pos;
        let ev = self.matrix(&format!("{what} eigenvalues"))?;
        let mean = DVector::from_column_slice(mean.as_slice());
        let eigenvalues = DVector::from_column_slice(ev.as_slice());
        // An empty part (eos's colour model of a shape-only file) is 0×0 throughout.
        if basis.nrows() != mean.len() && !basis.is_empty() {
            return Err(self.error_at(
                at_basis,
                format!("{what} basis has {} rows, the mean {}", basis.nrows(), mean.len()),
            ));
        }
        if eigenvalues.len() != basis.ncols() {
            return Err(self.error_at(
                at_ev,
                format!(
                    "{what}: {} eigenvalues for {} basis columns",
                    eigenvalues.len(),
                    basis.ncols()
                ),
            ));
        }
        let at_tri = self.pos;
        let count = self.u64(&format!("{what} triangle count"))?;
        let data = self.take(count.saturating_mul(12), &format!("{what} triangles"))?;
        let mut triangles = Vec::with_capacity(count as usize);
        for (t, c) in data.chunks_exact(12).enumerate() {
            let mut tri = [0u32; 3];
            for (k, slot) in tri.iter_mut().enumerate() {
                let v = i32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"));
                *slot = u32::try_from(v).map_err(|_| {
                    self.error_at(
                        at_tri + 8 + 12 * t + 4 * k,
                        format!("{what} triangle {t} has vertex {v}"),
                    )
                })?;
            }
            triangles.push(tri);
        }
        let basis = if basis.is_empty() { DMatrix::zeros(mean.len(), 0) } else { basis };
        Ok((PcaModel { mean, basis, eigenvalues }, triangles))
    }

    fn expect_end(&self) -> Result<()> {
        if self.pos != self.bytes.len() {
            return Err(self.error_at(
                self.pos,
                format!("{} unexpected trailing bytes", self.bytes.len() - self.pos),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes a tiny version-1 eos file: 2 vertices, 1 component, 1 triangle, no colour.
    fn tiny_model() -> Vec<u8> {
        let mut b = Vec::new();
        let mat = |b: &mut Vec<u8>, r: i32, c: i32, v: &[f32]| {
            b.extend(r.to_le_bytes());
            b.extend(c.to_le_bytes());
            for x in v {
                b.extend(x.to_le_bytes());
            }
        };
        b.extend(1u32.to_le_bytes());
        mat(&mut b, 6, 1, &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        mat(&mut b, 6, 1, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        mat(&mut b, 1, 1, &[2.5]);
        b.extend(1u64.to_le_bytes());
        for v in [0i32, 1, 1] {
            b.extend(v.to_le_bytes());
        }
        for _ in 0..3 {
            mat(&mut b, 0, 0, &[]);
        }
        b.extend(0u64.to_le_bytes());
        b.extend(0u64.to_le_bytes());
        b
    }

    #[test]
    fn parses_a_minimal_model() {
        let m = parse_eos_model(&tiny_model(), Path::new("m.bin")).unwrap();
        assert_eq!(m.num_vertices(), 2);
        assert_eq!(m.shape.eigenvalues[0], 2.5);
        assert_eq!(m.triangles, vec![[0, 1, 1]]);
    }

    #[test]
    fn truncation_reports_the_offset() {
        let full = tiny_model();
        for cut in [0, 3, 10, 30, full.len() - 1] {
            let e = parse_eos_model(&full[..cut], Path::new("m.bin")).unwrap_err();
            match e.location {
                Location::Offset(o) => assert!(o as usize <= cut, "offset {o} past cut {cut}"),
                ref l => panic!("expected an offset, got {l:?}"),
            }
            assert!(e.to_string().contains("truncated"), "{e}");
        }
        let mut extra = full.clone();
        extra.push(0);
        assert!(parse_eos_model(&extra, Path::new("m.bin")).is_err());
    }
}
