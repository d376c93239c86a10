//! The map suggestion's job: the TUI's `o` and `O` through the use case `lipmap map suggest`
//! calls (`workflow::map::suggest_map_from_labels`), with the labels the TUI holds, on the
//! head's own face when the shape predictor can be read (once, kept in [`TrackerSource`]),
//! else matched to the speaker with the same one-line reason.

use super::track::TrackerSource;
use crate::model::LandmarkMap;
use crate::session::{MapRole, Session};
use crate::tui::action::Action;
use crate::workflow::map::{MatchTo, suggest_map_from_labels};

/// What the suggestion's job is asked, copied so the job does not share the `App`.
#[derive(Clone, Debug)]
pub struct SuggestJob {
    /// The session as last written back (its meshes, model and clip).
    pub session: Session,
    /// Which mesh's map is labelled.
    pub role: MapRole,
    pub clip: String,
    /// The labels the suggestions start from.
    pub labels: LandmarkMap,
    /// The one landmark asked for (`o`), or `None` for every unlabelled one (`O`).
    pub landmark: Option<usize>,
}

/// Answers a request with `MapSuggested`: the suggested map, or the one line saying why
/// there is none; `say` hears that the predictor is being read.
pub fn suggest_for_tui(source: &TrackerSource, job: SuggestJob, say: &dyn Fn(String)) -> Action {
    let predictor = match source.suggestion_predictor(say) {
        Ok(p) => p,
        Err(e) => return failed(&job, &e),
    };
    let to = match &predictor {
        Ok(p) => MatchTo::OwnFace(p),
        Err(why) => MatchTo::Frame(None, Some(why)),
    };
    let labels = job.labels.clone();
    match suggest_map_from_labels(&job.session, job.role, labels, Some(&job.clip), to) {
        Ok(s) => Action::MapSuggested { landmark: job.landmark, suggested: Ok(Box::new(s)) },
        Err(e) => failed(&job, &e),
    }
}

fn failed(job: &SuggestJob, e: &crate::workflow::Error) -> Action {
    Action::MapSuggested { landmark: job.landmark, suggested: Err(crate::workflow::error_chain(e)) }
}
