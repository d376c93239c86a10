//! Visual features (Terissi et al. 2011, §3: a few parameters of mouth motion; lipmap's
//! equivalent): the first K principal components of the mouth region's motion, each frame's
//! vertices minus the clip's neutral mouth, PCA over all training frames.
//!
//! Input vertices are pose-free: a fitted clip's model-space shape (the fit separates the
//! rigid pose from the shape), so head motion does not leak into the features. Subtracting
//! each clip's own neutral removes the speaker's (or the fit's) static mouth shape and leaves
//! the articulation.

use super::error::{SpeechError, bad};
use crate::math::{DMatrix, DVector, Point3};
use serde::{Deserialize, Serialize};

/// One clip's mouth: per frame, the positions of the same V mouth vertices, and the neutral
/// positions of those vertices.
#[derive(Clone, Copy, Debug)]
pub struct MouthClip<'a> {
    pub frames: &'a [Vec<Point3>],
    pub neutral: &'a [Point3],
}

/// The PCA basis of mouth motion: mean displacement and K orthonormal components (3V × K).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisualBasis {
    pub mean: DVector,
    pub components: DMatrix,
    /// Variance along each component over the training frames.
    pub variances: Vec<f64>,
}

fn displacements(clip: &MouthClip, n_vertices: usize) -> Result<DMatrix, SpeechError> {
    if clip.neutral.len() != n_vertices {
        return Err(SpeechError::DimensionMismatch {
            what: "neutral mouth vertices",
            expected: n_vertices,
            got: clip.neutral.len(),
        });
    }
    let mut out = DMatrix::zeros(clip.frames.len(), 3 * n_vertices);
    for (f, frame) in clip.frames.iter().enumerate() {
        if frame.len() != n_vertices {
            return Err(SpeechError::DimensionMismatch {
                what: "mouth vertices in a frame",
                expected: n_vertices,
                got: frame.len(),
            });
        }
        for (v, (p, n)) in frame.iter().zip(clip.neutral).enumerate() {
            let d = p - n;
            if !(d.x.is_finite() && d.y.is_finite() && d.z.is_finite()) {
                return Err(bad("mouth vertex", format!("frame {f}, vertex {v} is not finite")));
            }
            for k in 0..3 {
                out[(f, 3 * v + k)] = d[k];
            }
        }
    }
    Ok(out)
}

/// Fits the basis of `k` components to all frames of `clips`.
///
/// # Errors
/// No frames, clips with different vertex counts, k = 0 or more than the data's dimension,
/// or motion with fewer than k directions of non-zero variance.
pub fn fit_visual_basis(clips: &[MouthClip], k: usize) -> Result<VisualBasis, SpeechError> {
    let n_vertices =
        clips.first().map(|c| c.neutral.len()).ok_or(SpeechError::Empty("mouth clips"))?;
    let dim = 3 * n_vertices;
    if k == 0 || k > dim {
        return Err(bad("visual components", format!("{k} of {dim} dimensions")));
    }
    let blocks: Vec<DMatrix> =
        clips.iter().map(|c| displacements(c, n_vertices)).collect::<Result<_, _>>()?;
    let n: usize = blocks.iter().map(DMatrix::nrows).sum();
    if n < 2 {
        return Err(SpeechError::TooFew { what: "mouth frames", need: 2, got: n });
    }
    let mut mean = DVector::zeros(dim);
    for b in &blocks {
        for row in b.row_iter() {
            mean += row.transpose();
        }
    }
    mean /= n as f64;
    let mut scatter = DMatrix::zeros(dim, dim);
    for b in &blocks {
        let mut c = b.clone();
        for mut row in c.row_iter_mut() {
            row -= mean.transpose();
        }
        scatter += c.tr_mul(&c);
    }
    let eig = (scatter / n as f64).symmetric_eigen();
    let mut order: Vec<usize> = (0..dim).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let top = eig.eigenvalues[order[0]];
    let mut components = DMatrix::zeros(dim, k);
    let mut variances = Vec::with_capacity(k);
    for (i, &o) in order.iter().take(k).enumerate() {
        let var = eig.eigenvalues[o];
        if var.is_nan() || var <= 1e-12 * top.max(1e-300) {
            return Err(SpeechError::TooFew {
                what: "directions of mouth motion",
                need: k,
                got: i,
            });
        }
        let mut v = eig.eigenvectors.column(o).into_owned();
        // Eigenvectors have no sign of their own; fix it so the same data gives the same
        // basis: the largest entry positive.
        let imax = v.iamax();
        if v[imax] < 0.0 {
            v = -v;
        }
        components.set_column(i, &v);
        variances.push(var);
    }
    Ok(VisualBasis { mean, components, variances })
}

impl VisualBasis {
    /// Mouth vertices per frame this basis expects.
    pub fn n_vertices(&self) -> usize {
        self.mean.len() / 3
    }

    /// Number of components K.
    pub fn n_components(&self) -> usize {
        self.components.ncols()
    }

    /// The clip's features, T × K.
    ///
    /// # Errors
    /// A clip whose vertex count differs from the basis's, non-finite vertices.
    pub fn project(&self, clip: &MouthClip) -> Result<DMatrix, SpeechError> {
        let mut d = displacements(clip, self.n_vertices())?;
        for mut row in d.row_iter_mut() {
            row -= self.mean.transpose();
        }
        Ok(d * &self.components)
    }

    /// The features of no displacement from the neutral (K): the mouth at rest.
    pub fn rest(&self) -> Vec<f64> {
        (-self.mean.transpose() * &self.components).iter().copied().collect()
    }

    /// Mouth vertices from features (T × K) around `neutral`.
    ///
    /// # Errors
    /// Feature or neutral sizes that do not match the basis.
    pub fn reconstruct(
        &self,
        features: &DMatrix,
        neutral: &[Point3],
    ) -> Result<Vec<Vec<Point3>>, SpeechError> {
        if features.ncols() != self.n_components() {
            return Err(SpeechError::DimensionMismatch {
                what: "visual features",
                expected: self.n_components(),
                got: features.ncols(),
            });
        }
        if neutral.len() != self.n_vertices() {
            return Err(SpeechError::DimensionMismatch {
                what: "neutral mouth vertices",
                expected: self.n_vertices(),
                got: neutral.len(),
            });
        }
        Ok(features
            .row_iter()
            .map(|f| {
                let d = &self.mean + &self.components * f.transpose();
                neutral
                    .iter()
                    .enumerate()
                    .map(|(v, p)| p + d.fixed_rows::<3>(3 * v).into_owned())
                    .collect()
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_moving_vertex_gives_its_direction_and_round_trips() {
        let neutral = vec![Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 0.0, 0.0)];
        // Vertex 1 moves along (0, 3, 4)/5 by s; vertex 0 along x by 0.1 s.
        let frames: Vec<Vec<Point3>> = (0..20)
            .map(|i| {
                let s = (i as f64 * 0.7).sin();
                vec![Point3::new(0.1 * s, 0.0, 0.0), Point3::new(1.0, 0.6 * s, 0.8 * s)]
            })
            .collect();
        let clip = MouthClip { frames: &frames, neutral: &neutral };
        let basis = fit_visual_basis(&[clip], 1).unwrap();
        let c = basis.components.column(0);
        let want = DVector::from_vec(vec![0.1, 0.0, 0.0, 0.0, 0.6, 0.8]).normalize();
        assert!((c - &want).norm() < 1e-9, "{c}");
        let f = basis.project(&clip).unwrap();
        let back = basis.reconstruct(&f, &neutral).unwrap();
        for (a, b) in back.iter().flatten().zip(frames.iter().flatten()) {
            assert!((a - b).norm() < 1e-9);
        }
    }

    #[test]
    fn still_or_mismatched_mouths_are_errors() {
        let neutral = vec![Point3::origin(); 2];
        let still = vec![neutral.clone(); 10];
        assert!(fit_visual_basis(&[MouthClip { frames: &still, neutral: &neutral }], 1).is_err());
        let short = vec![vec![Point3::origin()]; 3];
        assert!(fit_visual_basis(&[MouthClip { frames: &short, neutral: &neutral }], 1).is_err());
        assert!(fit_visual_basis(&[], 1).is_err());
    }
}
