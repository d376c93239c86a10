//! Morphable models as NumPy arrays: a folder of `.npy` files or one `.npz` archive with
//! the arrays `mean`, `basis_orthonormal` (or `basis`), `eigenvalues`, `triangles` and
//! optionally `expression_blendshapes` and `expression_names` (uint8 UTF-8 text, one name
//! per line) — the names of eos's exported model folder.
//!
//! Shapes: `mean` 3N (or N×3, flattened row by row); basis 3N×K (or N×3×K) with orthonormal
//! columns; `eigenvalues` K (variances); `triangles` T×3 0-based integers (optional);
//! `expression_blendshapes` E×3N (a 3N×E array is accepted too). Any of f32, f64, i32,
//! i64, u32, u64; C or Fortran order. Expression names come from `expression_names`, else
//! from a `summary.json` beside a folder's arrays (`blendshape_names`), else `expression_<j>`.

use crate::io::error::{FormatError, Result};
use crate::math::{DMatrix, DVector};
use crate::model::{Expressions, MorphableModel, PcaModel};
use npyz::{NpyFile, Order, TypeChar, WriterBuilder};
use std::io::Read;
use std::path::Path;

/// An array read from a `.npy`: its shape and its values in C (row-major) order.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    pub shape: Vec<usize>,
    pub data: Vec<f64>,
}

impl NpyArray {
    /// A 2-D view as a matrix (a 1-D array is one column).
    fn to_matrix(&self) -> Option<DMatrix> {
        match self.shape.as_slice() {
            [n] => Some(DMatrix::from_column_slice(*n, 1, &self.data)),
            [r, c] => Some(DMatrix::from_row_slice(*r, *c, &self.data)),
            _ => None,
        }
    }
}

/// Reads one `.npy` file as f64 values in C order.
///
/// # Errors
/// Unreadable file, a bad header, or a non-numeric dtype.
pub fn read_npy(path: &Path) -> Result<NpyArray> {
    let bytes = super::input::read_input(path)?;
    parse_npy(&bytes, path)
}

/// Parses the bytes of one `.npy` file (as [`read_npy`]); `path` is used only in errors.
///
/// # Errors
/// A bad header, data shorter than the header says, or a non-numeric dtype.
pub fn parse_npy(bytes: &[u8], path: &Path) -> Result<NpyArray> {
    parse_npy_field(bytes, path, "array")
}

/// Parses `.npy` bytes after checking the sizes its header claims against the bytes there
/// are: npyz allocates the header text and the values by those claims before reading, so a
/// corrupt length would otherwise ask for gigabytes.
fn parse_npy_field(bytes: &[u8], path: &Path, field: &str) -> Result<NpyArray> {
    let bad = |m: String| FormatError::at_field(path, field, m);
    let not_npy = |e: std::io::Error| match field {
        "array" => FormatError::whole(path, format!("not a .npy file: {e}")),
        _ => FormatError::at_field(path, field, format!("not a .npy array: {e}")),
    };
    let prefix = match bytes.get(6) {
        Some(1) => 10,
        Some(2 | 3) => 12,
        _ => 0, // not an .npy (or unknown version): npyz reports it
    };
    if prefix > 0 && bytes.len() >= prefix {
        let header_len = if prefix == 10 {
            u64::from(u16::from_le_bytes([bytes[8], bytes[9]]))
        } else {
            u64::from(u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]))
        };
        let left = (bytes.len() - prefix) as u64;
        if header_len > left {
            return Err(bad(format!(
                "truncated: header of {header_len} bytes, only {left} bytes follow"
            )));
        }
        let header = &bytes[prefix..prefix + header_len as usize];
        let depth = bracket_depth(header);
        if depth > MAX_HEADER_NESTING {
            return Err(bad(format!("header nests brackets {depth} deep; not a numeric array")));
        }
        let npy = NpyFile::new(bytes).map_err(not_npy)?;
        let data_len = left - header_len;
        let item = match npy.dtype() {
            npyz::DType::Plain(ts) => ts.size_field(),
            _ => 0,
        };
        let needed = npy.shape().iter().try_fold(item, |acc, &d| acc.checked_mul(d));
        if needed.is_none_or(|n| n > data_len) {
            let shape: Vec<String> = npy.shape().iter().map(u64::to_string).collect();
            return Err(bad(format!(
                "truncated: shape ({}) of {item}-byte values needs more than the {data_len} data bytes",
                shape.join(", ")
            )));
        }
        return npy_to_array(npy, path, field);
    }
    let npy = NpyFile::new(bytes).map_err(not_npy)?;
    npy_to_array(npy, path, field)
}

/// Deepest bracket nesting a header may have. Numeric arrays need 2 (`{… (3, 4) …}`);
/// npyz's header parser backtracks exponentially in the depth, so deeper is refused.
const MAX_HEADER_NESTING: usize = 8;

/// Maximum nesting of `(`, `[` and `{` in header text, outside quoted strings.
fn bracket_depth(header: &[u8]) -> usize {
    let (mut depth, mut max, mut quote) = (0usize, 0usize, None);
    for &b in header {
        match (quote, b) {
            (Some(q), _) if b == q => quote = None,
            (Some(_), _) => {}
            (None, b'\'' | b'"') => quote = Some(b),
            (None, b'(' | b'[' | b'{') => {
                depth += 1;
                max = max.max(depth);
            }
            (None, b')' | b']' | b'}') => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    max
}

fn npy_to_array<R: Read>(npy: NpyFile<R>, path: &Path, field: &str) -> Result<NpyArray> {
    let shape: Vec<usize> = npy.shape().iter().map(|&s| s as usize).collect();
    let order = npy.order();
    let bad =
        |e: std::io::Error| FormatError::at_field(path, field, format!("cannot read data: {e}"));
    let (ty, size) = match npy.dtype() {
        npyz::DType::Plain(ts) => (ts.type_char(), ts.size_field()),
        other => {
            return Err(FormatError::at_field(
                path,
                field,
                format!("unsupported dtype {}", other.descr()),
            ));
        }
    };
    let data: Vec<f64> = match (ty, size) {
        (TypeChar::Float, 4) => {
            npy.into_vec::<f32>().map_err(bad)?.into_iter().map(f64::from).collect()
        }
        (TypeChar::Float, 8) => npy.into_vec::<f64>().map_err(bad)?,
        (TypeChar::Int, 4) => {
            npy.into_vec::<i32>().map_err(bad)?.into_iter().map(f64::from).collect()
        }
        (TypeChar::Int, 8) => {
            npy.into_vec::<i64>().map_err(bad)?.into_iter().map(|v| v as f64).collect()
        }
        (TypeChar::Uint, 1) => {
            npy.into_vec::<u8>().map_err(bad)?.into_iter().map(f64::from).collect()
        }
        (TypeChar::Uint, 4) => {
            npy.into_vec::<u32>().map_err(bad)?.into_iter().map(f64::from).collect()
        }
        (TypeChar::Uint, 8) => {
            npy.into_vec::<u64>().map_err(bad)?.into_iter().map(|v| v as f64).collect()
        }
        _ => {
            return Err(FormatError::at_field(
                path,
                field,
                format!("unsupported dtype {ty:?} of {size} bytes (need float or integer)"),
            ));
        }
    };
    let data =
        if order == Order::Fortran && shape.len() > 1 { fortran_to_c(&data, &shape) } else { data };
    Ok(NpyArray { shape, data })
}

/// Reorders Fortran-order (first index fastest) values into C order (last index fastest).
fn fortran_to_c(data: &[f64], shape: &[usize]) -> Vec<f64> {
    let n = data.len();
    let mut out = vec![0.0; n];
    let mut idx = vec![0usize; shape.len()];
    for (f, &v) in data.iter().enumerate() {
        // Decode f as Fortran multi-index, then encode as C index.
        let mut rem = f;
        for (k, &s) in shape.iter().enumerate() {
            idx[k] = rem % s.max(1);
            rem /= s.max(1);
        }
        let c = idx.iter().zip(shape).fold(0, |acc, (&i, &s)| acc * s + i);
        out[c] = v;
    }
    out
}

/// Reads a model from a folder of `.npy` files laid out as eos's exported `model/` folder.
///
/// # Errors
/// A missing required array, a size mismatch (naming the field), or an invalid model.
pub fn read_npy_folder(dir: &Path) -> Result<MorphableModel> {
    let get = |name: &str| -> Result<Option<NpyArray>> {
        let p = dir.join(format!("{name}.npy"));
        if p.exists() { read_npy(&p).map(Some) } else { Ok(None) }
    };
    let names = match get("expression_names")? {
        Some(a) => Some(names_from_bytes(&a, dir)?),
        None => read_summary_names(dir),
    };
    assemble(dir, get, names)
}

/// Reads a model from an `.npz` archive with the same array names as a folder.
///
/// # Errors
/// As [`read_npy_folder`], plus a corrupt archive.
pub fn read_npz(path: &Path) -> Result<MorphableModel> {
    let mut archive = npyz::npz::NpzArchive::open(path)
        .map_err(|e| FormatError::whole(path, format!("not an .npz archive: {e}")))?;
    let arrays: Vec<String> = archive.array_names().map(str::to_string).collect();
    let mut get = |name: &str| -> Result<Option<NpyArray>> {
        if !arrays.iter().any(|a| a == name) {
            return Ok(None);
        }
        // Read the member's bytes first so its header's sizes can be checked (see
        // `parse_npy_field`) before anything is allocated by them.
        let member = npyz::npz::file_name_from_array_name(name);
        let mut entry = archive
            .zip_archive()
            .by_name(&member)
            .map_err(|e| FormatError::at_field(path, name, e.to_string()))?;
        let mut bytes = Vec::new();
        entry
            .read_to_end(&mut bytes)
            .map_err(|e| FormatError::at_field(path, name, format!("cannot read data: {e}")))?;
        parse_npy_field(&bytes, path, name).map(Some)
    };
    let names = match get("expression_names")? {
        Some(a) => Some(names_from_bytes(&a, path)?),
        None => None,
    };
    assemble(path, &mut get, names)
}

/// Expression names stored as a 1-D `uint8` array of UTF-8 text, one name per line
/// (numpy: `bytes(a).decode().split("\n")`), since `.npy` has no portable string list.
fn names_from_bytes(a: &NpyArray, path: &Path) -> Result<Vec<String>> {
    let bad = || FormatError::at_field(path, "expression_names", "not UTF-8 bytes (uint8, 1-D)");
    let bytes: Vec<u8> = a
        .data
        .iter()
        .map(|&v| ((0.0..=255.0).contains(&v) && v.fract() == 0.0).then_some(v as u8))
        .collect::<Option<_>>()
        .filter(|_| a.shape.len() == 1)
        .ok_or_else(bad)?;
    let text = String::from_utf8(bytes).map_err(|_| bad())?;
    Ok(if text.is_empty() { Vec::new() } else { text.split('\n').map(str::to_string).collect() })
}

/// `blendshape_names` from a `summary.json` beside the arrays, when present and readable.
fn read_summary_names(dir: &Path) -> Option<Vec<String>> {
    let text = super::input::read_input_string(&dir.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v.get("blendshape_names")?.as_array()?.iter().map(|n| n.as_str().map(str::to_string)).collect()
}

fn assemble(
    path: &Path,
    mut get: impl FnMut(&str) -> Result<Option<NpyArray>>,
    names: Option<Vec<String>>,
) -> Result<MorphableModel> {
    let field_err = |f: &str, m: String| FormatError::at_field(path, f, m);
    let mean = get("mean")?.ok_or_else(|| field_err("mean", "required array is missing".into()))?;
    let mean = DVector::from_vec(mean.data);
    let len = mean.len();
    if !len.is_multiple_of(3) {
        return Err(field_err("mean", format!("{len} values, not a multiple of 3")));
    }
    let (basis_name, basis) = match get("basis_orthonormal")? {
        Some(b) => ("basis_orthonormal", b),
        None => (
            "basis",
            get("basis")?.ok_or_else(|| {
                field_err("basis_orthonormal", "required array (or `basis`) is missing".into())
            })?,
        ),
    };
    let basis = match basis.shape.as_slice() {
        [r, k] if *r == len => DMatrix::from_row_slice(*r, *k, &basis.data),
        [n, 3, k] if 3 * n == len => DMatrix::from_row_slice(len, *k, &basis.data),
        s => {
            return Err(field_err(
                basis_name,
                format!("shape {s:?} does not match the mean's {len} values (need {len}×K)"),
            ));
        }
    };
    let ev = get("eigenvalues")?
        .ok_or_else(|| field_err("eigenvalues", "required array is missing".into()))?;
    let eigenvalues = DVector::from_vec(ev.data);
    if eigenvalues.len() != basis.ncols() {
        return Err(field_err(
            "eigenvalues",
            format!("{} values for {} basis columns", eigenvalues.len(), basis.ncols()),
        ));
    }
    let triangles = match get("triangles")? {
        None => Vec::new(),
        Some(t) => {
            if t.shape.len() != 2 || t.shape[1] != 3 {
                return Err(field_err("triangles", format!("shape {:?}, need T×3", t.shape)));
            }
            let n = len / 3;
            let mut out = Vec::with_capacity(t.shape[0]);
            for (i, c) in t.data.chunks_exact(3).enumerate() {
                let mut tri = [0u32; 3];
                for (k, &v) in c.iter().enumerate() {
                    if v < 0.0 || v.fract() != 0.0 || v as usize >= n {
                        return Err(field_err(
                            "triangles",
                            format!("triangle {i} has vertex {v}, the mean has {n} vertices"),
                        ));
                    }
                    tri[k] = v as u32;
                }
                out.push(tri);
            }
            out
        }
    };
    let expressions = match get("expression_blendshapes")? {
        None => None,
        Some(e) => {
            let deltas = match e.shape.as_slice() {
                [_, c] if *c == len => e.to_matrix().map(|m| m.transpose()),
                [r, _] if *r == len => e.to_matrix(),
                _ => None,
            }
            .ok_or_else(|| {
                field_err(
                    "expression_blendshapes",
                    format!(
                        "shape {:?} does not match the mean's {len} values (need E×{len})",
                        e.shape
                    ),
                )
            })?;
            let k = deltas.ncols();
            let names = match names {
                Some(n) if n.len() == k => n,
                _ => (0..k).map(|j| format!("expression_{j}")).collect(),
            };
            Some(Expressions { names, deltas })
        }
    };
    let model =
        MorphableModel { shape: PcaModel { mean, basis, eigenvalues }, expressions, triangles };
    model.validate().map_err(|e| FormatError::whole(path, e.to_string()))?;
    Ok(model)
}

/// Writes a model as an `.npz` archive (f64 arrays, names as read by [`read_npz`]),
/// atomically.
///
/// # Errors
/// I/O errors, naming the file.
pub fn write_npz(path: &Path, model: &MorphableModel) -> Result<()> {
    let io = |e: std::io::Error| FormatError::io(path, e);
    let file = super::atomic::AtomicFile::create(path).map_err(io)?;
    let mut npz = npyz::npz::NpzWriter::new(file);
    let s = &model.shape;
    let len = s.mean.len() as u64;
    let k = s.basis.ncols() as u64;
    let mut put = |name: &str, shape: &[u64], data: Vec<f64>| -> std::io::Result<()> {
        let mut w =
            npz.array::<f64>(name, Default::default())?.default_dtype().shape(shape).begin_nd()?;
        w.extend(data)?;
        w.finish()
    };
    put("mean", &[len], s.mean.as_slice().to_vec()).map_err(io)?;
    // C order: row r of the basis, all K columns, then the next row.
    put("basis_orthonormal", &[len, k], s.basis.transpose().as_slice().to_vec()).map_err(io)?;
    put("eigenvalues", &[k], s.eigenvalues.as_slice().to_vec()).map_err(io)?;
    if let Some(e) = &model.expressions {
        // E×3N in C order is the 3N×E matrix in column-major order.
        put(
            "expression_blendshapes",
            &[e.deltas.ncols() as u64, len],
            e.deltas.as_slice().to_vec(),
        )
        .map_err(io)?;
        let text = e.names.join("\n").into_bytes();
        let mut w = npz
            .array::<u8>("expression_names", Default::default())
            .and_then(|b| b.default_dtype().shape(&[text.len() as u64]).begin_nd())
            .map_err(io)?;
        w.extend(text).map_err(io)?;
        w.finish().map_err(io)?;
    }
    let mut w = npz
        .array::<i32>("triangles", Default::default())
        .and_then(|b| b.default_dtype().shape(&[model.triangles.len() as u64, 3]).begin_nd())
        .map_err(io)?;
    w.extend(model.triangles.iter().flat_map(|t| t.map(|v| v as i32))).map_err(io)?;
    w.finish().map_err(io)?;
    let file = npz.zip_writer().finish().map_err(|e| io(std::io::Error::other(e)))?;
    file.commit().map_err(io)
}

/// Writes an f32 `.npy` file of the given shape from C-order values (e.g. `shapes.npy`,
/// frames × 3N).
///
/// # Errors
/// A shape that does not match `data.len()`, or I/O errors, naming the file.
pub fn write_npy_f32(path: &Path, shape: &[u64], data: &[f32]) -> Result<()> {
    if shape.iter().product::<u64>() != data.len() as u64 {
        return Err(FormatError::whole(
            path,
            format!("shape {shape:?} does not hold {} values", data.len()),
        ));
    }
    let mut w = NpyF32Writer::create(path, shape)?;
    w.write(data)?;
    w.finish()
}

/// An f32 `.npy` file written row by row (e.g. one mesh per frame), so a large array never
/// has to be held whole. Values go out as whole byte blocks: writing them one by one through
/// a generic element writer cost more than fitting the frames. The file appears under its name
/// only when [`NpyF32Writer::finish`] succeeds (written atomically).
pub struct NpyF32Writer {
    path: std::path::PathBuf,
    file: super::atomic::AtomicFile,
    expected: u64,
    written: u64,
    bytes: Vec<u8>,
}

impl NpyF32Writer {
    /// Creates the file and writes the header for a C-order array of `shape`.
    ///
    /// # Errors
    /// I/O errors, naming the file.
    pub fn create(path: &Path, shape: &[u64]) -> Result<Self> {
        let io = |e: std::io::Error| FormatError::io(path, e);
        let mut file = super::atomic::AtomicFile::create(path).map_err(io)?;
        std::io::Write::write_all(&mut file, &npy_header_f32(shape)).map_err(io)?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            expected: shape.iter().product(),
            written: 0,
            bytes: Vec::new(),
        })
    }

    /// Appends `values` (f32, or f64 rounded to f32 as `as` does).
    ///
    /// # Errors
    /// As [`NpyF32Writer::write_rows`].
    pub fn write<T: NpyF32Value>(&mut self, values: &[T]) -> Result<()> {
        self.write_rows(&[values])
    }

    /// Appends `rows` one after the other. Rows whose values are already the file's bytes
    /// (f32 on a little-endian machine: a block of meshes) go to the file in one vectored
    /// write from their own memory, with no copy into the write buffer.
    ///
    /// # Errors
    /// More values than the shape holds; a value that is not finite as f32 (NaN, ±inf, or
    /// beyond f32's range), naming its index: lipmap never writes one into an output (none
    /// of `rows` is written, and the file is not put in place); I/O errors, naming the file.
    pub fn write_rows<T: NpyF32Value>(&mut self, rows: &[&[T]]) -> Result<()> {
        let first = self.written;
        self.written += rows.iter().map(|r| r.len() as u64).sum::<u64>();
        if self.written > self.expected {
            return Err(FormatError::whole(
                &self.path,
                format!("more than the {} values its shape holds", self.expected),
            ));
        }
        let mut offset = first;
        for values in rows {
            // A count over every value, with no early return, which the compiler vectorises.
            let not_finite =
                values.iter().map(|&v| u32::from(!is_finite_bits(v.f32_bits()))).sum::<u32>();
            if not_finite > 0 {
                let k = values.iter().position(|&v| !is_finite_bits(v.f32_bits())).unwrap_or(0);
                return Err(FormatError::whole(
                    &self.path,
                    format!(
                        "value {} is {}, not a number lipmap writes (nothing written)",
                        offset + k as u64,
                        crate::math::short_number(values[k].into())
                    ),
                ));
            }
            offset += values.len() as u64;
        }
        let io = |e| FormatError::io(&self.path, e);
        let own: Option<Vec<std::io::IoSlice<'_>>> =
            rows.iter().map(|r| T::own_le_bytes(r).map(std::io::IoSlice::new)).collect();
        match own {
            Some(mut slices) => write_all_vectored(&mut self.file, &mut slices).map_err(io),
            None => rows.iter().try_for_each(|values| {
                let bytes = T::le_bytes(values, &mut self.bytes);
                std::io::Write::write_all(&mut self.file, bytes).map_err(io)
            }),
        }
    }

    /// Checks that every value the shape holds was written, then puts the file in place.
    ///
    /// # Errors
    /// Fewer values than the shape holds (nothing is written), or I/O errors, naming the file.
    pub fn finish(self) -> Result<()> {
        if self.written != self.expected {
            return Err(FormatError::whole(
                &self.path,
                format!("{} values written, its shape holds {}", self.written, self.expected),
            ));
        }
        let path = self.path;
        self.file.commit().map_err(|e| FormatError::io(&path, e))
    }
}

/// A value [`NpyF32Writer`] takes: f32 as it is, or f64 rounded to f32 as `as` does.
pub trait NpyF32Value: Copy + Into<f64> {
    /// The bits of the value as f32.
    fn f32_bits(self) -> u32;

    /// `values` as the file's little-endian f32 bytes when their own memory is those bytes.
    fn own_le_bytes(values: &[Self]) -> Option<&[u8]>;

    /// `values` as the file's little-endian f32 bytes, made in `buf` when they are not
    /// already.
    fn le_bytes<'a>(values: &'a [Self], buf: &'a mut Vec<u8>) -> &'a [u8];
}

impl NpyF32Value for f32 {
    fn f32_bits(self) -> u32 {
        self.to_bits()
    }

    fn own_le_bytes(values: &[f32]) -> Option<&[u8]> {
        // The values' own memory: a mesh goes to the file without a copy. (bytemuck, as
        // pulp, the fit's vector dispatch, re-exports it.)
        cfg!(target_endian = "little").then(|| pulp::bytemuck::cast_slice(values))
    }

    fn le_bytes<'a>(values: &'a [f32], buf: &'a mut Vec<u8>) -> &'a [u8] {
        match Self::own_le_bytes(values) {
            Some(bytes) => bytes,
            None => f32_le_bytes(values.iter().copied(), values.len(), buf),
        }
    }
}

impl NpyF32Value for f64 {
    fn f32_bits(self) -> u32 {
        (self as f32).to_bits()
    }

    fn own_le_bytes(_: &[f64]) -> Option<&[u8]> {
        None
    }

    fn le_bytes<'a>(values: &'a [f64], buf: &'a mut Vec<u8>) -> &'a [u8] {
        f32_le_bytes(values.iter().map(|&v| v as f32), values.len(), buf)
    }
}

/// Writes every byte of `slices` with vectored writes, as `write_all` does for one slice
/// (`Write::write_all_vectored` is not stable). A buffered writer hands a total at least
/// its buffer's size straight to the file.
fn write_all_vectored(
    out: &mut impl std::io::Write,
    mut slices: &mut [std::io::IoSlice<'_>],
) -> std::io::Result<()> {
    while !slices.is_empty() {
        match out.write_vectored(slices) {
            Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
            Ok(n) => std::io::IoSlice::advance_slices(&mut slices, n),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Whether f32 bits are a finite number (the exponent not all ones): an integer test, which
/// vectorises to fewer instructions than the float comparisons of `is_finite`.
fn is_finite_bits(bits: u32) -> bool {
    bits & 0x7f80_0000 != 0x7f80_0000
}

/// The little-endian bytes of `n` f32 values, in `buf`.
fn f32_le_bytes(values: impl Iterator<Item = f32>, n: usize, buf: &mut Vec<u8>) -> &[u8] {
    buf.resize(4 * n, 0);
    for (out, v) in buf.chunks_exact_mut(4).zip(values) {
        out.copy_from_slice(&v.to_le_bytes());
    }
    buf
}

/// A version 1.0 `.npy` header for a C-order little-endian f32 array of `shape`, padded with
/// spaces and a newline so the data starts at a multiple of 64 bytes (the format's rule; the
/// same bytes npyz writes).
fn npy_header_f32(shape: &[u64]) -> Vec<u8> {
    let dims: String = shape.iter().map(|d| format!("{d}, ")).collect();
    let mut text = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({dims}), }}");
    // magic (6) + version (2) + header length (2) come before the text.
    let before = 10;
    let pad = 63 - (text.len() + before) % 64;
    text.extend(std::iter::repeat_n(' ', pad));
    text.push('\n');
    let mut out = Vec::with_capacity(before + text.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(text.len() as u16).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_reorder_matches_c() {
        // 2×3 matrix [[1,2,3],[4,5,6]] in Fortran order is 1 4 2 5 3 6.
        let c = fortran_to_c(&[1.0, 4.0, 2.0, 5.0, 3.0, 6.0], &[2, 3]);
        assert_eq!(c, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn npz_round_trip_and_size_errors() {
        let dir = tempfile::tempdir().unwrap();
        let mut basis = DMatrix::zeros(6, 2);
        basis[(0, 0)] = 1.0;
        basis[(5, 1)] = 1.0;
        let model = MorphableModel {
            shape: PcaModel {
                mean: DVector::from_vec(vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0]),
                basis,
                eigenvalues: DVector::from_vec(vec![3.0, 1.0]),
            },
            expressions: Some(Expressions {
                names: vec!["jaw open".into()],
                deltas: DMatrix::from_column_slice(6, 1, &[0.0, 1.0, 0.0, 0.0, -1.0, 0.0]),
            }),
            triangles: vec![[0, 1, 1]],
        };
        let p = dir.path().join("m.npz");
        write_npz(&p, &model).unwrap();
        assert_eq!(read_npz(&p).unwrap(), model);

        // A folder whose basis has the wrong number of rows names the field.
        let f = dir.path().join("folder");
        std::fs::create_dir(&f).unwrap();
        write_npy_f32(&f.join("mean.npy"), &[6], &[0.0; 6]).unwrap();
        write_npy_f32(&f.join("basis.npy"), &[9, 1], &[0.0; 9]).unwrap();
        write_npy_f32(&f.join("eigenvalues.npy"), &[1], &[1.0]).unwrap();
        let e = read_npy_folder(&f).unwrap_err();
        assert!(e.to_string().contains("field `basis`"), "{e}");
        assert!(write_npy_f32(&f.join("x.npy"), &[2, 2], &[0.0; 3]).is_err());
    }

    #[test]
    fn f32_npy_bytes_match_npyz() {
        let dir = tempfile::tempdir().unwrap();
        for shape in [vec![3u64], vec![2, 3], vec![1000, 10344]] {
            let n = shape.iter().product::<u64>() as usize;
            let data: Vec<f32> = (0..n).map(|i| (i as f32 * 0.37).sin()).collect();
            let p = dir.path().join("a.npy");
            write_npy_f32(&p, &shape, &data).unwrap();
            let mut want = Vec::new();
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(&shape)
                .writer(&mut want)
                .begin_nd()
                .unwrap();
            w.extend(data.iter().copied()).unwrap();
            w.finish().unwrap();
            assert!(std::fs::read(&p).unwrap() == want, "shape {shape:?}");
        }
    }

    #[test]
    fn rows_written_together_are_the_bytes_of_rows_written_one_by_one() {
        let dir = tempfile::tempdir().unwrap();
        // Rows past the write buffer's size in all (a block of meshes goes out vectored),
        // and f64 rows, which are converted.
        let rows: Vec<Vec<f32>> =
            (0..40).map(|r| (0..10_000).map(|i| ((r * 7 + i) as f32).cos()).collect()).collect();
        let slices: Vec<&[f32]> = rows.iter().map(Vec::as_slice).collect();
        let wide: Vec<Vec<f64>> =
            rows.iter().map(|r| r.iter().map(|&v| f64::from(v)).collect()).collect();
        let wide: Vec<&[f64]> = wide.iter().map(Vec::as_slice).collect();
        let shape = [40u64, 10_000];
        let one = dir.path().join("one.npy");
        let mut w = NpyF32Writer::create(&one, &shape).unwrap();
        slices.iter().for_each(|r| w.write(r).unwrap());
        w.finish().unwrap();
        let p = dir.path().join("f32.npy");
        let mut w = NpyF32Writer::create(&p, &shape).unwrap();
        slices.chunks(16).for_each(|b| w.write_rows(b).unwrap());
        w.finish().unwrap();
        assert!(std::fs::read(&p).unwrap() == std::fs::read(&one).unwrap());
        let p = dir.path().join("f64.npy");
        let mut w = NpyF32Writer::create(&p, &shape).unwrap();
        wide.chunks(16).for_each(|b| w.write_rows(b).unwrap());
        w.finish().unwrap();
        assert!(std::fs::read(&p).unwrap() == std::fs::read(&one).unwrap());
        // A value that is not finite in a later row is named by its index in the file, and
        // no row of the call is written.
        let p = dir.path().join("bad.npy");
        let mut w = NpyF32Writer::create(&p, &[3, 2]).unwrap();
        let e = w.write_rows(&[&[1.0f32, 2.0][..], &[3.0, f32::INFINITY]]).unwrap_err();
        assert!(e.to_string().contains("value 3 is"), "{e}");
    }

    #[test]
    fn a_value_not_finite_as_f32_is_named_and_nothing_is_put_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        let mut w = NpyF32Writer::create(&p, &[2, 3]).unwrap();
        w.write(&[1.0f32, 2.0, 3.0]).unwrap();
        let e = w.write(&[4.0f32, f32::NAN, 6.0]).unwrap_err().to_string();
        assert!(e.contains("value 4 is NaN"), "{e}");
        drop(w);
        assert!(!p.exists());
        // f64 beyond f32's range is infinite once written.
        let mut w = NpyF32Writer::create(&p, &[2]).unwrap();
        let e = w.write(&[1.0, 1e39]).unwrap_err().to_string();
        assert!(e.contains("value 1 is"), "{e}");
        let mut w = NpyF32Writer::create(&p, &[2]).unwrap();
        w.write(&[1.5f64, -0.25]).unwrap();
        w.finish().unwrap();
        assert_eq!(read_npy(&p).unwrap().data, vec![1.5, -0.25]);
    }
}
