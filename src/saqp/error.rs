//! Typed errors of the SAQP core: each names the sentence, frame or quantity at fault.

use thiserror::Error;

#[derive(Clone, Debug, Error, PartialEq)]
pub enum SaqpError {
    #[error("sentence `{0}` has no fitted frames")]
    NoFrames(String),
    #[error("sentence `{0}` has no phones")]
    NoPhones(String),
    #[error("sentence `{0}`: fewer than two phones, no trajectory to fit")]
    TooFewPhones(String),
    #[error(
        "sentence `{sentence}`: frame {frame} has {got} coefficients, the model has {expected}"
    )]
    CoefficientCount { sentence: String, frame: usize, got: usize, expected: usize },
    #[error("sentence `{0}`: frame rate must be positive and finite")]
    BadFps(String),
    #[error("sentence `{0}`: a coefficient is not finite")]
    NonFinite(String),
    #[error("sentence `{0}`: every phone is unseen in the training corpus")]
    AllPhonesUnseen(String),
    #[error(
        "sentence `{sentence}`: synthesized motion of length {got} for a sentence of {expected} frames"
    )]
    FrameCount { sentence: String, got: usize, expected: usize },
    #[error(
        "sentence `{sentence}`, frame {frame}: {got} points, the motion names {expected} vertices"
    )]
    PointCount { sentence: String, frame: usize, got: usize, expected: usize },
    #[error("sentence `{sentence}`: vertex {vertex} is not in the model ({vertices} vertices)")]
    VertexOutOfRange { sentence: String, vertex: usize, vertices: usize },
    #[error("sentence `{sentence}`: the motion lacks marker vertex {vertex}")]
    MissingVertex { sentence: String, vertex: usize },
    #[error("unknown sentence `{0}`")]
    UnknownSentence(String),
    #[error("the corpus has {got} sentences; at least {needed} are needed")]
    TooFewSentences { got: usize, needed: usize },
    #[error("the landmark map has no vertex inside the model ({0} vertices)")]
    NoLandmarks(usize),
    #[error("the shape basis has {rows} rows but the mean shape has {mean} values")]
    BasisShape { rows: usize, mean: usize },
    #[error("no motion: every frame equals its sentence's neutral shape")]
    NoMotion,
    #[error("the banded system is not positive definite (pivot {0})")]
    NotPositiveDefinite(usize),
    #[error("Gaussian process: {0}")]
    Gp(String),
    #[error("invalid option: {0}")]
    Option(String),
}
