//! The analysis screen's state: the tables and trajectories the analysis job computed, the
//! cursor in them, the quality cross-validation's tables (the session's, kept across clips)
//! and the speech-driven head's series.

/// Everything the analysis screen keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalysisScreen {
    /// The clip's own tables, then the quality tables.
    pub data: AnalysisData,
    pub cursor: AnalysisView,
    /// Generation of the newest requested analysis; older replies are dropped.
    pub generation: u64,
    /// The quality cross-validation's tables (SAQP over the session's sentences), kept after
    /// the clip's own analysis tables whenever those are recomputed.
    pub quality: Vec<AnalysisTable>,
    /// A quality cross-validation is running on a job.
    pub quality_running: bool,
    /// Where in the quality tables the previous clip left the cursor (table counted from the
    /// first quality table), until this clip's own tables arrive in front of them.
    pub quality_cursor: Option<AnalysisView>,
    /// The speech-driven head's series for the charts, and whether they are drawn.
    pub speech: SpeechSeries,
    pub show_speech: bool,
}

impl Default for AnalysisScreen {
    fn default() -> Self {
        Self {
            data: AnalysisData::default(),
            cursor: AnalysisView::default(),
            generation: 0,
            quality: Vec::new(),
            quality_running: false,
            quality_cursor: None,
            speech: SpeechSeries::Pending,
            show_speech: true,
        }
    }
}

/// One analysis table: named columns (the first is the row label), rows of display text with
/// numeric sort keys, rows optionally tied to a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisTable {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<AnalysisRow>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisRow {
    /// One display string per column.
    pub cells: Vec<String>,
    /// Per column: the number to sort by, when the cell is numeric.
    pub keys: Vec<Option<f64>>,
    /// The frame Enter jumps to (a worst frame, or the first frame of a phoneme).
    pub frame: Option<usize>,
    /// The session's clip Enter opens (a sentence of the quality tables), when not the
    /// open one.
    pub clip: Option<usize>,
}

impl AnalysisRow {
    /// A row of a text label and numbers (3 decimals).
    pub fn numbers(label: &str, values: &[f64], frame: Option<usize>) -> Self {
        let mut cells = vec![label.to_string()];
        cells.extend(values.iter().map(|v| format!("{v:.3}")));
        let mut keys = vec![None];
        keys.extend(values.iter().map(|v| Some(*v)));
        Self { cells, keys, frame, clip: None }
    }
}

/// A measure's trajectory over the clip, video against the fitted head, by frame number.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    pub name: String,
    pub video: Vec<(f64, f64)>,
    pub model: Vec<(f64, f64)>,
}

/// The speech-driven head's trajectories for the analysis charts: being driven from the
/// clip's audio (on a job), ready (min–max normalised as the others, by measure name), or
/// absent, with the reason the status line gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SpeechSeries {
    #[default]
    Pending,
    Ready(Vec<(String, Vec<(f64, f64)>)>),
    Absent(String),
}

impl SpeechSeries {
    /// The series of measure `name`, when ready.
    pub fn of(&self, name: &str) -> Option<&[(f64, f64)]> {
        match self {
            Self::Ready(all) => all.iter().find(|(n, _)| n == name).map(|(_, s)| s.as_slice()),
            _ => None,
        }
    }
}

/// What the analysis screen shows; computed by the analysis job from `eval`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisData {
    pub tables: Vec<AnalysisTable>,
    pub trajectories: Vec<Trajectory>,
    /// What the analysis worked around (shown in the status line).
    pub warnings: Vec<String>,
}

/// Analysis view cursor and sorting.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalysisView {
    pub table: usize,
    pub row: usize,
    /// Column index to sort by.
    pub sort_column: usize,
    pub descending: bool,
}
