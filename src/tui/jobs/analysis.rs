//! The analysis job: measures the video and the fitted head, evaluates them and turns the
//! report into the analysis screen's tables and trajectories.

use crate::alignment::Alignment;
use crate::fit::FrameFit;
use crate::landmarks::Track;
use crate::model::{LandmarkMap, MorphableModel};
use crate::tui::app::App;
use crate::tui::screens::analysis::{AnalysisData, AnalysisRow, AnalysisTable, Trajectory};
use std::sync::Arc;

/// Everything the analysis needs: the clip's effective landmarks, phones and fits.
pub struct AnalysisJob {
    pub generation: u64,
    pub name: String,
    pub model: Arc<MorphableModel>,
    pub map: LandmarkMap,
    pub track: Track,
    pub alignment: Alignment,
    pub fps: f64,
    pub fits: Vec<FrameFit>,
    /// The head the facial indices are taken on (shown after the error tables), as `lipmap
    /// indices` takes them.
    pub index_head: IndexHeadSource,
    /// The clip's landmarks as corrected, lips not sealed: the speaker's indices are taken on
    /// them, as `lipmap indices` takes them (`track` is the fit's input).
    pub speaker_track: Track,
    /// The side view's P per front frame (corrections applied), when the clip has one.
    pub side_p: Option<Vec<Option<f64>>>,
    /// The landmark set the fits used, named in the tables.
    pub set: crate::landmarks::LandmarkSet,
}

/// The head the analysis takes facial indices on, owned by the job (see
/// [`crate::workflow::indices::IndexHead`]).
pub enum IndexHeadSource {
    /// The model through the fit's map, on the mesh the app shows (when the model's own).
    Model(Option<Arc<crate::model::Mesh>>),
    /// A head that is another mesh than the model, through its own map.
    OwnMap(Arc<crate::model::Mesh>, LandmarkMap),
}

impl IndexHeadSource {
    /// The head `lipmap indices` would read: the head's own map as being labelled when the
    /// head view labels it, else the session's head with its own map when there is one,
    /// else the model.
    pub fn of(app: &App) -> Self {
        use crate::session::MapRole;
        let labelled = match (app.head.label_role, &app.mesh, &app.map) {
            (MapRole::Head, Some(mesh), Some(map)) if !map.is_empty() => {
                Some((mesh.clone(), map.clone()))
            }
            _ => None,
        };
        match labelled.or_else(|| app.other_head.clone()) {
            Some((mesh, map)) => Self::OwnMap(mesh, map),
            None => Self::Model(app.mesh.clone()),
        }
    }
}

impl AnalysisJob {
    /// The analysis of the app's clip (named `name`) and fits, as request `generation`;
    /// `None` without a model or a map.
    pub fn of(app: &App, generation: u64, name: String) -> Option<Self> {
        Some(Self {
            generation,
            name,
            model: app.model.clone()?,
            map: app.fit_map()?.clone(),
            track: app.fit_input_track(),
            alignment: app.alignment.clone().unwrap_or_default(),
            fps: app.fps,
            fits: app.fits.by_frame.values().cloned().collect(),
            index_head: IndexHeadSource::of(app),
            speaker_track: app.track.clone(),
            side_p: app.side.view().map(|s| s.p_series(app.n_frames(), app.fps)),
            set: app.fit_settings.set,
        })
    }
}

/// Measures the video and the fitted head and evaluates them with
/// `crate::workflow::evaluate_clip` (min–max normalised, as the published method), then turns
/// the report into the analysis view's tables and trajectories.
pub fn analyse_for_tui(job: &AnalysisJob) -> AnalysisData {
    use crate::measure::Measure;
    use crate::workflow::{ClipInput, DEFAULT_WORST_ROWS, Normalisation, evaluate_clip};
    let input = ClipInput {
        name: &job.name,
        alignment: &job.alignment,
        fps: job.fps,
        track: &job.track,
        fits: &job.fits,
        side_view: job.side_p.is_some(),
        side_p: job.side_p.as_deref(),
        pose: crate::measure::PoseComparison::default(),
        set: Some(job.set),
    };
    let evaluated =
        evaluate_clip(&job.model, &job.map, &input, Normalisation::MinMax, DEFAULT_WORST_ROWS);
    let (u, report) = (&evaluated.utterance, &evaluated.report);
    let first_frame_of = |label: &str| {
        let phones = &crate::reference::current().phones;
        let key = phones.key_of(label);
        job.alignment
            .phones
            .iter()
            .find(|p| phones.key_of(&p.label) == key)
            .map(|p| Alignment::frames_of(p, job.fps).start)
    };
    // The facial indices of speaker and head from what the app holds (no disk reads), when
    // a map and the index points allow them.
    use crate::workflow::indices::IndexHead;
    let head = match &job.index_head {
        IndexHeadSource::Model(mesh) => {
            IndexHead::Model { model: &job.model, map: &job.map, head: mesh.as_deref() }
        }
        IndexHeadSource::OwnMap(mesh, map) => IndexHead::OwnMap { mesh, map },
    };
    let index_tables = crate::workflow::indices::index_tables(
        head,
        &job.name,
        &job.speaker_track,
        &job.alignment,
        job.fps,
        &crate::reference::current().bounds,
    )
    .unwrap_or_default();
    let tables = [
        &report.phonemes,
        &report.visemes,
        &report.sentences,
        &report.worst_frames,
        &report.worst_fits,
    ]
    .into_iter()
    .chain(index_tables.iter())
    .map(|t| table_for_tui(t, &first_frame_of, t.title == report.phonemes.title))
    .collect();
    let normalised = u.min_max_normalised();
    let trajectories = Measure::ALL
        .into_iter()
        .filter(|m| {
            normalised.video.series(*m).iter().any(Option::is_some)
                || normalised.head.series(*m).iter().any(Option::is_some)
        })
        .map(|m| Trajectory {
            name: m.as_str().to_string(),
            video: frame_points(normalised.video.series(m)),
            model: frame_points(normalised.head.series(m)),
        })
        .collect();
    let warnings = evaluated.warnings.iter().map(|w| w.status_text().to_string()).collect();
    AnalysisData { tables, trajectories, warnings }
}

/// A per-frame series as chart points (frame, value), gaps left out.
pub(super) fn frame_points(s: &[Option<f64>]) -> Vec<(f64, f64)> {
    s.iter().enumerate().filter_map(|(f, v)| v.map(|v| (f as f64, v))).collect()
}

/// An eval `Table` as an analysis table: a `frame` column gives the row's jump target; in the
/// phoneme table the phone's first occurrence does.
pub(super) fn table_for_tui(
    t: &crate::eval::Table,
    first_frame_of: &dyn Fn(&str) -> Option<usize>,
    phones: bool,
) -> AnalysisTable {
    use crate::eval::Cell;
    let frame_col = t.headers.iter().position(|h| h == "frame");
    let rows = t
        .rows
        .iter()
        .map(|r| {
            let cells: Vec<String> = (0..t.headers.len())
                .map(|c| r.get(c).map_or(String::new(), |x| x.display(t.precision)))
                .collect();
            let keys = (0..t.headers.len())
                .map(|c| match r.get(c) {
                    Some(Cell::Num(v)) if v.is_finite() => Some(*v),
                    Some(Cell::Int(i)) => Some(*i as f64),
                    _ => None,
                })
                .collect();
            let frame = match (frame_col, r.get(frame_col.unwrap_or(usize::MAX))) {
                (Some(_), Some(Cell::Int(i))) => usize::try_from(*i).ok(),
                _ if phones => cells.first().and_then(|l| first_frame_of(l)),
                _ => None,
            };
            AnalysisRow { cells, keys, frame, clip: None }
        })
        .collect();
    AnalysisTable { title: t.title.clone(), columns: t.headings(), rows }
}
