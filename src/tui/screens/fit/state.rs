//! The fit screen's state: the fit job under way (its generation, progress and error). The
//! fits themselves are shared (`app::Fits`): every screen reads them.

/// The newest fit requested and how it is going.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitScreen {
    /// Generation of the newest requested fit; replies from older ones are dropped.
    pub generation: u64,
    pub running: bool,
    pub progress: (usize, usize),
    pub error: Option<String>,
}
