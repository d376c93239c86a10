//! `lipmap model build|info`: build a 3DMM by PCA over a folder of pose OBJs (optionally with
//! blendshapes) and write lipmap's model file; print a model's size and variance explained.

use super::output::plural;
use crate::io::model_file::{self, Precision};
use crate::io::model_source;
use crate::measure::lip_reach::InnerLipGap;
use crate::model::pca::{Keep, variance_explained};
use anyhow::{Result, bail};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug)]
pub enum ModelCommand {
    /// Build a model by PCA over a folder of pose OBJs with identical topology.
    Build(BuildArgs),
    /// Print a model's size and the variance its components explain.
    Info(InfoArgs),
}

#[derive(clap::Args, Debug)]
pub struct BuildArgs {
    /// Folder of pose OBJs (same vertex count and order in every file).
    pub poses: PathBuf,
    /// Output model file (lipmap's format; see docs/model-format.md).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Keep the fewest components explaining this fraction of the variance.
    #[arg(long, default_value_t = 0.98, conflicts_with = "components")]
    pub variance: f64,
    /// Keep exactly this many components instead.
    #[arg(long)]
    pub components: Option<usize>,
    /// Expression blendshapes to add (eos .bin, folder of .target or OBJ files).
    #[arg(long)]
    pub blendshapes: Option<PathBuf>,
    /// Store 8-byte floats (default 4-byte).
    #[arg(long)]
    pub f64: bool,
}

#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// A model: eos .bin, .npz, folder of .npy parts, lipmap model file, or folder of pose OBJs.
    pub model: PathBuf,
    /// Expression blendshapes to load with it.
    #[arg(long)]
    pub blendshapes: Option<PathBuf>,
    /// A landmark map (eos TOML such as ibug_to_sfm.txt, or its JSON): also say how far the
    /// model can close its lips (the smallest inner-lip gap 62–66 its expressions reach from
    /// the mean identity).
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(cmd: &ModelCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        ModelCommand::Build(a) => build(a, out),
        ModelCommand::Info(a) => info(a, out),
    }
}

fn build(a: &BuildArgs, out: &mut dyn Write) -> Result<()> {
    if !(a.variance > 0.0 && a.variance <= 1.0) {
        bail!("--variance must be in (0, 1], got {}", a.variance);
    }
    let keep = a.components.map_or(Keep::VarianceFraction(a.variance), Keep::Components);
    let (mut model, summary) = model_source::build_model_from_obj_folder(&a.poses, keep)?;
    if let Some(b) = &a.blendshapes {
        model = model_source::with_blendshapes(model, b)?;
    }
    let precision = if a.f64 { Precision::F64 } else { Precision::F32 };
    model_file::write_model_file(&a.out, &model, precision)?;
    // Counts what was read: pose files, and apart from that the directions they vary in
    // (identical or linearly dependent poses add files but no direction).
    writeln!(
        out,
        "{}: {} read ({} vertices each), varying in {}; kept {} ({:.1} % of the variance), {}",
        a.out.display(),
        plural(summary.shapes, "pose file"),
        model.num_vertices(),
        plural(summary.all_eigenvalues.len(), "direction"),
        plural(model.num_shape_components(), "component"),
        100.0 * summary.variance_explained(),
        plural(model.num_expressions(), "expression")
    )?;
    Ok(())
}

fn info(a: &InfoArgs, out: &mut dyn Write) -> Result<()> {
    let model = model_source::load_model(&a.model, a.blendshapes.as_deref())?;
    let e = &model.shape.eigenvalues;
    let cumulative: Vec<f64> = (1..=e.len()).map(|k| variance_explained(e, k)).collect();
    let reach = match &a.mapping {
        Some(path) => {
            let map = crate::io::landmark_map_toml::read_landmark_map(path)?;
            let reach = lip_reach(&model, &map);
            if reach.is_none() {
                bail!(
                    "{}: the map does not place inner-lip points 63 and 67 (1-based) on the model",
                    path.display()
                );
            }
            reach
        }
        None => None,
    };
    if a.json {
        let v = serde_json::json!({
            "vertices": model.num_vertices(),
            "triangles": model.triangles.len(),
            "shape_components": model.num_shape_components(),
            "expressions": model.expression_names(),
            "eigenvalues": e.as_slice(),
            "cumulative_variance_of_kept": cumulative,
            "inner_lip_gap_mean_identity": reach.as_ref().map(|r| r.neutral),
            "smallest_inner_lip_gap": reach.as_ref().map(|r| r.smallest),
            "smallest_inner_lip_gap_plausible_identity": reach.as_ref().map(|r| r.plausible),
        });
        serde_json::to_writer_pretty(&mut *out, &v)?;
        writeln!(out)?;
        return Ok(());
    }
    writeln!(out, "model        {}", a.model.display())?;
    writeln!(out, "vertices     {}", model.num_vertices())?;
    writeln!(out, "triangles    {}", model.triangles.len())?;
    writeln!(out, "components   {}", model.num_shape_components())?;
    writeln!(
        out,
        "expressions  {} {}",
        model.num_expressions(),
        model.expression_names().join(" ")
    )?;
    if let Some(r) = &reach {
        writeln!(
            out,
            "inner lips   gap {:.3} model units at rest (mean identity), smallest reachable {:.3} \
             (expressions β ≥ 0; frontal), {:.3} with any identity within 99 % of its prior",
            r.neutral, r.smallest, r.plausible,
        )?;
    }
    if !cumulative.is_empty() {
        writeln!(out, "variance explained (share of the kept components' total):")?;
        for k in [1usize, 2, 3, 5, 10, 20, 50] {
            if k <= cumulative.len() {
                writeln!(out, "  first {k:>3}  {:6.2} %", 100.0 * cumulative[k - 1])?;
            }
        }
    }
    Ok(())
}

/// The frontal inner-lip gap of the mean identity with no expression, the smallest its
/// expressions reach, and the smallest any plausible identity reaches with them (what a frame
/// fitted alone can do), in model units.
struct LipReach {
    neutral: f64,
    smallest: f64,
    plausible: f64,
}

fn lip_reach(
    model: &crate::model::MorphableModel,
    map: &crate::model::LandmarkMap,
) -> Option<LipReach> {
    let gap = InnerLipGap::of(model, map)?;
    Some(LipReach {
        neutral: gap.length(&[], &[]),
        smallest: gap.smallest(&[])?.0,
        plausible: gap.smallest_plausible()?,
    })
}
