//! A demo motion corpus for SAQP: many GRID sentences of speaker 0 with phone timings,
//! coarticulated true shapes and "tracked" landmarks (true projections under a moving head
//! plus tracker noise), generated in memory and never rendered, so a corpus of 100–250
//! sentences takes seconds and can be fitted straight away. GRID's six-slot grammar over a
//! 51-word vocabulary makes the same triphones recur across sentences, as SAQP's context
//! statistics need.
//!
//! Start with [`generate_corpus`], fit each sentence's `tracked` frames (e.g. with
//! [`crate::fit::fit_clip`]) and turn the fits into a [`crate::saqp::Corpus`] with
//! [`DemoCorpus::to_saqp`]; [`DemoCorpus::truth_corpus`] gives the corpus of the true shapes.

use super::speakers::MouthWarp;
use super::{
    coart, demo_head, frame_cameras, head_motion, lexicon, simulate_tracker, speaker_vertices,
    visemes,
};
use crate::alignment::Alignment;
use crate::fit::FrameFit;
use crate::landmarks::{N_LANDMARKS, Track};
use crate::math::{DVector, Point2};
use crate::model::pca::{Keep, build_pca_from_shapes};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use crate::saqp::{Corpus, LinearShapes, Sentence};
use anyhow::Result;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

/// Image size the landmarks are projected into (as `lipmap demo` renders).
const WIDTH: u32 = 720;
const HEIGHT: u32 = 480;

/// What to generate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CorpusOptions {
    pub seed: u64,
    pub sentences: usize,
    pub fps: f64,
    /// Standard deviation of the tracker noise, pixels.
    pub noise_px: f64,
}

impl Default for CorpusOptions {
    fn default() -> Self {
        Self { seed: super::DEFAULT_SEED, sentences: 200, fps: 25.0, noise_px: 0.7 }
    }
}

/// One generated sentence.
#[derive(Clone, Debug, PartialEq)]
pub struct CorpusSentence {
    pub name: String,
    pub alignment: Alignment,
    pub fps: f64,
    /// Tracked landmarks (image pixels, y down) of every frame.
    pub tracked: Track,
    /// True shape coefficients of every frame in the demo model.
    pub truth: Vec<DVector>,
}

/// The demo's model, map and sentences.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoCorpus {
    pub model: MorphableModel,
    pub landmarks: LandmarkMap,
    /// Coefficients of the head at rest (the speaker's neutral face).
    pub neutral: DVector,
    pub image_height: f64,
    pub sentences: Vec<CorpusSentence>,
}

/// Generates `options.sentences` GRID sentences of speaker 0 (in parallel; each sentence
/// has its own seed drawn from `options.seed`, so the result does not depend on threads).
///
/// # Errors
/// A non-positive frame rate, or a failure building the demo model.
pub fn generate_corpus(options: &CorpusOptions) -> Result<DemoCorpus> {
    anyhow::ensure!(options.fps.is_finite() && options.fps > 0.0, "fps must be positive");
    let (head, fields) = demo_head();
    let shapes: Vec<DVector> =
        visemes::pose_meshes(&head, &fields).into_iter().map(|(_, m)| m.to_flat()).collect();
    let shape = build_pca_from_shapes(&shapes, Keep::Components(super::DEMO_MODEL_COMPONENTS))
        .map_err(|e| anyhow::anyhow!("building the demo PCA model: {e}"))?;
    let model = MorphableModel { shape, expressions: None, triangles: head.mesh.triangles() };
    let neutral = model
        .shape
        .coefficients_of(&head.mesh.to_flat())
        .ok_or_else(|| anyhow::anyhow!("the demo head does not match its model"))?;
    let warp = MouthWarp::default();
    let mut rng = StdRng::seed_from_u64(options.seed);
    let seeds: Vec<u64> = (0..options.sentences).map(|_| rng.random()).collect();
    let sentences = seeds
        .par_iter()
        .enumerate()
        .map(|(ci, &seed)| -> Result<CorpusSentence> {
            let mut rng = StdRng::seed_from_u64(seed);
            let words = lexicon::random_sentence(&mut rng);
            let alignment = lexicon::time_sentence(&words, &mut rng).map_err(anyhow::Error::msg)?;
            let n_frames = (alignment.duration() * options.fps - 1e-9).ceil().max(1.0) as usize;
            let traj = coart::mouth_trajectory(&alignment, options.fps, n_frames);
            let motion = head_motion(&mut rng, n_frames, options.fps);
            let mut truth = Vec::with_capacity(n_frames);
            let mut points = Vec::with_capacity(n_frames);
            for f in 0..n_frames {
                let verts = speaker_vertices(&head, &fields, &warp, &traj[f]);
                let (front, _) = frame_cameras(&motion[f], WIDTH, HEIGHT);
                let pts: Vec<Point2> = (0..N_LANDMARKS)
                    .map(|l| front.project(&verts[head.landmarks.vertex(l).unwrap_or(0)]))
                    .collect();
                points.push(pts);
                let flat = Mesh { vertices: verts, faces: Vec::new() }.to_flat();
                truth.push(model.shape.coefficients_of(&flat).unwrap_or_else(|| neutral.clone()));
            }
            let (tracked, _) =
                simulate_tracker(&points, options.fps, options.noise_px, 0.0, &mut rng);
            Ok(CorpusSentence {
                name: format!("s{}_{}", ci + 1, words.join("_")),
                alignment,
                fps: options.fps,
                tracked,
                truth,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(DemoCorpus {
        model,
        landmarks: head.landmarks,
        neutral,
        image_height: HEIGHT as f64,
        sentences,
    })
}

impl DemoCorpus {
    fn corpus(&self, frames: impl Fn(usize) -> Vec<DVector>) -> Corpus {
        let sentences = self
            .sentences
            .iter()
            .enumerate()
            .map(|(i, s)| Sentence {
                name: s.name.clone(),
                phones: s.alignment.phones.clone(),
                fps: s.fps,
                frames: frames(i),
                neutral: self.neutral.clone(),
            })
            .collect();
        Corpus {
            shapes: LinearShapes::from_model(&self.model),
            landmarks: self.landmarks.clone(),
            sentences,
            // The shipped classes: the demo's phones are the shipped lexicon's.
            visemes: crate::eval::VisemeTable::default(),
            phones: crate::alignment::PhoneInventory::default(),
        }
    }

    /// Fits every sentence's tracked landmarks as one clip with `settings`, sentence order.
    pub fn fit_sentences(&self, settings: &crate::fit::FitSettings) -> Vec<Vec<FrameFit>> {
        self.sentences
            .iter()
            .map(|s| {
                crate::fit::fit_clip(
                    &self.model,
                    &self.landmarks,
                    &s.tracked.frames,
                    self.image_height,
                    settings,
                    None,
                )
            })
            .collect()
    }

    /// The SAQP corpus of per-sentence fits (one `FrameFit` per frame, in frame order); the
    /// frames without a usable fit filled in by the fit's gap policy (`fit::gaps`), a
    /// sentence that cannot be filled held at the neutral.
    pub fn to_saqp(&self, fits: &[Vec<FrameFit>]) -> Corpus {
        self.corpus(|i| {
            let (n, fps) = (fits[i].len(), self.sentences[i].fps);
            match crate::fit::fill_gaps(&fits[i], n, fps, &[]) {
                Ok(filled) => filled.fits.iter().map(LinearShapes::coefficients_of_fit).collect(),
                Err(_) => vec![self.neutral.clone(); n],
            }
        })
    }

    /// The SAQP corpus of the true shapes (no fitting).
    pub fn truth_corpus(&self) -> Corpus {
        self.corpus(|i| self.sentences[i].truth.clone())
    }
}
