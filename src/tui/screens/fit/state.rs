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
    /// The model map's anatomy problems shown to the user, who is asked whether to fit
    /// anyway (`f` again with the same problems is yes; see `workflow::check_before_fit`).
    pub map_problems: Vec<String>,
}
