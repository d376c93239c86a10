//! Terminal graphics protocols (Sixel, Kitty, iTerm2 through `ratatui-image`) for the frame
//! image: choosing one at startup, rasterising the view and its markers, caching the encoding.
//!
//! Start at `GraphicsState::detect` (run loop, once, after the alternate screen is entered and
//! before events are read) and `GraphicsState::render`. Half-blocks stay the default: auto
//! mode never uses a protocol inside tmux or over SSH, and falls back when the terminal does
//! not answer the query. The protocol image covers exactly the `Mapping`'s area, cell for
//! cell, so mouse hit-testing through `Mapping` is unchanged.

use crate::tui::app::FrameImage;
use crate::tui::widgets::halfblock::{Mapping, Marker};
use image::{DynamicImage, RgbImage};
use ratatui::buffer::Buffer;
use ratatui::layout::Size;
use ratatui::style::{Color, Modifier};
use ratatui::widgets::Widget;
use ratatui_image::picker::cap_parser::QueryStdioOptions;
use ratatui_image::picker::{Picker, ProtocolType};
use ratatui_image::protocol::Protocol;
use ratatui_image::protocol::iterm2::Iterm2;
use ratatui_image::protocol::kitty::Kitty;
use ratatui_image::protocol::sixel::Sixel;
use std::str::FromStr;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::Duration;

/// Environment variable read when `--graphics` is not given.
pub const GRAPHICS_ENV: &str = "LIPMAP_GRAPHICS";

/// How long auto mode waits for the terminal's answer. Local terminals answer within a few
/// milliseconds; a silent one must not hold the UI back.
const AUTO_QUERY_TIMEOUT: Duration = Duration::from_millis(300);
/// An explicit protocol only needs the cell size from the query; allow a slower link.
const FORCED_QUERY_TIMEOUT: Duration = Duration::from_millis(1000);
/// Cell size assumed when the terminal does not report one (a common 1:2 font).
const DEFAULT_CELL_PX: (u16, u16) = (10, 20);

/// What the user asked for with `--graphics` or `LIPMAP_GRAPHICS`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum GraphicsChoice {
    /// Query the terminal; never inside tmux or over SSH.
    #[default]
    Auto,
    Halfblocks,
    Sixel,
    Kitty,
    Iterm2,
}

impl GraphicsChoice {
    pub const NAMES: &'static str = "auto, halfblocks, sixel, kitty, iterm2";

    /// The choice from the command-line flag, else from `LIPMAP_GRAPHICS` (`env_value`),
    /// else auto. An empty variable counts as unset.
    ///
    /// # Errors
    /// When the variable holds an unknown name (the message names the variable).
    pub fn resolve(flag: Option<Self>, env_value: Option<&str>) -> Result<Self, String> {
        if let Some(c) = flag {
            return Ok(c);
        }
        match env_value.map(str::trim).filter(|v| !v.is_empty()) {
            None => Ok(Self::Auto),
            Some(v) => v.parse().map_err(|e| format!("{GRAPHICS_ENV}={v}: {e}")),
        }
    }

    /// `resolve` with the process's `LIPMAP_GRAPHICS`.
    ///
    /// # Errors
    /// As `resolve`.
    pub fn from_flag_or_env(flag: Option<Self>) -> Result<Self, String> {
        Self::resolve(flag, std::env::var(GRAPHICS_ENV).ok().as_deref())
    }
}

impl FromStr for GraphicsChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "halfblocks" | "half-blocks" | "halfblock" => Ok(Self::Halfblocks),
            "sixel" => Ok(Self::Sixel),
            "kitty" => Ok(Self::Kitty),
            "iterm2" | "iterm" => Ok(Self::Iterm2),
            other => Err(format!("unknown graphics mode `{other}` (expected {})", Self::NAMES)),
        }
    }
}

/// The parts of the environment the decision depends on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TermEnv {
    /// `$TMUX` is set: images need passthrough, which tmux often drops.
    pub tmux: bool,
    /// `$SSH_CONNECTION` or `$SSH_TTY` is set: every image crosses the network.
    pub ssh: bool,
}

impl TermEnv {
    /// From a variable lookup (empty values count as unset), so tests need no process env.
    pub fn from_lookup(var: impl Fn(&str) -> Option<String>) -> Self {
        let set = |n: &str| var(n).is_some_and(|v| !v.is_empty());
        Self { tmux: set("TMUX"), ssh: set("SSH_CONNECTION") || set("SSH_TTY") }
    }

    pub fn from_process() -> Self {
        Self::from_lookup(|n| std::env::var(n).ok())
    }
}

/// What to do at startup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Half-blocks: asked for (`None`), or auto mode's reason, shown in the status line.
    HalfBlocks(Option<&'static str>),
    /// Ask the terminal which protocol it speaks (auto mode on a local terminal).
    Query,
    /// Use this protocol (asked for explicitly); the query only supplies the cell size.
    Force(ProtocolType),
}

/// The startup decision for a choice in an environment. Explicit protocols are honoured
/// inside tmux and over SSH; auto mode is not, since a protocol there is slow or broken.
pub fn decide(choice: GraphicsChoice, env: TermEnv) -> Decision {
    match choice {
        GraphicsChoice::Halfblocks => Decision::HalfBlocks(None),
        GraphicsChoice::Sixel => Decision::Force(ProtocolType::Sixel),
        GraphicsChoice::Kitty => Decision::Force(ProtocolType::Kitty),
        GraphicsChoice::Iterm2 => Decision::Force(ProtocolType::Iterm2),
        GraphicsChoice::Auto if env.tmux => Decision::HalfBlocks(Some("inside tmux")),
        GraphicsChoice::Auto if env.ssh => Decision::HalfBlocks(Some("over SSH")),
        GraphicsChoice::Auto => Decision::Query,
    }
}

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
struct Encoder {
    protocol: ProtocolType,
    /// Pixels per cell (width, height).
    cell_px: (u16, u16),
    /// Wrap sequences in tmux passthrough.
    tmux: bool,
    /// One Kitty image id for the whole run: re-transmitting under it replaces the old image
    /// in the terminal's memory instead of piling up new ones.
    kitty_id: u32,
}

impl Encoder {
    /// Rasterises the view `key` describes and encodes it, sized to the mapping's area.
    fn encode(&self, image: &FrameImage, key: &CacheKey) -> Result<Protocol, String> {
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
struct Job {
    key: CacheKey,
    image: Arc<FrameImage>,
}

type Encoded = (CacheKey, Result<Protocol, String>);

/// The encoder thread's ends: it takes the newest job, drops older queued ones, and replies.
struct Background {
    jobs: Sender<Job>,
    done: Receiver<Encoded>,
}

impl Background {
    fn start(encoder: Encoder) -> Self {
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

/// The chosen protocol and its cached image. Owned by the run loop (a terminal resource,
/// not app state); `halfblocks()` is inert and what tests and `TestBackend` use.
///
/// Encoding costs milliseconds (Sixel tens of them), so the run loop's state encodes on a
/// thread (`in_background`): until a view's encoding arrives the previous image stays (or
/// the half-blocks, when the area changed) and `poll` says when to redraw.
pub struct GraphicsState {
    encoder: Option<Encoder>,
    background: Option<Background>,
    /// The key last sent to the encoder thread and not yet answered.
    pending: Option<CacheKey>,
    cache: Option<(CacheKey, Protocol)>,
    encodes: u64,
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

pub fn protocol_name(p: ProtocolType) -> &'static str {
    match p {
        ProtocolType::Halfblocks => "half-blocks",
        ProtocolType::Sixel => "sixel",
        ProtocolType::Kitty => "kitty",
        ProtocolType::Iterm2 => "iterm2",
    }
}

/// The view of `img` that `m` shows, as pixels: `m.area` cells of `cell_px` pixels each,
/// nearest image pixel per output pixel (black outside the image), markers drawn on top.
///
/// A display pixel of `Mapping` is one cell wide and half a cell high, so output pixel
/// `(u, v)` is display point `((u+½)/cw, (v+½)/(ch/2))`: the same cells show the same image
/// points as with half-blocks, and `Mapping::cell_to_image` stays right for the mouse.
pub fn rasterise_view(
    img: &FrameImage,
    m: &Mapping,
    cell_px: (u16, u16),
    markers: &[Marker],
) -> RgbImage {
    let (cw, ch) = (f64::from(cell_px.0.max(1)), f64::from(cell_px.1.max(1)));
    let out_w = u32::from(m.area.width) * u32::from(cell_px.0.max(1));
    let out_h = u32::from(m.area.height) * u32::from(cell_px.1.max(1));
    let mut out = RgbImage::new(out_w, out_h);
    let complete = img.rgb.len() >= 3 * img.width as usize * img.height as usize;
    if complete {
        let index = |p: f64, size: u32| {
            // Pixel i covers [i - ½, i + ½).
            let i = (p + 0.5).floor();
            (i >= 0.0 && i < f64::from(size)).then_some(i as usize)
        };
        let cols: Vec<Option<usize>> = (0..out_w)
            .map(|u| index(m.display_to_image((f64::from(u) + 0.5) / cw, 0.0).0, img.width))
            .collect();
        let rows: Vec<Option<usize>> = (0..out_h)
            .map(|v| index(m.display_to_image(0.0, (f64::from(v) + 0.5) * 2.0 / ch).1, img.height))
            .collect();
        let w = img.width as usize;
        for (v, row) in out.rows_mut().enumerate() {
            let Some(y) = rows[v] else { continue };
            for (px, x) in row.zip(&cols) {
                if let Some(x) = x {
                    let i = 3 * (y * w + x);
                    px.0.copy_from_slice(&img.rgb[i..i + 3]);
                }
            }
        }
    }
    let radius = (cw.min(ch / 2.0) * 0.3).max(1.5);
    for mk in markers {
        let (dx, dy) = m.image_to_display(mk.x, mk.y);
        draw_marker(&mut out, (dx * cw, dy * ch / 2.0), mk, radius);
    }
    out
}

/// Outline shapes standing for the half-block marker symbols.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Disc,
    Diamond,
    HollowDiamond,
    Cross,
    Plus,
    Square,
}

impl Shape {
    fn of_symbol(symbol: &str) -> Self {
        match symbol {
            "•" | "●" | "·" | "o" => Self::Disc,
            "◆" => Self::Diamond,
            "◇" => Self::HollowDiamond,
            "×" | "x" => Self::Cross,
            "+" => Self::Plus,
            _ => Self::Square,
        }
    }

    /// Whether the offset `(dx, dy)` from the centre is inside the shape of radius `r` and
    /// stroke `t`, grown outwards by `grow` (for the halo).
    fn contains(self, dx: f64, dy: f64, r: f64, t: f64, grow: f64) -> bool {
        let (ax, ay) = (dx.abs(), dy.abs());
        match self {
            Self::Disc => dx.hypot(dy) <= r + grow,
            Self::Square => ax.max(ay) <= r + grow,
            Self::Diamond => ax + ay <= 1.3 * r + grow,
            Self::HollowDiamond => {
                let d = ax + ay;
                d <= 1.3 * r + grow && d >= 1.3 * r - t - grow
            }
            Self::Cross => {
                // Distance to the nearer diagonal.
                let off = (ax - ay).abs() / std::f64::consts::SQRT_2;
                off <= t / 2.0 + grow && ax.max(ay) <= r + grow
            }
            Self::Plus => {
                let bar =
                    |along: f64, across: f64| along <= 1.2 * r + grow && across <= t / 2.0 + grow;
                bar(ax, ay) || bar(ay, ax)
            }
        }
    }
}

/// Draws one marker into `out` at pixel position `centre` (continuous, pixel centres at
/// `i + ½`). The shape follows the symbol, the fill its foreground colour (halved when
/// DIM, larger when BOLD); a halo in its background colour, or a dark one, keeps it
/// visible on any image. `radius` is the base size in pixels. Parts outside are clipped.
pub fn draw_marker(out: &mut RgbImage, centre: (f64, f64), mk: &Marker, radius: f64) {
    let shape = Shape::of_symbol(mk.symbol);
    let mut r = radius;
    if mk.symbol == "·" {
        r *= 0.6;
    }
    if mk.symbol == "●" {
        r *= 1.4;
    }
    if mk.style.add_modifier.contains(Modifier::BOLD) {
        r *= 1.3;
    }
    let t = (r * 0.6).max(1.0);
    let mut fill = colour_rgb(mk.style.fg.unwrap_or(Color::White));
    if mk.style.add_modifier.contains(Modifier::DIM) {
        fill = fill.map(|c| c / 2);
    }
    let (halo, grow) = match mk.style.bg {
        Some(bg) => (colour_rgb(bg), (r * 0.4).max(1.5)),
        None => ([0, 0, 0], 1.0),
    };
    let reach = 1.5 * r + grow + t + 1.0;
    let (w, h) = (f64::from(out.width()), f64::from(out.height()));
    let x0 = (centre.0 - reach).floor().max(0.0);
    let x1 = (centre.0 + reach).ceil().min(w);
    let y0 = (centre.1 - reach).floor().max(0.0);
    let y1 = (centre.1 + reach).ceil().min(h);
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    for y in y0 as u32..y1 as u32 {
        for x in x0 as u32..x1 as u32 {
            let dx = f64::from(x) + 0.5 - centre.0;
            let dy = f64::from(y) + 0.5 - centre.1;
            if shape.contains(dx, dy, r, t, 0.0) {
                out.put_pixel(x, y, image::Rgb(fill));
            } else if shape.contains(dx, dy, r, t, grow) {
                out.put_pixel(x, y, image::Rgb(halo));
            }
        }
    }
}

/// An RGB value for a terminal colour (the xterm defaults for the 16 named colours).
pub fn colour_rgb(c: Color) -> [u8; 3] {
    const ANSI: [[u8; 3]; 16] = [
        [0, 0, 0],
        [205, 0, 0],
        [0, 205, 0],
        [205, 205, 0],
        [0, 0, 238],
        [205, 0, 205],
        [0, 205, 205],
        [229, 229, 229],
        [127, 127, 127],
        [255, 0, 0],
        [0, 255, 0],
        [255, 255, 0],
        [92, 92, 255],
        [255, 0, 255],
        [0, 255, 255],
        [255, 255, 255],
    ];
    match c {
        Color::Rgb(r, g, b) => [r, g, b],
        Color::Reset | Color::White => ANSI[15],
        Color::Black => ANSI[0],
        Color::Red => ANSI[1],
        Color::Green => ANSI[2],
        Color::Yellow => ANSI[3],
        Color::Blue => ANSI[4],
        Color::Magenta => ANSI[5],
        Color::Cyan => ANSI[6],
        Color::Gray => ANSI[7],
        Color::DarkGray => ANSI[8],
        Color::LightRed => ANSI[9],
        Color::LightGreen => ANSI[10],
        Color::LightYellow => ANSI[11],
        Color::LightBlue => ANSI[12],
        Color::LightMagenta => ANSI[13],
        Color::LightCyan => ANSI[14],
        Color::Indexed(i) if i < 16 => ANSI[usize::from(i)],
        Color::Indexed(i) if i < 232 => {
            // The 6×6×6 colour cube.
            let level = |v: u8| if v == 0 { 0 } else { 55 + 40 * v };
            let i = i - 16;
            [level(i / 36), level((i / 6) % 6), level(i % 6)]
        }
        Color::Indexed(i) => {
            let g = 8 + 10 * (i - 232);
            [g, g, g]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::app::ImageView;
    use ratatui::layout::Rect;
    use ratatui::style::Style;

    fn env(tmux: bool, ssh: bool) -> TermEnv {
        TermEnv { tmux, ssh }
    }

    #[test]
    fn auto_queries_only_on_a_local_plain_terminal() {
        use GraphicsChoice as C;
        let forced = [
            (C::Sixel, ProtocolType::Sixel),
            (C::Kitty, ProtocolType::Kitty),
            (C::Iterm2, ProtocolType::Iterm2),
        ];
        for (tmux, ssh) in [(false, false), (true, false), (false, true), (true, true)] {
            let e = env(tmux, ssh);
            // Explicit requests win everywhere, tmux and SSH included.
            for (c, p) in forced {
                assert_eq!(decide(c, e), Decision::Force(p));
            }
            assert_eq!(decide(C::Halfblocks, e), Decision::HalfBlocks(None));
            let auto = decide(C::Auto, e);
            match (tmux, ssh) {
                (false, false) => assert_eq!(auto, Decision::Query),
                (true, _) => assert_eq!(auto, Decision::HalfBlocks(Some("inside tmux"))),
                (false, true) => assert_eq!(auto, Decision::HalfBlocks(Some("over SSH"))),
            }
        }
    }

    #[test]
    fn environment_variables_feed_the_decision() {
        let vars = |pairs: &'static [(&'static str, &'static str)]| {
            move |n: &str| pairs.iter().find(|(k, _)| *k == n).map(|(_, v)| v.to_string())
        };
        assert_eq!(TermEnv::from_lookup(vars(&[])), env(false, false));
        assert_eq!(
            TermEnv::from_lookup(vars(&[("TMUX", "/tmp/tmux-0/default,1,0")])),
            env(true, false)
        );
        assert_eq!(
            TermEnv::from_lookup(vars(&[("SSH_CONNECTION", "10.0.0.2 5 10.0.0.1 22")])),
            env(false, true)
        );
        assert_eq!(TermEnv::from_lookup(vars(&[("SSH_TTY", "/dev/pts/3")])), env(false, true));
        // Empty values are unset (e.g. `TMUX= lipmap tui …`).
        assert_eq!(TermEnv::from_lookup(vars(&[("TMUX", ""), ("SSH_TTY", "")])), env(false, false));

        use GraphicsChoice as C;
        // Flag beats variable; variable beats the default; empty variable is unset.
        assert_eq!(C::resolve(Some(C::Halfblocks), Some("kitty")), Ok(C::Halfblocks));
        assert_eq!(C::resolve(None, Some("Kitty")), Ok(C::Kitty));
        assert_eq!(C::resolve(None, Some(" sixel ")), Ok(C::Sixel));
        assert_eq!(C::resolve(None, Some("")), Ok(C::Auto));
        assert_eq!(C::resolve(None, None), Ok(C::Auto));
        let err = C::resolve(None, Some("png")).unwrap_err();
        assert!(err.contains("LIPMAP_GRAPHICS=png") && err.contains("kitty"), "{err}");
        // Over SSH with the variable set to a protocol, it is used; set to auto, it is not.
        let ssh = env(false, true);
        assert_eq!(
            decide(C::resolve(None, Some("sixel")).unwrap(), ssh),
            Decision::Force(ProtocolType::Sixel)
        );
        assert!(matches!(
            decide(C::resolve(None, Some("auto")).unwrap(), ssh),
            Decision::HalfBlocks(_)
        ));
    }

    /// A 40×20 image whose pixel `(x, y)` is `(6x, 12y, 77)`, so each pixel is identifiable.
    fn gradient() -> FrameImage {
        let (w, h) = (40u32, 20u32);
        let mut rgb = Vec::new();
        for y in 0..h {
            for x in 0..w {
                rgb.extend([(6 * x) as u8, (12 * y) as u8, 77]);
            }
        }
        FrameImage { width: w, height: h, rgb }
    }

    fn marker(x: f64, y: f64, symbol: &'static str, style: Style) -> Marker {
        Marker { x, y, symbol, style }
    }

    #[test]
    fn markers_are_rasterised_into_the_view_pixels() {
        let img = FrameImage { width: 40, height: 20, rgb: vec![100; 40 * 20 * 3] };
        // 20×5 cells of 4×8 px: display 20×10, the image fits at scale 0.5; 80×40 px out.
        let area = Rect::new(0, 0, 20, 5);
        let m = Mapping::new(area, 40, 20, &ImageView::default()).unwrap();
        let cell = (4, 8);
        let green = marker(10.0, 10.0, "•", Style::new().fg(Color::LightGreen));
        let dim =
            marker(30.0, 10.0, "×", Style::new().fg(Color::Yellow).add_modifier(Modifier::DIM));
        let selected =
            marker(20.0, 4.0, "●", Style::new().fg(Color::LightMagenta).bg(Color::White));
        let out = rasterise_view(&img, &m, cell, &[green.clone(), dim, selected]);
        assert_eq!(out.dimensions(), (80, 40));
        // Image point (x, y) lands at output pixel (dx·4, dy·4): scale 0.5 display px per
        // image px, 4 output px per display px horizontally, 8/2 vertically.
        let at = |x: f64, y: f64| {
            let (dx, dy) = m.image_to_display(x, y);
            *out.get_pixel((dx * 4.0) as u32, (dy * 4.0) as u32)
        };
        assert_eq!(at(10.0, 10.0).0, [0, 255, 0]);
        assert_eq!(at(30.0, 10.0).0, [102, 102, 0], "DIM halves the colour");
        assert_eq!(at(20.0, 4.0).0, [255, 0, 255]);
        // Away from markers: the image itself.
        assert_eq!(at(2.0, 17.0).0, [100, 100, 100]);
        // Scanning right from a marker's centre: its fill, then its halo, then the image.
        let colours_right_of = |x: f64, y: f64| {
            let (dx, dy) = m.image_to_display(x, y);
            let (cx, cy) = ((dx * 4.0) as u32, (dy * 4.0) as u32);
            let mut seen: Vec<[u8; 3]> = Vec::new();
            for px in cx..80 {
                let c = out.get_pixel(px, cy).0;
                if seen.last() != Some(&c) {
                    seen.push(c);
                }
            }
            seen
        };
        // The selected marker's white background shows as a halo around it…
        assert_eq!(colours_right_of(20.0, 4.0)[..3], [[255, 0, 255], [255; 3], [100; 3]]);
        // …and a plain marker's halo is dark, so it stays visible on a bright image.
        assert_eq!(colours_right_of(10.0, 10.0)[..3], [[0, 255, 0], [0; 3], [100; 3]]);
        // Markers outside the view are clipped without a panic.
        let off = rasterise_view(&img, &m, cell, &[marker(-500.0, 9e9, "◆", Style::new())]);
        assert!(off.pixels().all(|p| p.0 == [100, 100, 100]));
    }

    #[test]
    fn protocol_pixels_match_the_mouse_mapping_when_zoomed() {
        let img = gradient();
        let area = Rect::new(3, 2, 16, 6);
        let view = ImageView { zoom: 2.5, center: Some((25.0, 8.0)) };
        let m = Mapping::new(area, img.width, img.height, &view).unwrap();
        let cell = (7u16, 15u16);
        let out = rasterise_view(&img, &m, cell, &[]);
        for (col, row) in [(3u16, 2u16), (10, 4), (18, 7), (12, 2)] {
            // The image point a click on this cell selects…
            let (x, y) = m.cell_to_image(col, row).unwrap();
            // …is the image pixel the protocol image shows at that cell's centre.
            let px = u32::from(col - area.x) * 7 + 3;
            let py = u32::from(row - area.y) * 15 + 7;
            let shown = out.get_pixel(px, py).0;
            let (ix, iy) = ((x + 0.5).floor(), (y + 0.5).floor());
            if ix < 0.0 || iy < 0.0 || ix >= 40.0 || iy >= 20.0 {
                assert_eq!(shown, [0, 0, 0]);
            } else {
                assert_eq!(shown, img.pixel(ix as u32, iy as u32), "cell {col},{row}");
            }
        }
    }

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
