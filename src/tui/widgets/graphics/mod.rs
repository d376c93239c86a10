//! Terminal graphics protocols (Sixel, Kitty, iTerm2 through `ratatui-image`) for the frame
//! image: choosing one at startup, rasterising the view and its markers, caching the encoding.
//!
//! Start at `GraphicsState::detect` (run loop, once, after the alternate screen is entered and
//! before events are read) and `GraphicsState::render`. Half-blocks stay the default: auto
//! mode never uses a protocol inside tmux or over SSH, and falls back when the terminal does
//! not answer the query. The protocol image covers exactly the `Mapping`'s area, cell for
//! cell, so mouse hit-testing through `Mapping` is unchanged.
//!
//! One concern a file: `choice` (what the user asked for, the environment, the startup
//! decision), `detect` (querying the terminal), `raster` (the view and its markers as
//! pixels), `encode` (pixels to a protocol's escape sequences, on a thread of its own) and
//! `state` (the chosen protocol and its cached image, drawn into the buffer).

mod choice;
mod detect;
mod encode;
mod raster;
mod state;

pub use choice::{Decision, GRAPHICS_ENV, GraphicsChoice, TermEnv, decide, protocol_name};
pub use encode::CacheKey;
pub use raster::{colour_rgb, draw_marker, rasterise_view};
pub use state::GraphicsState;
