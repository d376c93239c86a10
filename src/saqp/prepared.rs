//! A corpus turned into what every SAQP step works on: phones as ids, per-frame region
//! coefficients, per-phone midpoint samples and the recorded marker motion. Built once, so
//! the cross-validation's many sub-corpora only index into it.

use super::SaqpError;
use super::corpus::Corpus;
use super::motion::MotionBasis;
use super::quality::MarkerSet;
use super::sampling::phone_midpoint_samples;
use crate::alignment::{Phone, PhoneInventory};
use crate::eval::VisemeTable;
use crate::math::DVector;
use serde::{Deserialize, Serialize};

/// Phones (their keys in the phone inventory: IPA, ARPAbet with or without stress digits and
/// Festival/HTK labels of one phone share a key, silences fold to `sil`) as small ids, with
/// each phone's viseme class.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhoneSet {
    labels: Vec<String>,
    visemes: Vec<Option<u16>>,
}

impl PhoneSet {
    /// The id of `label`'s phone (its key in `inventory`), added when new with its class in
    /// `table` (the corpus's tables, or the ones a saved predictor is used with).
    pub fn intern(&mut self, label: &str, inventory: &PhoneInventory, table: &VisemeTable) -> u16 {
        let g = inventory.key_of(label);
        if let Some(i) = self.labels.iter().position(|l| *l == g) {
            return i as u16;
        }
        let vis = table.class_of(&g).and_then(|id| table.classes.iter().position(|c| c.id == id));
        self.labels.push(g);
        self.visemes.push(vis.map(|v| v as u16));
        (self.labels.len() - 1) as u16
    }

    /// The ids of a phone sequence, interning new labels (keyed by `inventory`, classed by
    /// `table`).
    pub fn intern_all(
        &mut self,
        phones: &[Phone],
        inventory: &PhoneInventory,
        table: &VisemeTable,
    ) -> Vec<u16> {
        phones.iter().map(|p| self.intern(&p.label, inventory, table)).collect()
    }

    pub fn label(&self, id: u16) -> &str {
        &self.labels[id as usize]
    }

    /// The viseme class of phone `id`, if the table has it.
    pub fn viseme(&self, id: u16) -> Option<u16> {
        self.visemes.get(id as usize).copied().flatten()
    }

    /// Whether phone `id` is speech, not silence (what coverage and unseen phones count).
    pub fn is_speech(&self, id: u16) -> bool {
        self.label(id) != crate::alignment::SILENCE_KEY
    }

    pub fn len(&self) -> usize {
        self.labels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// Checks a set read from a file: one viseme entry per label, labels distinct and not
    /// empty, no more than ids can number.
    ///
    /// # Errors
    /// The field at fault.
    pub fn validate(&self) -> Result<(), String> {
        if self.labels.len() != self.visemes.len() || self.labels.len() > usize::from(u16::MAX) {
            return Err(format!(
                "phones: {} labels and {} viseme entries (they must match, at most {})",
                self.labels.len(),
                self.visemes.len(),
                u16::MAX
            ));
        }
        let mut seen = std::collections::HashSet::new();
        if let Some(bad) = self.labels.iter().find(|l| l.is_empty() || !seen.insert(l.as_str())) {
            return Err(format!("phones.labels: `{bad}` is empty or repeated"));
        }
        Ok(())
    }
}

/// One sentence, prepared.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedSentence {
    pub name: String,
    pub ids: Vec<u16>,
    pub phones: Vec<Phone>,
    pub fps: f64,
    /// Region coefficients per frame.
    pub coefficients: Vec<DVector>,
    /// One midpoint sample per phone.
    pub samples: Vec<DVector>,
    /// Recorded marker displacements per frame.
    pub truth: Vec<DVector>,
}

impl PreparedSentence {
    pub fn n_frames(&self) -> usize {
        self.coefficients.len()
    }
}

/// A prepared corpus.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    pub basis: MotionBasis,
    pub markers: MarkerSet,
    pub phones: PhoneSet,
    pub sentences: Vec<PreparedSentence>,
}

/// Variance each region's PCA keeps (the paper's 95 %).
pub const REGION_VARIANCE: f64 = 0.95;
/// Evenly spread face markers added to the landmark vertices.
pub const EXTRA_MARKERS: usize = 32;

impl Prepared {
    /// Validates the corpus, builds the region PCA over all its frames and prepares every
    /// sentence.
    ///
    /// # Errors
    /// Whatever [`Corpus::validate`] finds, or a corpus without motion.
    pub fn new(corpus: &Corpus) -> Result<Self, SaqpError> {
        corpus.validate()?;
        let deltas: Vec<DVector> = corpus
            .sentences
            .iter()
            .flat_map(|s| s.frames.iter().map(move |c| c - &s.neutral))
            .collect();
        let basis =
            MotionBasis::build(&corpus.shapes, &corpus.landmarks, &deltas, REGION_VARIANCE)?;
        let markers = MarkerSet::build(&corpus.shapes, &corpus.landmarks, &basis, EXTRA_MARKERS);
        let mut phones = PhoneSet::default();
        let sentences = corpus
            .sentences
            .iter()
            .map(|s| {
                let deltas: Vec<DVector> = s.frames.iter().map(|c| c - &s.neutral).collect();
                let coefficients: Vec<DVector> = deltas.iter().map(|d| basis.encode(d)).collect();
                let truth = deltas.iter().map(|d| &markers.model_rows * d).collect();
                let samples = phone_midpoint_samples(&coefficients, s.fps, &s.phones);
                PreparedSentence {
                    name: s.name.clone(),
                    ids: phones.intern_all(&s.phones, &corpus.phones, &corpus.visemes),
                    phones: s.phones.clone(),
                    fps: s.fps,
                    coefficients,
                    samples,
                    truth,
                }
            })
            .collect();
        Ok(Self { basis, markers, phones, sentences })
    }
}
