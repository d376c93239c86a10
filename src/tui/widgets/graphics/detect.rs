//! Querying the terminal at startup for its graphics protocol and cell size.

use super::choice::{Decision, GraphicsChoice, TermEnv, decide};
use super::state::GraphicsState;
use ratatui_image::picker::cap_parser::QueryStdioOptions;
use ratatui_image::picker::{Picker, ProtocolType};
use std::time::Duration;

/// How long auto mode waits for the terminal's answer. Local terminals answer within a few
/// milliseconds; a silent one must not hold the UI back.
const AUTO_QUERY_TIMEOUT: Duration = Duration::from_millis(300);
/// An explicit protocol only needs the cell size from the query; allow a slower link.
const FORCED_QUERY_TIMEOUT: Duration = Duration::from_millis(1000);
/// Cell size assumed when the terminal does not report one (a common 1:2 font).
const DEFAULT_CELL_PX: (u16, u16) = (10, 20);

impl GraphicsState {
    /// Decides and, when needed, queries the terminal. Call once after raw mode and the
    /// alternate screen are on and before any event is read (the answer arrives on stdin,
    /// where the event reader would swallow it). Bounded by a short timeout; any failure
    /// gives half-blocks with the reason in `note`. Encodes in the background.
    pub fn detect(choice: GraphicsChoice, env: TermEnv) -> Self {
        let query = |timeout| {
            Picker::from_query_stdio_with_options(QueryStdioOptions {
                timeout,
                ..QueryStdioOptions::default()
            })
        };
        let fallback = |why: String| Self {
            note: format!("graphics: half-blocks ({why})"),
            ..Self::halfblocks()
        };
        let chosen = match decide(choice, env) {
            Decision::HalfBlocks(None) => Self::halfblocks(),
            Decision::HalfBlocks(Some(why)) => {
                fallback(format!("{why}; --graphics sixel|kitty|iterm2 forces one"))
            }
            Decision::Query => match query(AUTO_QUERY_TIMEOUT) {
                Ok(p) if p.protocol_type() == ProtocolType::Halfblocks => Self::halfblocks(),
                Ok(p) => {
                    let f = p.font_size();
                    Self::with_protocol(p.protocol_type(), (f.width, f.height), false)
                }
                Err(e) => fallback(format!("terminal query failed: {e}")),
            },
            Decision::Force(protocol) => {
                let cell = query(FORCED_QUERY_TIMEOUT)
                    .map(|p| (p.font_size().width, p.font_size().height))
                    .unwrap_or(DEFAULT_CELL_PX);
                Self::with_protocol(protocol, cell, env.tmux)
            }
        };
        chosen.in_background()
    }
}
