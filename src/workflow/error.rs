//! What can go wrong in a session use case, as one typed enum, and the warnings a use case
//! returns instead of printing (the fronts show them: the CLI on stderr, the TUI in its
//! status line).

use crate::io::FormatError;
use crate::session::SessionError;
use std::path::PathBuf;

/// Why a session use case failed. Every message names the file, clip or setting concerned;
/// the fronts print it as it is (the CLI joins a [`Error::Context`] chain on one line).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The session names no model.
    #[error("the session has no model: give one with `lipmap new --model`")]
    NoModel,
    /// The session has no landmark map (or an empty one); `session` names it in the hint.
    #[error("{}", no_map_message(session.as_deref()))]
    NoMap { session: Option<PathBuf> },
    /// The session's head mesh has no head map (or an empty one); `session` names it in the
    /// hint.
    #[error("{}", no_head_map_message(head, session.as_deref()))]
    NoHeadMap { head: PathBuf, session: Option<PathBuf> },
    /// A map the fit cannot use.
    #[error(transparent)]
    MapCheck(#[from] super::resources::MapCheckError),
    /// A map the fit refuses before anything is fitted (unusable, or failing the anatomy
    /// check without `--accept-map-warnings`).
    #[error(transparent)]
    FitRefused(#[from] super::resources::FitRefusal),
    /// A map file that fails the checks of `lipmap map check` on the mesh it names vertices
    /// of, given to be used (import, new, transfer) without `--accept-map-warnings`.
    #[error(
        "{}: the landmark map fails the checks on {mesh}: {}; fix it (`lipmap map check`, the TUI's view 2) or go on with --accept-map-warnings",
        file.display(),
        super::resources::problems_summary(problems)
    )]
    MapRefused { file: PathBuf, mesh: String, problems: Vec<String> },
    /// A map naming vertices the model lacks.
    #[error(transparent)]
    MapRange(#[from] super::resources::MapRangeError),
    /// A clip name the session does not have.
    #[error("no clip `{name}` in the session (clips: {})", known.join(", "))]
    UnknownClip { name: String, known: Vec<String> },
    /// A use case that needs at least one clip.
    #[error("the session has no clips")]
    NoClips,
    /// Reading, writing, locking or editing the session (a held lock is `SessionError::Locked`).
    #[error(transparent)]
    Session(#[from] SessionError),
    /// A file that does not parse, with its line or field.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// Frames that cannot be read.
    #[error(transparent)]
    Frames(#[from] crate::io::frames::FrameError),
    /// A file or folder that cannot be read or written.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// A render of the fitted head that failed.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Configurations that cannot be compared.
    #[error(transparent)]
    Compare(#[from] crate::eval::compare::CompareError),
    /// A file lipmap's tracker reads that is not given and not where Debian installs it.
    #[error(
        "no {what} at {}: install it (Debian/Ubuntu `apt-get install {package}`) or name one with {flag} FILE",
        path.display()
    )]
    NoTrackerFile {
        /// What the file holds ("shape predictor", "face detector cascade").
        what: &'static str,
        /// Where it was looked for.
        path: PathBuf,
        /// The Debian package that installs it.
        package: &'static str,
        /// The flag that names it (`--predictor`, `--detector`).
        flag: &'static str,
    },
    /// Suggestions for a map that cannot be made, matched to `on` (the head's own face, a
    /// frame). A front says where labels are made when there are too few.
    #[error("{on}: {error}")]
    Suggest { on: String, error: crate::fit::suggest::SuggestError },
    /// Input that breaks a rule of the use case (the message says which).
    #[error("{0}")]
    Invalid(String),
    /// `source` in the setting `context` names (a clip, a head, a file).
    #[error("{context}")]
    Context {
        context: String,
        #[source]
        source: Box<Error>,
    },
}

/// How to give a session its model map, `SESSION` standing for the session's path. The TUI
/// opens its head view on the model while the model map is empty, so "view 2" is where it
/// is labelled whether the model is the head's own mesh or another one.
pub const NO_MAP_HINT: &str =
    "label it in the TUI (view 2) or `lipmap import SESSION --mapping FILE`";

/// Why a session cannot be fitted yet: it has no model map (or an empty one). It names the
/// model map, not just "a map", since a session whose head is another mesh has two and only
/// the model's is what `fit` needs.
pub const NO_MAP_MESSAGE: &str = "the session has no model map (what `fit` uses)";

/// [`NO_MAP_MESSAGE`] with [`NO_MAP_HINT`], naming `session` when known.
pub fn no_map_message(session: Option<&std::path::Path>) -> String {
    format!("{NO_MAP_MESSAGE}: {}", session_hint(NO_MAP_HINT, session))
}

/// Why a session's head cannot be measured or driven yet: its head map is missing.
fn no_head_map_message(head: &std::path::Path, session: Option<&std::path::Path>) -> String {
    let hint = "label it in the TUI (view 2) or set one with \
                `lipmap import SESSION --head-mapping MAP.toml`";
    format!("the head {} has no map yet: {}", head.display(), session_hint(hint, session))
}

/// `hint` with its `SESSION` placeholder replaced by the session's path when known.
pub(crate) fn session_hint(hint: &str, session: Option<&std::path::Path>) -> String {
    match session {
        Some(p) => hint.replace("SESSION", &p.display().to_string()),
        None => hint.to_string(),
    }
}

/// A workflow result.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// This error with the session it concerns named where its hint has a place for it
    /// (the use cases below a session's path report errors without it).
    pub fn in_session(self, path: &std::path::Path) -> Self {
        let session = Some(path.to_path_buf());
        match self {
            Error::NoMap { .. } => Error::NoMap { session },
            Error::NoHeadMap { head, .. } => Error::NoHeadMap { head, session },
            Error::Context { context, source } => {
                Error::Context { context, source: Box::new(source.in_session(path)) }
            }
            e => e,
        }
    }

    /// This error inside `context` (e.g. "clip `a`"), shown before it.
    pub fn context(self, context: impl Into<String>) -> Self {
        Error::Context { context: context.into(), source: Box::new(self) }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }
}

/// `.context(..)` on results whose error converts into [`Error`].
pub trait Context<T> {
    /// The error inside `context`.
    fn context(self, context: impl Into<String>) -> Result<T>;
    /// The error inside the context `f` makes (only on failure).
    fn with_context<S: Into<String>>(self, f: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: Into<Error>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.into().context(context))
    }
    fn with_context<S: Into<String>>(self, f: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| e.into().context(f()))
    }
}

/// Something a use case noticed but worked around; the result is still valid. The text is
/// the line the command line prints on stderr as it is (mostly `lipmap: warning: …` or
/// `lipmap: note: …`; [`Warning::status_text`] drops that prefix for the TUI's status line).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning(pub String);

impl Warning {
    /// The line without the command line's `lipmap: ` and `note: `/`warning: ` prefixes, for
    /// a status line that has no room for them.
    pub fn status_text(&self) -> &str {
        let s = self.0.strip_prefix("lipmap: ").unwrap_or(&self.0);
        s.strip_prefix("note: ").or_else(|| s.strip_prefix("warning: ")).unwrap_or(s)
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// `e` and its causes on one line, `outer: cause: cause`. Text already said is not said
/// again: a cause already in the message is dropped, and a cause that repeats the message
/// (a path given as context to an error that names the path) replaces it, so no line reads
/// `/x: /x: No such file`.
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut msg = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let c = cause.to_string();
        if c.strip_prefix(&msg).is_some_and(|rest| rest.is_empty() || rest.starts_with(':')) {
            msg = c;
        } else if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
        source = cause.source();
    }
    msg
}

/// How a long use case reports progress: a new stage of `total` steps, or steps done in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Progress {
    /// A stage starts (e.g. "fitting s1 (F4)"), `total` steps (0 when not known yet).
    Stage { what: String, total: usize },
    /// `done` of `total` steps of the current stage are done.
    Steps { done: usize, total: usize },
    /// The use case has finished (a progress bar can be cleared).
    Finished,
}

/// The callback a use case reports [`Progress`] to (called from worker threads too).
pub type ProgressFn<'a> = &'a (dyn Fn(Progress) + Sync);

/// A callback that ignores progress.
pub fn no_progress(_: Progress) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_given_as_context_to_an_error_naming_it_is_said_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = Error::io("/x", io).context("/x");
        assert_eq!(error_chain(&e), "/x: No such file");
        let e = Error::Invalid("bad value".into()).context("clip `a`");
        assert_eq!(error_chain(&e), "clip `a`: bad value");
        let e = Error::io("/x.csv", std::io::Error::other("gone")).context("/x");
        assert_eq!(error_chain(&e), "/x: /x.csv: gone");
    }
}
