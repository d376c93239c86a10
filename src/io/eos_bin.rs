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
use std::io::{BufReader, Read};
use std::path::Path;

/// Reads an eos morphable model (`.bin`): its shape part becomes the PCA model, its
/// triangles the model's triangles; the colour part and texture coordinates are skipped.
///
/// The file is read through a small buffer and its matrices converted as they arrive: a
/// whole-file copy of a model would be megabytes of fresh memory touched once, its page
/// faults a sizeable part of a short `lipmap fit` (docs/performance.md).
///
/// # Errors
/// Unreadable file, truncation (with the byte offset), inconsistent sizes, or a model that
/// fails [`MorphableModel::validate`].
pub fn read_eos_model(path: &Path) -> Result<MorphableModel> {
    let (file, len) = super::input::open_input_sized(path, super::input::MAX_INPUT_BYTES)?;
    eos_model_from(Reader::new(BufReader::with_capacity(READ_BUFFER, file), len, path))
}

/// Parses the bytes of an eos model file; `path` is used only in error messages.
///
/// # Errors
/// As [`read_eos_model`].
pub fn parse_eos_model(bytes: &[u8], path: &Path) -> Result<MorphableModel> {
    eos_model_from(Reader::new(bytes, bytes.len() as u64, path))
}

fn eos_model_from(mut r: Reader<'_, impl Read>) -> Result<MorphableModel> {
    let version = r.u32("version")?;
    let (shape, triangles) = r.pca_part("shape model")?;
    if version < 2 {
        r.pca_part("colour model")?;
        let n = r.u64("texture coordinate count")?;
        r.skip_array(n, 16, "texture coordinates")?;
        r.expect_end()?;
    }
    let model = MorphableModel { shape, expressions: None, triangles };
    model.validate().map_err(|e| FormatError::whole(r.path, e.to_string()))?;
    Ok(model)
}

/// Reads an eos blendshape file into expression deltas (one column per blendshape).
///
/// # Errors
/// Unreadable file, truncation (with the byte offset), a blendshape that is not a
/// column vector, or blendshapes of different lengths.
pub fn read_eos_blendshapes(path: &Path) -> Result<Expressions> {
    let (file, len) = super::input::open_input_sized(path, super::input::MAX_INPUT_BYTES)?;
    eos_blendshapes_from(Reader::new(BufReader::with_capacity(READ_BUFFER, file), len, path))
}

/// Parses the bytes of an eos blendshape file; `path` is used only in error messages.
///
/// # Errors
/// As [`read_eos_blendshapes`].
pub fn parse_eos_blendshapes(bytes: &[u8], path: &Path) -> Result<Expressions> {
    eos_blendshapes_from(Reader::new(bytes, bytes.len() as u64, path))
}

fn eos_blendshapes_from(mut r: Reader<'_, impl Read>) -> Result<Expressions> {
    let count = r.u64("blendshape count")?;
    // Each blendshape takes at least 16 bytes (name length + matrix header).
    if count > r.len / 16 {
        return Err(r.error_at(0, format!("blendshape count {count} exceeds the file size")));
    }
    let mut names = Vec::new();
    let mut columns: Vec<DVector> = Vec::new();
    for j in 0..count as usize {
        let len = r.u64("name length")?;
        let at = r.pos;
        let name = r.bytes(len, "blendshape name")?;
        let name =
            String::from_utf8(name).map_err(|_| r.error_at(at, "blendshape name is not UTF-8"))?;
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

/// Bytes read from a model file at a time.
const READ_BUFFER: usize = 64 << 10;

/// A bounds-checked little-endian cursor over `len` bytes of `input` that reports failures
/// at its byte offset. The sizes a file states are checked against `len` before anything is
/// allocated for them.
struct Reader<'a, R> {
    input: R,
    len: u64,
    pos: u64,
    path: &'a Path,
}

impl<'a, R: Read> Reader<'a, R> {
    fn new(input: R, len: u64, path: &'a Path) -> Self {
        Self { input, len, pos: 0, path }
    }

    fn error_at(&self, offset: u64, message: impl Into<String>) -> FormatError {
        FormatError::new(self.path, Location::Offset(offset), message)
    }

    fn truncated(&self, n: u64, what: &str) -> FormatError {
        let left = self.len.saturating_sub(self.pos);
        self.error_at(self.pos, format!("truncated: {what} needs {n} bytes, only {left} left"))
    }

    /// Checks that `n` more bytes are there.
    fn need(&self, n: u64, what: &str) -> Result<()> {
        if n > self.len.saturating_sub(self.pos) {
            return Err(self.truncated(n, what));
        }
        Ok(())
    }

    /// Fills `out` with the next bytes; a file that shrank while read is truncated there.
    fn fill(&mut self, out: &mut [u8], what: &str) -> Result<()> {
        let n = out.len() as u64;
        self.need(n, what)?;
        match self.input.read_exact(out) {
            Ok(()) => {
                self.pos += n;
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(self.truncated(n, what)),
            Err(e) => Err(FormatError::io(self.path, e)),
        }
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        self.fill(&mut b, what)?;
        Ok(b)
    }

    /// The next `n` bytes.
    fn bytes(&mut self, n: u64, what: &str) -> Result<Vec<u8>> {
        self.need(n, what)?;
        let mut b = vec![0u8; n as usize];
        self.fill(&mut b, what)?;
        Ok(b)
    }

    fn u32(&mut self, what: &str) -> Result<u32> {
        self.array(what).map(u32::from_le_bytes)
    }

    fn i32(&mut self, what: &str) -> Result<i32> {
        self.array(what).map(i32::from_le_bytes)
    }

    fn u64(&mut self, what: &str) -> Result<u64> {
        self.array(what).map(u64::from_le_bytes)
    }

    fn skip_array(&mut self, count: u64, item_bytes: u64, what: &str) -> Result<()> {
        let n = count
            .checked_mul(item_bytes)
            .ok_or_else(|| self.error_at(self.pos, format!("{what}: count {count} overflows")))?;
        self.need(n, what)?;
        let copied = std::io::copy(&mut (&mut self.input).take(n), &mut std::io::sink())
            .map_err(|e| FormatError::io(self.path, e))?;
        if copied < n {
            return Err(self.truncated(n, what));
        }
        self.pos += n;
        Ok(())
    }

    /// An Eigen `f32` matrix: i32 rows, i32 cols, column-major data, widened to f64 a
    /// buffer at a time.
    fn matrix(&mut self, what: &str) -> Result<DMatrix> {
        let at = self.pos;
        let rows = self.i32(&format!("{what} rows"))?;
        let cols = self.i32(&format!("{what} cols"))?;
        if rows < 0 || cols < 0 {
            return Err(self.error_at(at, format!("{what} has negative size {rows}×{cols}")));
        }
        let (rows, cols) = (rows as usize, cols as usize);
        let total = rows as u64 * cols as u64;
        self.need(total.saturating_mul(4), what)?;
        let mut values = Vec::with_capacity(total as usize);
        let mut chunk = [0u8; 4096];
        while values.len() < total as usize {
            let n = chunk.len().min(4 * (total as usize - values.len()));
            self.fill(&mut chunk[..n], what)?;
            values.extend(
                chunk[..n]
                    .chunks_exact(4)
                    .map(|c| f64::from(f32::from_le_bytes(c.try_into().expect("4 bytes")))),
            );
        }
        Ok(DMatrix::from_vec(rows, cols, values))
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
        let data = self.bytes(count.saturating_mul(12), &format!("{what} triangles"))?;
        let mut triangles = Vec::with_capacity(count as usize);
        for (t, c) in data.chunks_exact(12).enumerate() {
            let mut tri = [0u32; 3];
            for (k, slot) in tri.iter_mut().enumerate() {
                let v = i32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"));
                *slot = u32::try_from(v).map_err(|_| {
                    self.error_at(
                        at_tri + 8 + 12 * t as u64 + 4 * k as u64,
                        format!("{what} triangle {t} has vertex {v}"),
                    )
                })?;
            }
            triangles.push(tri);
        }
        let basis = if basis.is_empty() { DMatrix::zeros(mean.len(), 0) } else { basis };
        Ok((PcaModel { mean, basis, eigenvalues }, triangles))
    }

    /// The file ends here: at its stated length, and nothing more to read (a file that grew
    /// while read is refused as well).
    fn expect_end(&mut self) -> Result<()> {
        let mut probe = [0u8; 1];
        let more = loop {
            match self.input.read(&mut probe) {
                Ok(n) => break n > 0,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(FormatError::io(self.path, e)),
            }
        };
        if self.pos != self.len || more {
            let extra = self.len.saturating_sub(self.pos).max(1);
            return Err(self.error_at(self.pos, format!("{extra} unexpected trailing bytes")));
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

    /// A file is read through a small buffer: the same model as from its bytes, and the same
    /// errors at the same offsets when it is cut short or has bytes past its end.
    #[test]
    fn a_file_read_in_pieces_is_its_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.bin");
        let full = tiny_model();
        std::fs::write(&p, &full).unwrap();
        assert_eq!(read_eos_model(&p).unwrap(), parse_eos_model(&full, &p).unwrap());
        let mut extra = full.clone();
        extra.push(0);
        for bytes in [&full[..30], &full[..full.len() - 1], &extra[..]] {
            std::fs::write(&p, bytes).unwrap();
            let from_file = read_eos_model(&p).unwrap_err().to_string();
            assert_eq!(from_file, parse_eos_model(bytes, &p).unwrap_err().to_string());
        }
    }
}
