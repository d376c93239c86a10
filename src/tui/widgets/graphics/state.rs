//! `GraphicsState`: the chosen protocol and its cached image, encoded again only when what
//! is shown changes, and drawn into the buffer over the half-block image.

use super::choice::protocol_name;
use super::encode::{Background, CacheKey, Encoded, Encoder, Job};
use crate::tui::app::FrameImage;
use crate::tui::widgets::halfblock::{Mapping, Marker};
use ratatui::buffer::Buffer;
use ratatui::widgets::Widget;
use ratatui_image::picker::ProtocolType;
use ratatui_image::protocol::Protocol;
use std::sync::Arc;

/// The chosen protocol and its cached image. Owned by the run loop (a terminal resource,
/// not app state); `halfblocks()` is inert and what tests and `TestBackend` use.
///
/// Encoding costs milliseconds (Sixel tens of them), so the run loop's state encodes on a
/// thread (`in_background`): until a view's encoding arrives the previous image stays (or
/// the half-blocks, when the area changed) and `poll` says when to redraw.
pub struct GraphicsState {
    pub(super) encoder: Option<Encoder>,
    pub(super) background: Option<Background>,
    /// The key last sent to the encoder thread and not yet answered.
    pub(super) pending: Option<CacheKey>,
    pub(super) cache: Option<(CacheKey, Protocol)>,
    pub(super) encodes: u64,
    /// One line for the status bar: what was chosen and why.
    pub note: String,
}

impl GraphicsState {
    /// No protocol: the half-block widget draws everything.
    pub fn halfblocks() -> Self {
        Self {
            encoder: None,
            background: None,
            pending: None,
            cache: None,
            encodes: 0,
            note: String::new(),
        }
    }

    /// A protocol with a known cell size, encoding synchronously inside `render` (tests,
    /// benchmarks; `detect` adds `in_background`). Half-blocks (`ProtocolType::Halfblocks`)
    /// or an empty cell size give `halfblocks()`.
    pub fn with_protocol(protocol: ProtocolType, cell_px: (u16, u16), tmux: bool) -> Self {
        if protocol == ProtocolType::Halfblocks || cell_px.0 == 0 || cell_px.1 == 0 {
            return Self::halfblocks();
        }
        let encoder = Encoder { protocol, cell_px, tmux, kitty_id: rand::random::<u32>().max(1) };
        Self {
            encoder: Some(encoder),
            note: format!(
                "graphics: {} ({}×{} px cells)",
                protocol_name(protocol),
                cell_px.0,
                cell_px.1
            ),
            ..Self::halfblocks()
        }
    }

    /// Moves encoding to a thread of its own (no-op for half-blocks).
    pub fn in_background(mut self) -> Self {
        if let Some(enc) = self.encoder {
            self.background = Some(Background::start(enc));
        }
        self
    }

    /// The protocol in use, `None` for half-blocks.
    pub fn protocol(&self) -> Option<ProtocolType> {
        self.encoder.map(|e| e.protocol)
    }

    /// Pixels per cell, when a protocol is in use.
    pub fn cell_px(&self) -> Option<(u16, u16)> {
        self.encoder.map(|e| e.cell_px)
    }

    /// How many encodings were accepted (each is a full re-send to the terminal).
    pub fn encodes(&self) -> u64 {
        self.encodes
    }

    /// Draws `image` with `markers` through the protocol into `mapping.area` of `buf`.
    /// Encodes only when the cache key (frame, image, view, markers, area) changed: at once,
    /// or on the encoder thread, showing the previous image of the same area meanwhile.
    /// Returns whether a protocol image was drawn; false (nothing drawn, half-blocks stay)
    /// without a protocol, while the first encoding of an area is pending, or after an
    /// encoding failed (the protocol is then switched off, the reason kept in `note`).
    pub fn render(
        &mut self,
        image: &Arc<FrameImage>,
        frame: usize,
        mapping: Mapping,
        markers: &[Marker],
        buf: &mut Buffer,
    ) -> bool {
        let Some(enc) = self.encoder else { return false };
        let key = CacheKey {
            frame,
            image: Arc::as_ptr(image) as usize,
            mapping,
            markers: markers.to_vec(),
        };
        if self.cache.as_ref().is_none_or(|(k, _)| *k != key) {
            match &self.background {
                None => {
                    let result = enc.encode(image, &key);
                    self.accept(key, result);
                }
                Some(bg) if self.pending.as_ref() != Some(&key) => {
                    let job = Job { key: key.clone(), image: Arc::clone(image) };
                    if bg.jobs.send(job).is_err() {
                        self.switch_off("the encoder thread stopped".into());
                        return false;
                    }
                    self.pending = Some(key);
                }
                Some(_) => {}
            }
        }
        match &self.cache {
            Some((k, p)) if k.mapping.area == mapping.area => {
                ratatui_image::Image::new(p).render(mapping.area, buf);
                true
            }
            _ => false,
        }
    }

    /// Takes finished background encodings; true when the newest one arrived (or the
    /// protocol was switched off), so the caller redraws. Stale results are dropped.
    pub fn poll(&mut self) -> bool {
        let Some(bg) = &self.background else { return false };
        let finished: Vec<Encoded> = bg.done.try_iter().collect();
        let mut changed = false;
        for (key, result) in finished {
            if self.pending.as_ref() == Some(&key) {
                self.pending = None;
                self.accept(key, result);
                changed = true;
            }
        }
        changed
    }

    fn accept(&mut self, key: CacheKey, result: Result<Protocol, String>) {
        match result {
            Ok(p) => {
                self.encodes += 1;
                self.cache = Some((key, p));
            }
            Err(e) => self.switch_off(e),
        }
    }

    fn switch_off(&mut self, why: String) {
        if let Some(enc) = self.encoder {
            self.note =
                format!("graphics: half-blocks ({} failed: {why})", protocol_name(enc.protocol));
        }
        *self = Self { note: std::mem::take(&mut self.note), ..Self::halfblocks() };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::screens::frames::ImageView;
    use crate::tui::widgets::graphics::raster::tests::{gradient, marker};
    use ratatui::layout::Rect;
    use ratatui::style::{Color, Style};
    use std::time::Duration;

    fn render_once(
        gfx: &mut GraphicsState,
        image: &Arc<FrameImage>,
        m: Mapping,
        markers: &[Marker],
    ) -> Buffer {
        let mut buf = Buffer::empty(Rect::new(0, 0, 30, 10));
        assert!(gfx.render(image, 0, m, markers, &mut buf));
        buf
    }

    #[test]
    fn encodes_again_only_when_something_shown_changed() {
        let image = Arc::new(gradient());
        let area = Rect::new(0, 0, 20, 5);
        let m = Mapping::new(area, 40, 20, &ImageView::default()).unwrap();
        let mut markers = vec![marker(10.0, 10.0, "•", Style::new().fg(Color::LightGreen))];
        let mut gfx = GraphicsState::with_protocol(ProtocolType::Kitty, (4, 8), false);
        render_once(&mut gfx, &image, m, &markers);
        render_once(&mut gfx, &image, m, &markers);
        assert_eq!(gfx.encodes(), 1, "nothing changed: the cached encoding is reused");
        markers[0].x += 0.25;
        render_once(&mut gfx, &image, m, &markers);
        assert_eq!(gfx.encodes(), 2, "a marker moved");
        let zoomed = Mapping::new(area, 40, 20, &ImageView { zoom: 2.0, center: None }).unwrap();
        render_once(&mut gfx, &image, zoomed, &markers);
        assert_eq!(gfx.encodes(), 3, "the view changed");
        let redecoded = Arc::new(gradient());
        render_once(&mut gfx, &redecoded, zoomed, &markers);
        assert_eq!(gfx.encodes(), 4, "a new image");
        render_once(&mut gfx, &redecoded, zoomed, &markers);
        assert_eq!(gfx.encodes(), 4);
        // Half-blocks draw nothing here and never encode.
        let mut hb = GraphicsState::halfblocks();
        let mut buf = Buffer::empty(Rect::new(0, 0, 30, 10));
        assert!(!hb.render(&image, 0, m, &markers, &mut buf));
        assert_eq!(hb.encodes(), 0);
        assert_eq!(
            GraphicsState::with_protocol(ProtocolType::Sixel, (0, 16), false).protocol(),
            None
        );
    }

    #[test]
    fn background_encoding_keeps_the_old_image_until_the_new_one_arrives() {
        let image = Arc::new(gradient());
        let area = Rect::new(0, 0, 20, 5);
        let m = Mapping::new(area, 40, 20, &ImageView::default()).unwrap();
        let mut markers = vec![marker(10.0, 10.0, "•", Style::new().fg(Color::LightGreen))];
        let mut gfx =
            GraphicsState::with_protocol(ProtocolType::Sixel, (4, 8), false).in_background();
        let wait = |gfx: &mut GraphicsState| {
            let start = std::time::Instant::now();
            while !gfx.poll() {
                assert!(start.elapsed() < Duration::from_secs(5), "encoder never answered");
                std::thread::sleep(Duration::from_millis(1));
            }
        };
        let mut buf = Buffer::empty(Rect::new(0, 0, 30, 10));
        // Nothing to show yet: the half-blocks stay.
        assert!(!gfx.render(&image, 0, m, &markers, &mut buf));
        wait(&mut gfx);
        assert!(gfx.render(&image, 0, m, &markers, &mut buf));
        let first = buf[(0, 0)].symbol().to_string();
        assert_eq!(gfx.encodes(), 1);
        // A marker moves: the previous image is drawn until its replacement is polled.
        markers[0].y += 3.0;
        let mut buf = Buffer::empty(Rect::new(0, 0, 30, 10));
        assert!(gfx.render(&image, 0, m, &markers, &mut buf));
        assert_eq!(buf[(0, 0)].symbol(), first);
        wait(&mut gfx);
        assert!(gfx.render(&image, 0, m, &markers, &mut buf));
        assert_ne!(buf[(0, 0)].symbol(), first);
        assert_eq!(gfx.encodes(), 2);
        assert!(!gfx.poll(), "nothing pending");
    }

    #[test]
    fn kitty_sixel_and_iterm2_sequences_start_correctly() {
        let image = Arc::new(gradient());
        let area = Rect::new(2, 1, 10, 4);
        let m = Mapping::new(area, 40, 20, &ImageView::default()).unwrap();
        let markers = [marker(20.0, 10.0, "◆", Style::new().fg(Color::Yellow))];

        let mut kitty = GraphicsState::with_protocol(ProtocolType::Kitty, (6, 12), false);
        let buf = render_once(&mut kitty, &image, m, &markers);
        let first = buf[(2, 1)].symbol();
        // Transmit once (RGBA, 60×48 px, virtual placement), then placeholders everywhere.
        assert!(first.starts_with("\x1b_Gq=2,i="), "{:?}", &first[..20]);
        assert!(first.contains("a=T,U=1,f=32,t=d,s=60,v=48,"));
        assert!(buf[(11, 4)].symbol().starts_with('\u{10EEEE}'));
        assert_eq!(buf[(12, 4)].symbol(), " ", "nothing outside the area");
        // A second draw of the same view does not transmit again.
        let again = render_once(&mut kitty, &image, m, &markers);
        assert!(again[(2, 1)].symbol().starts_with('\u{10EEEE}'));

        let mut sixel = GraphicsState::with_protocol(ProtocolType::Sixel, (6, 12), false);
        let buf = render_once(&mut sixel, &image, m, &markers);
        let data = buf[(2, 1)].symbol();
        // Erase the area row by row, then a DCS sixel sequence ending in ST.
        assert!(data.starts_with("\x1b[10X\x1b[1B"), "{:?}", &data[..20]);
        let dcs = data.find("\x1bP").expect("sixel DCS");
        assert!(data[dcs..].contains('q') && data.ends_with("\x1b\\"));

        let mut tmux = GraphicsState::with_protocol(ProtocolType::Sixel, (6, 12), true);
        let buf = render_once(&mut tmux, &image, m, &markers);
        assert!(buf[(2, 1)].symbol().starts_with("\x1bPtmux;"), "tmux passthrough");

        let mut iterm = GraphicsState::with_protocol(ProtocolType::Iterm2, (6, 12), false);
        let buf = render_once(&mut iterm, &image, m, &markers);
        assert!(buf[(2, 1)].symbol().contains("\x1b]1337;File=inline=1;"));
    }
}
