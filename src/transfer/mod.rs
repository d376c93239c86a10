//! Transfer: drive any head mesh with a source face model's motion through control points
//! and interpolation (Terissi et al. 2011, "Animation of generic 3D head models driven by
//! speech", §5). Plain values in and out: the source's reference shape, triangles and
//! landmark map; the target's mesh, skin mask and landmark map.
//!
//! Start at [`Transfer::new`] (setup, once per source/target pair) and
//! [`Transfer::apply`] (per frame: a source shape in, the target's vertices out). The steps,
//! one per file: [`placement`] (similarity + identity adaptation), [`projection`] (controls
//! and their target vertices, control triangles), [`barycentric`] and [`biharmonic`]
//! (interpolation), [`parts`] (teeth, tongue, eyes). `docs/transfer.md` explains where
//! this departs from the paper.

pub mod apply;
pub mod barycentric;
pub mod biharmonic;
pub mod frame;
pub mod parts;
pub mod placement;
pub mod projection;
pub mod setup;
pub mod similarity;
pub mod surface;

pub use frame::HeadFrame;
pub use parts::PartsMode;
pub use placement::{Identity, Placement};
pub use setup::{Interpolation, LipGap, SourceFace, TargetHead, Transfer, TransferOptions};
pub use similarity::{Similarity, estimate_similarity};
pub use surface::Surface;

/// Why a transfer cannot be set up or applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TransferError {
    #[error(
        "too few landmarks are labelled on both source and target: {found}, at least {needed} needed"
    )]
    TooFewLandmarks { found: usize, needed: usize },
    #[error(
        "the {side} landmark map puts iBUG point {landmark} on vertex {vertex}, but the {side} has {vertices} vertices (a map for another mesh?)"
    )]
    LandmarkOutOfRange {
        side: &'static str,
        landmark: crate::landmarks::PointNo,
        vertex: usize,
        vertices: usize,
    },
    #[error("face {face} uses vertex {vertex}, but the head has {vertices} vertices")]
    FaceOutOfRange { face: usize, vertex: usize, vertices: usize },
    #[error("the skin mask has {len} entries for {vertices} vertices")]
    SkinLength { len: usize, vertices: usize },
    #[error("face {face} has a triangle of zero area (degenerate)")]
    DegenerateTriangle { face: usize },
    #[error("edge {a}–{b} is shared by more than two triangles (non-manifold)")]
    NonManifoldEdge { a: usize, b: usize },
    #[error("cannot place the source from {points} landmark pairs: collinear or too few")]
    DegeneratePlacement { points: usize },
    #[error("control {control} has no free target skin vertex with an agreeing normal")]
    NoTargetVertex { control: usize },
    #[error("no control triangle survived the geodesic check; barycentric mode cannot run")]
    NoControlTriangles,
    #[error("a source shape has {len} values, expected {expected}")]
    ShapeLength { len: usize, expected: usize },
    #[error("{got} control positions given, expected {expected}")]
    ControlCount { got: usize, expected: usize },
    #[error("the source shape has non-finite values")]
    NonFinite,
    #[error("sparse solver: {0}")]
    Solver(String),
}
