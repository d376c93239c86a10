//! The motion corpus SAQP learns from: fitted sentences as per-frame coefficients of a linear
//! shape model (so pose-free shapes are produced on demand instead of stored), their phone
//! timings, and the model's mean shape and landmark map.

use super::SaqpError;
use crate::alignment::Phone;
use crate::fit::FrameFit;
use crate::math::{DMatrix, DVector};
use crate::model::{LandmarkMap, MorphableModel};

/// A linear shape generator `S = mean + basis · c` (flat `x0 y0 z0 …`, 3N values): a
/// morphable model's identity basis scaled by √e followed by its expression blendshapes.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearShapes {
    pub mean: DVector,
    pub basis: DMatrix,
}

impl LinearShapes {
    /// The generator of a morphable model: coefficients are `[α; β]` as a [`FrameFit`] reports.
    pub fn from_model(model: &MorphableModel) -> Self {
        let id = model.shape.rescaled_basis();
        let basis = match &model.expressions {
            Some(e) if e.deltas.ncols() > 0 => {
                let mut b = DMatrix::zeros(id.nrows(), id.ncols() + e.deltas.ncols());
                b.columns_mut(0, id.ncols()).copy_from(&id);
                b.columns_mut(id.ncols(), e.deltas.ncols()).copy_from(&e.deltas);
                b
            }
            _ => id,
        };
        Self { mean: model.shape.mean.clone(), basis }
    }

    /// The coefficient vector `[α; β]` of a fitted frame.
    pub fn coefficients_of_fit(fit: &FrameFit) -> DVector {
        DVector::from_iterator(
            fit.identity.len() + fit.expression.len(),
            fit.identity.iter().chain(&fit.expression).copied(),
        )
    }

    /// The neutral (identity-only) coefficients of a fitted frame: `[α; 0]`.
    pub fn neutral_of_fit(fit: &FrameFit) -> DVector {
        DVector::from_iterator(
            fit.identity.len() + fit.expression.len(),
            fit.identity.iter().copied().chain(fit.expression.iter().map(|_| 0.0)),
        )
    }

    pub fn num_vertices(&self) -> usize {
        self.mean.len() / 3
    }

    pub fn num_coefficients(&self) -> usize {
        self.basis.ncols()
    }

    /// The pose-free shape for coefficients `c`.
    pub fn shape(&self, c: &DVector) -> DVector {
        &self.mean + &self.basis * c
    }
}

/// One fitted sentence.
#[derive(Clone, Debug, PartialEq)]
pub struct Sentence {
    pub name: String,
    /// Phone intervals in seconds, in time order.
    pub phones: Vec<Phone>,
    /// Frame `f` is at time `f / fps`.
    pub fps: f64,
    /// Per frame, the shape coefficients (pose-free by construction).
    pub frames: Vec<DVector>,
    /// The clip's neutral (identity) shape coefficients; motion is measured from it.
    pub neutral: DVector,
}

/// Fitted sentences of one speaker, on one shape model.
#[derive(Clone, Debug, PartialEq)]
pub struct Corpus {
    pub shapes: LinearShapes,
    pub landmarks: LandmarkMap,
    pub sentences: Vec<Sentence>,
    /// The phoneme → viseme classes a rare phone backs off to (the reader's table, passed
    /// in like every other input).
    pub visemes: crate::eval::VisemeTable,
    /// The phone inventory that says which labels are one phone (IPA, ARPAbet, Festival).
    pub phones: crate::alignment::PhoneInventory,
}

impl Corpus {
    /// Checks shapes and every sentence; the first problem, naming the sentence.
    ///
    /// # Errors
    /// A basis whose rows differ from the mean's length, no landmark inside the model, a
    /// sentence with no frames, no phones, a bad frame rate, a coefficient vector of the
    /// wrong length or a non-finite coefficient.
    pub fn validate(&self) -> Result<(), SaqpError> {
        let (rows, m) = (self.shapes.basis.nrows(), self.shapes.num_coefficients());
        if rows != self.shapes.mean.len() || rows % 3 != 0 {
            return Err(SaqpError::BasisShape { rows, mean: self.shapes.mean.len() });
        }
        let n = self.shapes.num_vertices();
        if !self.landmarks.pairs().any(|(_, v)| v < n) {
            return Err(SaqpError::NoLandmarks(n));
        }
        for s in &self.sentences {
            if s.frames.is_empty() {
                return Err(SaqpError::NoFrames(s.name.clone()));
            }
            if s.phones.is_empty() {
                return Err(SaqpError::NoPhones(s.name.clone()));
            }
            if !(s.fps.is_finite() && s.fps > 0.0) {
                return Err(SaqpError::BadFps(s.name.clone()));
            }
            let frames = std::iter::once(&s.neutral).chain(&s.frames);
            for (f, c) in frames.enumerate() {
                if c.len() != m {
                    let frame = f.saturating_sub(1);
                    let (sentence, got) = (s.name.clone(), c.len());
                    return Err(SaqpError::CoefficientCount { sentence, frame, got, expected: m });
                }
                if c.iter().any(|x| !x.is_finite()) {
                    return Err(SaqpError::NonFinite(s.name.clone()));
                }
            }
        }
        Ok(())
    }

    /// The index of the sentence called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.sentences.iter().position(|s| s.name == name)
    }
}
