//! The application layer: every session-level use case the command line, the TUI and the
//! demo share (open a session, load its resources, fit with the cache, evaluate, indices,
//! side view). Plain calls over the core returning typed results and a typed [`Error`];
//! progress goes to a callback and warnings come back in the result: nothing here prints.
//!
//! Start with [`open_for_edit`] / [`read_session`] / [`open_for_read`] (the one way a
//! session is opened, `session.rs`), then a use case: [`fit_session`], [`evaluate_session`]
//! (and [`evaluate_clip`] for the TUI's open clip), `export::export`, and one module per
//! analysis.

pub mod audio;
pub mod create;
pub mod demo;
pub mod error;
pub mod evaluate;
pub mod export;
pub mod fit;
pub mod fit_files;
pub mod flags;
pub mod heads;
pub mod indices;
pub mod map;
pub mod measure_fits;
pub mod profile_edit;
pub mod reference;
pub mod resources;
pub mod saqp;
pub mod session;
pub mod side_view;
pub mod speech;
pub mod speech_session;
pub mod track;
pub mod transfer;
pub mod untrusted;
pub mod validate;

pub use error::{
    Context, Error, NO_MAP_MESSAGE, Progress, ProgressFn, Result, Warning, error_chain, no_progress,
};
pub use evaluate::{
    ClipEvaluated, ClipEvaluation, ClipInput, ClipRequest, ClipsEvaluated, ClipsToMeasure,
    DEFAULT_WORST_ROWS, EvalConditions, EvalReport, EvalRequest, EvalTally, FitTally, NamedFits,
    Normalisation, SessionEvaluation, evaluate, evaluate_clip, evaluate_session,
    for_each_clip_evaluated, utterance_from_parts, utterance_of, utterance_of_clip,
    utterances_with,
};
pub use fit::{
    ClipFits, ClipFitted, FitStep, SessionFitted, fit_clip_cached, fit_session, shapes_by_frame,
};
pub use resources::{
    FitRefusal, MIN_FIT_LANDMARKS, MapCheckError, MapRangeError, Resources, check_before_fit,
    check_map_for_fit, check_map_vertices, load_resources, shadowed_map_file,
};
pub use session::{
    EditSession, ReadSession, clip_length, clip_or_first, find_clip, image_height, open_for_edit,
    open_for_edit_at, open_for_read, open_for_read_at, read_only_notice, read_session,
    select_clips, session_path,
};
pub use side_view::{
    HeadP, PROFILE_SETUP_KEY, RenderedHeadP, SidePoint, check_setup_in_frame, head_p_by_render,
    head_p_of_clip_by_render, head_p_options, profile_setup, resample_to_front, side_view_points,
    side_view_protrusion, side_view_track,
};
