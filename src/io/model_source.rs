//! One entry point for every model source `--model` accepts: [`load_model`] picks the
//! reader from the path (eos `.bin`, `.npz`, a `.npy` folder, a lipmap model file, a
//! folder of pose OBJs built by PCA, or one OBJ) and adds blendshapes from `--blendshapes`.
//!
//! Blendshape sources: an eos blendshape `.bin`, an E×3N `.npy`, one `.target`/`.obj`, or a
//! folder of `.target`, `.target.gz` and `.obj` files (taken in file-name order). OBJ
//! blendshapes are full target shapes (delta = OBJ − model mean); targets are deltas.

use crate::io::error::{FormatError, Result};
use crate::io::{eos_bin, makehuman_target, model_file, npy_model, obj};
use crate::math::{DMatrix, DVector};
use crate::model::blendshapes::Blendshape;
use crate::model::pca::{Keep, PcaSummary, build_pca_with_summary};
use crate::model::{Expressions, MorphableModel, PcaModel};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The kinds of model source [`load_model`] recognises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelSourceKind {
    /// eos cereal `.bin` model.
    EosBin,
    /// NumPy `.npz` archive.
    Npz,
    /// Folder of `.npy` arrays (has `mean.npy`).
    NpyFolder,
    /// lipmap's own model file (recognised by its magic).
    LipmapFile,
    /// Folder of pose OBJs with one topology, turned into a model by PCA.
    PoseFolder,
    /// A single OBJ: a mean-only model (a base for blendshapes).
    Obj,
}

/// Decides what kind of model source `path` is, from its contents and name.
///
/// # Errors
/// A missing path, or one that matches no known kind.
pub fn detect_model_source(path: &Path) -> Result<ModelSourceKind> {
    if path.is_dir() {
        if path.join("mean.npy").is_file() {
            return Ok(ModelSourceKind::NpyFolder);
        }
        if !list_files(path, |p| has_ext(p, "obj"))?.is_empty() {
            return Ok(ModelSourceKind::PoseFolder);
        }
        return Err(FormatError::whole(path, "folder has neither mean.npy nor any .obj file"));
    }
    if !path.exists() {
        return Err(FormatError::whole(path, "no such file or folder"));
    }
    if model_file::is_model_file(path) {
        return Ok(ModelSourceKind::LipmapFile);
    }
    if has_ext(path, "npz") {
        Ok(ModelSourceKind::Npz)
    } else if has_ext(path, "bin") {
        Ok(ModelSourceKind::EosBin)
    } else if has_ext(path, "obj") {
        Ok(ModelSourceKind::Obj)
    } else {
        Err(FormatError::whole(
            path,
            "unknown model format (expected eos .bin, .npz, a .npy folder, a lipmap model file, \
             a folder of pose OBJs or an OBJ)",
        ))
    }
}

/// Loads a morphable model from any supported source, PCA folders at the default 98 %
/// variance, then adds blendshapes when `blendshapes` is given (they **replace** any
/// expression part the model file carries, so passing the same blendshapes twice cannot
/// double them).
///
/// # Errors
/// Any read or format error, naming the file and line, field or byte offset.
pub fn load_model(path: &Path, blendshapes: Option<&Path>) -> Result<MorphableModel> {
    load_model_with(path, blendshapes, Keep::default())
}

/// [`load_model`] with an explicit PCA setting for pose folders.
///
/// # Errors
/// As [`load_model`].
pub fn load_model_with(
    path: &Path,
    blendshapes: Option<&Path>,
    keep: Keep,
) -> Result<MorphableModel> {
    let model = match detect_model_source(path)? {
        ModelSourceKind::EosBin => eos_bin::read_eos_model(path)?,
        ModelSourceKind::Npz => npy_model::read_npz(path)?,
        ModelSourceKind::NpyFolder => npy_model::read_npy_folder(path)?,
        ModelSourceKind::LipmapFile => model_file::read_model_file(path)?,
        ModelSourceKind::PoseFolder => build_model_from_obj_folder(path, keep)?.0,
        ModelSourceKind::Obj => {
            let mesh = obj::read_obj(path)?;
            MorphableModel::new(PcaModel::mean_only(mesh.to_flat()), None, mesh.triangles())
                .map_err(|e| FormatError::whole(path, e.to_string()))?
        }
    };
    match blendshapes {
        None => Ok(model),
        Some(b) => with_blendshapes(model, b),
    }
}

/// Replaces a model's expressions with blendshapes read from `path` (see the module doc).
///
/// # Errors
/// Read errors, or blendshapes whose size does not match the model (naming the file).
pub fn with_blendshapes(mut model: MorphableModel, path: &Path) -> Result<MorphableModel> {
    let n = model.num_vertices();
    let expressions = read_blendshapes_for(path, &model.shape.mean)?;
    if expressions.deltas.nrows() != 3 * n {
        return Err(FormatError::whole(
            path,
            format!(
                "blendshapes have {} vertices but the model has {n}",
                expressions.deltas.nrows() / 3
            ),
        ));
    }
    model.expressions = (expressions.deltas.ncols() > 0).then_some(expressions);
    model.validate().map_err(|e| FormatError::whole(path, e.to_string()))?;
    Ok(model)
}

/// Reads blendshapes for a model whose mean shape is `mean` (3N): OBJ targets become
/// `OBJ − mean`, sparse targets are densified to N vertices.
///
/// # Errors
/// Unreadable files, an empty folder, or a file of another vertex count (naming it).
pub fn read_blendshapes_for(path: &Path, mean: &DVector) -> Result<Expressions> {
    let n = mean.len() / 3;
    if path.is_dir() {
        let files = list_files(path, |p| makehuman_target::is_target_file(p) || has_ext(p, "obj"))?;
        if files.is_empty() {
            return Err(FormatError::whole(path, "no .target, .target.gz or .obj files in folder"));
        }
        let shapes: Vec<Blendshape> =
            files.par_iter().map(|f| read_one_blendshape(f, mean)).collect::<Result<_>>()?;
        return stack(path, n, shapes);
    }
    if has_ext(path, "bin") {
        return eos_bin::read_eos_blendshapes(path);
    }
    if has_ext(path, "npy") {
        let a = npy_model::read_npy(path)?;
        return match a.shape.as_slice() {
            [e, c] if *c == 3 * n => Ok(Expressions {
                names: (0..*e).map(|j| format!("expression_{j}")).collect(),
                deltas: DMatrix::from_row_slice(*e, *c, &a.data).transpose(),
            }),
            s => Err(FormatError::whole(path, format!("shape {s:?}, need E×{}", 3 * n))),
        };
    }
    if makehuman_target::is_target_file(path) || has_ext(path, "obj") {
        let b = read_one_blendshape(path, mean)?;
        return stack(path, n, vec![b]);
    }
    Err(FormatError::whole(
        path,
        "unknown blendshape format (expected eos .bin, .npy, .target, .obj or a folder)",
    ))
}

fn read_one_blendshape(file: &Path, mean: &DVector) -> Result<Blendshape> {
    let n = mean.len() / 3;
    if makehuman_target::is_target_file(file) {
        return makehuman_target::read_target_blendshape(file, n);
    }
    let mesh = obj::read_obj(file)?;
    if mesh.num_vertices() != n {
        return Err(FormatError::whole(
            file,
            format!("has {} vertices, the model has {n}", mesh.num_vertices()),
        ));
    }
    let name = file.file_stem().and_then(|s| s.to_str()).unwrap_or("blendshape").to_string();
    Ok(Blendshape { name, delta: mesh.to_flat() - mean })
}

fn stack(path: &Path, n: usize, shapes: Vec<Blendshape>) -> Result<Expressions> {
    crate::model::blendshapes::expressions_from_blendshapes(3 * n, &shapes)
        .map_err(|e| FormatError::whole(path, e.to_string()))
}

/// Builds a model by PCA over every `.obj` in `dir` (file-name order), all with the same
/// vertex count; triangles come from the first file. Returns the PCA summary too, for
/// reporting the variance explained.
///
/// # Errors
/// No OBJ files, an unreadable OBJ, a file whose vertex count differs from the first
/// (naming both), or a PCA failure (fewer than 2 poses, no variance).
pub fn build_model_from_obj_folder(dir: &Path, keep: Keep) -> Result<(MorphableModel, PcaSummary)> {
    let files = list_files(dir, |p| has_ext(p, "obj"))?;
    if files.is_empty() {
        return Err(FormatError::whole(dir, "no .obj files in folder"));
    }
    let meshes: Vec<crate::model::Mesh> =
        files.par_iter().map(|f| obj::read_obj(f)).collect::<Result<_>>()?;
    let n = meshes[0].num_vertices();
    for (f, m) in files.iter().zip(&meshes) {
        if m.num_vertices() != n {
            return Err(FormatError::whole(
                f,
                format!(
                    "has {} vertices but {} has {n}: pose OBJs must share one topology",
                    m.num_vertices(),
                    files[0].display()
                ),
            ));
        }
    }
    let shapes: Vec<DVector> = meshes.iter().map(|m| m.to_flat()).collect();
    let summary = build_pca_with_summary(&shapes, keep)
        .map_err(|e| FormatError::whole(dir, e.to_string()))?;
    let model = MorphableModel::new(summary.model.clone(), None, meshes[0].triangles())
        .map_err(|e| FormatError::whole(&files[0], e.to_string()))?;
    Ok((model, summary))
}

fn has_ext(p: &Path, ext: &str) -> bool {
    p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// Files (not folders) directly in `dir` matching `keep`, sorted by file name.
fn list_files(dir: &Path, keep: impl Fn(&Path) -> bool) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|e| FormatError::io(dir, e))?;
    let mut files = Vec::new();
    for entry in rd {
        let p = entry.map_err(|e| FormatError::io(dir, e))?.path();
        if p.is_file() && keep(&p) {
            files.push(p);
        }
    }
    files.sort();
    Ok(files)
}
