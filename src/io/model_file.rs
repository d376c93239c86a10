//! lipmap's own model file: a compact little-endian binary holding a whole
//! [`MorphableModel`] (shape PCA, expressions with names, triangles), specified in
//! `docs/model-format.md`. Write with [`write_model_file`], read with [`read_model_file`].
//!
//! The header gives every size up front, so a reader knows the exact file length before it
//! touches the payload: truncation is reported with the byte offset where data ran out.

use crate::io::error::{FormatError, Location, Result};
use crate::math::{DMatrix, DVector};
use crate::model::{Expressions, MorphableModel, PcaModel};
use std::path::Path;

/// The 8 bytes every lipmap model file starts with.
pub const MAGIC: &[u8; 8] = b"LIPMAPMM";
/// The format version this code writes and reads.
pub const VERSION: u32 = 1;
/// Bytes before the payload: magic, version, flags and four u64 sizes.
pub const HEADER_LEN: usize = 48;
const FLAG_F64: u32 = 1;

/// Width of the stored floating-point payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Precision {
    /// 4-byte floats: half the size; ~7 significant digits (ample for mm-scale shapes).
    #[default]
    F32,
    /// 8-byte floats: lossless for lipmap's f64 values.
    F64,
}

/// Whether the file starts with the lipmap model magic (false when unreadable).
pub fn is_model_file(path: &Path) -> bool {
    use std::io::Read;
    let mut buf = [0u8; 8];
    super::input::open_input(path, super::input::MAX_INPUT_BYTES)
        .is_ok_and(|mut f| f.read_exact(&mut buf).is_ok())
        && &buf == MAGIC
}

/// Serialises a model into bytes (see `docs/model-format.md`).
///
/// ```
/// use lipmap::io::model_file::{encode_model, decode_model, Precision};
/// use lipmap::model::{MorphableModel, PcaModel};
/// let m = MorphableModel {
///     shape: PcaModel::mean_only(nalgebra::DVector::from_vec(vec![1.0, 2.0, 3.0])),
///     expressions: None,
///     triangles: vec![],
/// };
/// let bytes = encode_model(&m, Precision::F64);
/// assert_eq!(decode_model(&bytes, std::path::Path::new("m.lmm")).unwrap(), m);
/// ```
pub fn encode_model(model: &MorphableModel, precision: Precision) -> Vec<u8> {
    let s = &model.shape;
    let e = model.expressions.as_ref();
    let (k, ne) = (s.basis.ncols(), model.num_expressions());
    let width = if precision == Precision::F64 { 8 } else { 4 };
    let floats = s.mean.len() * (1 + k + ne) + k;
    let mut b = Vec::with_capacity(HEADER_LEN + floats * width + model.triangles.len() * 12);
    b.extend_from_slice(MAGIC);
    b.extend(VERSION.to_le_bytes());
    b.extend((if precision == Precision::F64 { FLAG_F64 } else { 0 }).to_le_bytes());
    for n in [model.num_vertices(), k, ne, model.triangles.len()] {
        b.extend((n as u64).to_le_bytes());
    }
    let put = |b: &mut Vec<u8>, values: &[f64]| {
        for &v in values {
            match precision {
                Precision::F32 => b.extend((v as f32).to_le_bytes()),
                Precision::F64 => b.extend(v.to_le_bytes()),
            }
        }
    };
    put(&mut b, s.mean.as_slice());
    put(&mut b, s.basis.as_slice());
    put(&mut b, s.eigenvalues.as_slice());
    if let Some(e) = e {
        put(&mut b, e.deltas.as_slice());
    }
    for t in &model.triangles {
        for v in t {
            b.extend(v.to_le_bytes());
        }
    }
    for name in model.expression_names() {
        b.extend((name.len() as u32).to_le_bytes());
        b.extend_from_slice(name.as_bytes());
    }
    b
}

/// Writes a model file.
///
/// # Errors
/// A model failing [`MorphableModel::validate`] (nothing is written), or I/O errors.
pub fn write_model_file(path: &Path, model: &MorphableModel, precision: Precision) -> Result<()> {
    model.validate().map_err(|e| FormatError::whole(path, format!("not saved: {e}")))?;
    let bytes = encode_model(model, precision);
    super::atomic::write_atomic_bytes(path, &bytes).map_err(|e| FormatError::io(path, e))
}

/// Reads a model file.
///
/// # Errors
/// Unreadable file, wrong magic or version, truncation (with the byte offset), trailing
/// bytes, or a model failing [`MorphableModel::validate`].
pub fn read_model_file(path: &Path) -> Result<MorphableModel> {
    let bytes = super::input::read_input(path)?;
    decode_model(&bytes, path)
}

/// Decodes model-file bytes; `path` is used only in error messages.
///
/// # Errors
/// As [`read_model_file`].
pub fn decode_model(bytes: &[u8], path: &Path) -> Result<MorphableModel> {
    let at = |o: usize, m: String| FormatError::new(path, Location::Offset(o as u64), m);
    if bytes.len() < HEADER_LEN {
        return Err(at(
            bytes.len(),
            format!("truncated header: {} of {HEADER_LEN} bytes", bytes.len()),
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err(at(0, "not a lipmap model file (bad magic)".into()));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version != VERSION {
        return Err(at(8, format!("unsupported version {version} (this lipmap reads {VERSION})")));
    }
    let flags = u32_at(12);
    if flags & !FLAG_F64 != 0 {
        return Err(at(12, format!("unknown flags {flags:#x}")));
    }
    let width: u64 = if flags & FLAG_F64 != 0 { 8 } else { 4 };
    let (n, k, ne, nt) = (u64_at(16), u64_at(24), u64_at(32), u64_at(40));
    let too_big = || at(16, format!("sizes N={n} K={k} E={ne} T={nt} overflow"));
    let len = n.checked_mul(3).ok_or_else(too_big)?;
    let floats = len
        .checked_mul(k.checked_add(ne).and_then(|v| v.checked_add(1)).ok_or_else(too_big)?)
        .and_then(|v| v.checked_add(k))
        .ok_or_else(too_big)?;
    let fixed = floats
        .checked_mul(width)
        .and_then(|v| v.checked_add(nt.checked_mul(12)?))
        // Each expression name has at least its 4-byte length: bounds E even when N = 0.
        .and_then(|v| v.checked_add(ne.checked_mul(4)?))
        .and_then(|v| v.checked_add(HEADER_LEN as u64))
        .ok_or_else(too_big)?;
    if fixed > bytes.len() as u64 {
        return Err(at(
            bytes.len(),
            format!(
                "truncated: the header promises at least {fixed} bytes, the file has {}",
                bytes.len()
            ),
        ));
    }
    let (len, k, ne, nt) = (len as usize, k as usize, ne as usize, nt as usize);
    let mut pos = HEADER_LEN;
    let mut take = |count: usize| -> Vec<f64> {
        let w = width as usize;
        let v = bytes[pos..pos + count * w]
            .chunks_exact(w)
            .map(|c| match w {
                4 => f32::from_le_bytes(c.try_into().expect("4 bytes")) as f64,
                _ => f64::from_le_bytes(c.try_into().expect("8 bytes")),
            })
            .collect();
        pos += count * w;
        v
    };
    let mean = DVector::from_vec(take(len));
    let basis = DMatrix::from_vec(len, k, take(len * k));
    let eigenvalues = DVector::from_vec(take(k));
    let deltas = DMatrix::from_vec(len, ne, take(len * ne));
    let mut triangles = Vec::with_capacity(nt);
    for c in bytes[pos..pos + nt * 12].chunks_exact(12) {
        let v = |i: usize| u32::from_le_bytes(c[4 * i..4 * i + 4].try_into().expect("4 bytes"));
        triangles.push([v(0), v(1), v(2)]);
    }
    pos += nt * 12;
    let mut names = Vec::with_capacity(ne);
    for j in 0..ne {
        if pos + 4 > bytes.len() {
            return Err(at(pos, format!("truncated: name of expression {j} missing")));
        }
        let l = u32::from_le_bytes(bytes[pos..pos + 4].try_into().expect("4 bytes")) as usize;
        if pos + 4 + l > bytes.len() {
            return Err(at(pos + 4, format!("truncated: name of expression {j} needs {l} bytes")));
        }
        let name = std::str::from_utf8(&bytes[pos + 4..pos + 4 + l])
            .map_err(|_| at(pos + 4, format!("name of expression {j} is not UTF-8")))?;
        names.push(name.to_string());
        pos += 4 + l;
    }
    if pos != bytes.len() {
        return Err(at(pos, format!("{} unexpected trailing bytes", bytes.len() - pos)));
    }
    let expressions = (ne > 0).then_some(Expressions { names, deltas });
    let model =
        MorphableModel { shape: PcaModel { mean, basis, eigenvalues }, expressions, triangles };
    model.validate().map_err(|e| FormatError::whole(path, e.to_string()))?;
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> MorphableModel {
        let mut basis = DMatrix::zeros(9, 2);
        basis[(0, 0)] = 0.6;
        basis[(1, 0)] = 0.8;
        basis[(8, 1)] = 1.0;
        MorphableModel {
            shape: PcaModel {
                mean: DVector::from_fn(9, |i, _| i as f64 * 0.1 + 1.0 / 3.0),
                basis,
                eigenvalues: DVector::from_vec(vec![5.0, 0.25]),
            },
            expressions: Some(Expressions {
                names: vec!["jawOpen".into(), "mouthPücker".into()],
                deltas: DMatrix::from_fn(9, 2, |r, c| (r * 2 + c) as f64 - 4.5),
            }),
            triangles: vec![[0, 1, 2], [2, 1, 0]],
        }
    }

    #[test]
    fn round_trips_in_both_precisions() {
        let m = model();
        let p = Path::new("m.lmm");
        assert_eq!(decode_model(&encode_model(&m, Precision::F64), p).unwrap(), m);
        let back = decode_model(&encode_model(&m, Precision::F32), p).unwrap();
        assert!((&back.shape.mean - &m.shape.mean).abs().max() < 1e-6);
        assert_eq!(back.expression_names(), m.expression_names());
        assert_eq!(back.triangles, m.triangles);
    }

    #[test]
    fn every_truncation_is_an_offset_error() {
        let bytes = encode_model(&model(), Precision::F32);
        for cut in 0..bytes.len() {
            let e = decode_model(&bytes[..cut], Path::new("m.lmm")).unwrap_err();
            assert!(matches!(e.location, Location::Offset(o) if o as usize <= cut), "{cut}: {e}");
        }
        let mut bad = bytes.clone();
        bad[0] = b'X';
        assert!(decode_model(&bad, Path::new("m.lmm")).unwrap_err().message.contains("magic"));
        let mut bad = bytes.clone();
        bad[8] = 9;
        assert!(decode_model(&bad, Path::new("m.lmm")).unwrap_err().message.contains("version"));
        // A triangle index past the last vertex is caught by validation.
        let mut bad = bytes.clone();
        let tri_at = bytes.len() - (4 + 7) - (4 + 12) - 24;
        bad[tri_at] = 200;
        assert!(decode_model(&bad, Path::new("m.lmm")).is_err());
    }
}
