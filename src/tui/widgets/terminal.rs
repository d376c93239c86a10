//! Terminal setup and teardown: raw mode, alternate screen, mouse capture; restored on
//! every exit path, normal return, error (via `Drop`) and panic (via a panic hook).
//!
//! `TerminalGuard` owns the terminal; dropping it restores. Restoring twice is harmless.

use ratatui::Terminal;
use ratatui::backend::CrosstermBackend;
use ratatui::crossterm::event::{DisableMouseCapture, EnableMouseCapture};
use ratatui::crossterm::execute;
use ratatui::crossterm::terminal::{
    EnterAlternateScreen, LeaveAlternateScreen, disable_raw_mode, enable_raw_mode,
};
use std::io::{Stdout, stdout};
use std::sync::Once;

pub type Tui = Terminal<CrosstermBackend<Stdout>>;

/// Puts the terminal back: mouse off, main screen, cursor shown, cooked mode. Errors are
/// ignored: this runs while leaving, often after something already failed.
pub fn restore() {
    let _ = execute!(
        stdout(),
        DisableMouseCapture,
        LeaveAlternateScreen,
        ratatui::crossterm::cursor::Show
    );
    let _ = disable_raw_mode();
}

static HOOK: Once = Once::new();

/// Installs (once) a panic hook that restores the terminal before the default hook prints,
/// so the panic message is readable and the shell usable.
pub fn install_panic_hook() {
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            restore();
            previous(info);
        }));
    });
}

/// The terminal in TUI mode; restores it when dropped.
pub struct TerminalGuard {
    pub terminal: Tui,
}

impl TerminalGuard {
    /// Enters raw mode, the alternate screen and mouse capture.
    ///
    /// # Errors
    /// When the terminal refuses (not a TTY); the terminal is restored before returning.
    pub fn enter() -> std::io::Result<Self> {
        Self::enter_with(|| ()).map(|(guard, ())| guard)
    }

    /// As `enter`, running `probe` once raw mode and the alternate screen are on and the
    /// `Terminal` exists, but before mouse capture and before any event is read: the moment
    /// a terminal query (graphics protocol, cell size) must run, so its reply is neither
    /// echoed on the main screen nor mixed with mouse reports. After `Terminal::new`, whose
    /// own cursor-position query must not race with a probe still reading a slow reply.
    ///
    /// # Errors
    /// As `enter`.
    pub fn enter_with<T>(probe: impl FnOnce() -> T) -> std::io::Result<(Self, T)> {
        install_panic_hook();
        let setup = || -> std::io::Result<(Tui, T)> {
            enable_raw_mode()?;
            execute!(stdout(), EnterAlternateScreen)?;
            let mut t = Terminal::new(CrosstermBackend::new(stdout()))?;
            let probed = probe();
            execute!(stdout(), EnableMouseCapture)?;
            t.clear()?;
            Ok((t, probed))
        };
        match setup() {
            Ok((terminal, probed)) => Ok((Self { terminal }, probed)),
            Err(e) => {
                restore();
                Err(e)
            }
        }
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        restore();
    }
}
