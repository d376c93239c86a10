//! The fit screen: fitted against tracked landmarks on the frame, the fit's progress, the
//! frame's pose and worst residuals, and the fitted head front and side. Its keys are the
//! frames screen's (mode chain fit → frames → global). `state`, `update`, `view` as every
//! screen.

pub mod state;
pub mod update;
pub mod view;

pub use state::FitScreen;
