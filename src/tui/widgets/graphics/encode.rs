//! Encoding a rasterised view into a protocol's escape sequences (Sixel, Kitty, iTerm2, all
//! through `ratatui-image`), and the thread that does it off the UI thread.

use super::raster::rasterise_view;
use crate::tui::app::FrameImage;
use crate::tui::widgets::halfblock::{Mapping, Marker};
use image::DynamicImage;
use ratatui::layout::Size;
use ratatui_image::picker::ProtocolType;
use ratatui_image::protocol::Protocol;
use ratatui_image::protocol::iterm2::Iterm2;
use ratatui_image::protocol::kitty::Kitty;
use ratatui_image::protocol::sixel::Sixel;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};

/// Everything an encoding depends on: when equal, the cached protocol image is reused.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheKey {
    pub frame: usize,
    /// Identity of the decoded image (a re-decode of the same frame is a new image).
    pub image: usize,
    pub mapping: Mapping,
    pub markers: Vec<Marker>,
}

/// What an encoding needs besides the pixels; copied into the encoder thread.
#[derive(Clone, Copy, Debug)]
pub(super) struct Encoder {
    pub(super) protocol: ProtocolType,
    /// Pixels per cell (width, height).
    pub(super) cell_px: (u16, u16),
    /// Wrap sequences in tmux passthrough.
    pub(super) tmux: bool,
    /// One Kitty image id for the whole run: re-transmitting under it replaces the old image
    /// in the terminal's memory instead of piling up new ones.
    pub(super) kitty_id: u32,
}

impl Encoder {
    /// Rasterises the view `key` describes and encodes it, sized to the mapping's area.
    pub(super) fn encode(&self, image: &FrameImage, key: &CacheKey) -> Result<Protocol, String> {
        let m = &key.mapping;
        let pixels = rasterise_view(image, m, self.cell_px, &key.markers);
        let size = Size::new(m.area.width, m.area.height);
        let img = DynamicImage::ImageRgb8(pixels);
        let encoded = match self.protocol {
            ProtocolType::Sixel => Sixel::new(img, size, self.tmux).map(Protocol::Sixel),
            ProtocolType::Kitty => {
                Kitty::new(img, size, self.kitty_id, self.tmux, false).map(Protocol::Kitty)
            }
            ProtocolType::Iterm2 => Iterm2::new(img, size, self.tmux).map(Protocol::ITerm2),
            ProtocolType::Halfblocks => return Err("half-blocks is not a protocol".into()),
        };
        encoded.map_err(|e| e.to_string())
    }
}

/// A view to encode, and the image it shows.
pub(super) struct Job {
    pub(super) key: CacheKey,
    pub(super) image: Arc<FrameImage>,
}

pub(super) type Encoded = (CacheKey, Result<Protocol, String>);

/// The encoder thread's ends: it takes the newest job, drops older queued ones, and replies.
pub(super) struct Background {
    pub(super) jobs: Sender<Job>,
    pub(super) done: Receiver<Encoded>,
}

impl Background {
    pub(super) fn start(encoder: Encoder) -> Self {
        let (jobs, job_rx) = channel::<Job>();
        let (done_tx, done) = channel();
        std::thread::spawn(move || {
            // Ends when the `GraphicsState` (the job sender) is dropped.
            while let Ok(mut job) = job_rx.recv() {
                while let Ok(newer) = job_rx.try_recv() {
                    job = newer;
                }
                let result = encoder.encode(&job.image, &job.key);
                if done_tx.send((job.key, result)).is_err() {
                    return;
                }
            }
        });
        Self { jobs, done }
    }
}
