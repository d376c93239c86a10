//! `App`: the TUI's whole state as plain data (no widgets, no terminal handles), and the small
//! value types it is made of: views, overlays, edit history, frame images, analysis tables.
//!
//! Only `update::update` changes an `App`; views read it. Side effects (decode a frame, run
//! a fit, save) are queued in `App::effects` and carried out by the run loop's workers.

pub use super::head_state::{
    HeadFrame, HeadFraming, HeadSetup, HeadView, PreparedHead, TransferredHeads,
};
pub use super::save_state::SaveState;
use crate::alignment::Alignment;
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::edit::PointChange;
use crate::landmarks::flags::{FlagThresholds, FrameFlags, MeasureSeries};
use crate::landmarks::{N_LANDMARKS, Track};
use crate::math::Point2;
use crate::measure::profile::{ProfileSetup, ProfileTrack};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

/// A decoded RGB frame, row-major, 3 bytes a pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl FrameImage {
    /// The pixel at `(x, y)`, black outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        if x >= self.width || y >= self.height {
            return [0, 0, 0];
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// Where frame images come from. Implementations must be cheap to share across threads;
/// `load` runs on a worker thread, never on the UI thread.
pub trait FrameProvider: Send + Sync {
    /// Decodes the image of frame number `frame`.
    ///
    /// # Errors
    /// When the frame does not exist or cannot be decoded.
    fn load(&self, frame: usize) -> anyhow::Result<FrameImage>;
}

/// The five views, switched with 1–5.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum View {
    #[default]
    Frames,
    Head,
    Fit,
    Analysis,
    /// The side view's lip profile (P), when the clip has a side view.
    Side,
}

/// What a prompt asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PromptKind {
    GotoPoint,
    GotoFrame,
    Propagate,
    GotoLabel,
}

impl PromptKind {
    pub fn question(self) -> &'static str {
        match self {
            Self::GotoPoint => "point number (0-67)",
            Self::GotoFrame => "frame number",
            Self::Propagate => "propagate to how many next frames (Enter = 10)",
            Self::GotoLabel => "landmark to label (0-67)",
        }
    }
}

/// Overlays stack over the view; the top one sees keys first.
#[derive(Clone, Debug, PartialEq)]
pub enum Overlay {
    Help { scroll: u16 },
    Prompt { kind: PromptKind, input: String },
}

/// Which points an edit moves together.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scope {
    #[default]
    Point,
    Group,
    Mouth,
    All,
}

impl Scope {
    pub fn next(self) -> Self {
        match self {
            Self::Point => Self::Group,
            Self::Group => Self::Mouth,
            Self::Mouth => Self::All,
            Self::All => Self::Point,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Self::Point => "point",
            Self::Group => "group",
            Self::Mouth => "mouth",
            Self::All => "all",
        }
    }
}

/// Image zoom and pan: `zoom` 1 fits the frame to the view; `center` is the image pixel
/// shown at the centre of the view (None = image centre). Kept across frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageView {
    pub zoom: f64,
    pub center: Option<(f64, f64)>,
}

impl Default for ImageView {
    fn default() -> Self {
        Self { zoom: 1.0, center: None }
    }
}

/// One undoable edit.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    Points(Vec<PointChange>),
    Reviewed {
        frame: usize,
        now: bool,
    },
    /// Landmark map changes, applied together (one label, or all suggestions at once).
    Labels(Vec<LabelChange>),
    /// The user's upper-lip point of a side-view frame (None = the automatic one).
    Profile {
        side_frame: usize,
        before: Option<Point2>,
        after: Option<Point2>,
    },
}

/// The clip's side view for protrusion: the once-per-clip setup, the automatic profile
/// points with the user's corrections, and the decoded side frames.
#[derive(Clone, Debug, PartialEq)]
pub struct SideView {
    pub setup: ProfileSetup,
    pub track: ProfileTrack,
    pub fps: f64,
    pub offset_s: f64,
    pub n_frames: usize,
    pub images: BTreeMap<usize, Arc<FrameImage>>,
    pub image_errors: BTreeMap<usize, String>,
}

impl SideView {
    /// Side frames kept decoded (a few around the current one).
    pub const CACHE: usize = 8;

    /// The side frame shown with front frame `frame` (nearest in time, after the offset).
    pub fn frame_for(&self, frame: usize, front_fps: f64) -> Option<usize> {
        let k = ((frame as f64 / front_fps - self.offset_s) * self.fps).round();
        (k >= 0.0 && (k as usize) < self.n_frames).then_some(k as usize)
    }

    /// P per front frame (normalised when a nose length is known), corrections applied.
    pub fn p_series(&self, n_front: usize, front_fps: f64) -> Vec<Option<f64>> {
        crate::workflow::resample_to_front(front_fps, self.fps, self.offset_s, n_front, |k| {
            self.track.effective(k, &self.setup).and_then(|p| p.p_norm.or(p.p_px))
        })
    }

    /// Sets or clears (None) the user's point of side frame `k`.
    pub fn set_correction(&mut self, k: usize, point: Option<Point2>) {
        match point {
            Some(p) => self.track.correct(k, p),
            None => {
                self.track.clear_correction(k);
            }
        }
    }
}

/// Where the side view stands: not in the clip, being measured, ready, or failed.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SideState {
    #[default]
    None,
    Measuring,
    Ready(Box<SideView>),
    Failed(String),
}

impl SideState {
    pub fn view(&self) -> Option<&SideView> {
        match self {
            Self::Ready(v) => Some(v),
            _ => None,
        }
    }

    pub fn view_mut(&mut self) -> Option<&mut SideView> {
        match self {
            Self::Ready(v) => Some(v),
            _ => None,
        }
    }
}

/// One landmark's vertex before and after a labelling edit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LabelChange {
    pub landmark: usize,
    pub before: Option<usize>,
    pub after: Option<usize>,
}

/// One analysis table: named columns (the first is the row label), rows of display text with
/// numeric sort keys, rows optionally tied to a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisTable {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<AnalysisRow>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisRow {
    /// One display string per column.
    pub cells: Vec<String>,
    /// Per column: the number to sort by, when the cell is numeric.
    pub keys: Vec<Option<f64>>,
    /// The frame Enter jumps to (a worst frame, or the first frame of a phoneme).
    pub frame: Option<usize>,
    /// The session's clip Enter opens (a sentence of the quality tables), when not the
    /// open one.
    pub clip: Option<usize>,
}

impl AnalysisRow {
    /// A row of a text label and numbers (3 decimals).
    pub fn numbers(label: &str, values: &[f64], frame: Option<usize>) -> Self {
        let mut cells = vec![label.to_string()];
        cells.extend(values.iter().map(|v| format!("{v:.3}")));
        let mut keys = vec![None];
        keys.extend(values.iter().map(|v| Some(*v)));
        Self { cells, keys, frame, clip: None }
    }
}

/// A measure's trajectory over the clip, video against the fitted head, by frame number.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    pub name: String,
    pub video: Vec<(f64, f64)>,
    pub model: Vec<(f64, f64)>,
}

/// The speech-driven head's trajectories for the analysis charts: being driven from the
/// clip's audio (on a worker), ready (min–max normalised as the others, by measure name), or
/// absent, with the reason the status line gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SpeechSeries {
    #[default]
    Pending,
    Ready(Vec<(String, Vec<(f64, f64)>)>),
    Absent(String),
}

impl SpeechSeries {
    /// The series of measure `name`, when ready.
    pub fn of(&self, name: &str) -> Option<&[(f64, f64)]> {
        match self {
            Self::Ready(all) => all.iter().find(|(n, _)| n == name).map(|(_, s)| s.as_slice()),
            _ => None,
        }
    }
}

/// What the analysis view shows; filled by the session bridge from `eval`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalysisData {
    pub tables: Vec<AnalysisTable>,
    pub trajectories: Vec<Trajectory>,
    /// What the analysis worked around (shown in the status line).
    pub warnings: Vec<String>,
}

/// Analysis view cursor and sorting.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalysisView {
    pub table: usize,
    pub row: usize,
    /// Column index to sort by.
    pub sort_column: usize,
    pub descending: bool,
}

/// The fit's progress and results.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitState {
    /// Generation of the newest requested fit; replies from older ones are dropped.
    pub generation: u64,
    pub running: bool,
    pub progress: (usize, usize),
    /// By frame number.
    pub fits: BTreeMap<usize, FrameFit>,
    /// Frames edited since their fit (re-fit only these).
    pub stale: BTreeSet<usize>,
    pub error: Option<String>,
}

/// Work for the run loop to hand to workers or the session.
#[derive(Clone, Debug, PartialEq)]
pub enum Effect {
    /// Decode these frames, first one first (the rest are prefetch).
    LoadFrames(Vec<usize>),
    /// Fit these frames (all when `None`) of the current track.
    Fit {
        generation: u64,
        frames: Option<Vec<usize>>,
    },
    /// Write the corrections, reviewed set and map to the session file; the reply names
    /// `generation`.
    Save {
        generation: u64,
    },
    /// Write the session's state and these fits to its fit cache (they were fitted from the
    /// landmarks it now holds).
    StoreFits {
        fits: Vec<FrameFit>,
    },
    SaveMap,
    /// Read the session's map file.
    LoadMap,
    /// Recompute the analysis tables from the current track and fits.
    Analyse {
        generation: u64,
    },
    /// Cross-validate quality prediction over the session's sentences.
    AssessQuality,
    /// Decode this side-view frame.
    LoadSideFrame(usize),
    /// Set up the transfer onto the session's transferred head number `.0`.
    PrepareHead(usize),
    /// Transfer the current fit of `frame` onto the (set-up) head `head`.
    TransferFrame {
        head: usize,
        frame: usize,
    },
    Quit,
}

/// Everything the TUI shows and edits.
pub struct App {
    pub title: String,
    /// The tracker's landmarks as imported; never edited.
    pub tracked: Track,
    /// Effective landmarks: tracked with corrections and interpolations applied.
    pub track: Track,
    pub reviewed: BTreeSet<usize>,
    pub alignment: Option<Alignment>,
    pub fps: f64,
    /// Position in `track.frames` of the current frame.
    pub frame_pos: usize,
    pub selected: usize,
    pub scope: Scope,
    pub view: View,
    pub image_view: ImageView,
    pub overlays: Vec<Overlay>,
    pub undo: Vec<Edit>,
    pub redo: Vec<Edit>,
    /// An open undo entry a mouse drag keeps extending.
    pub dragging: bool,
    /// The current drag has already pushed its undo entry.
    pub drag_open: bool,
    /// Size of the clip's frames, known once one is decoded.
    pub image_size: Option<(u32, u32)>,
    /// Unsaved changes, the save in flight, and whether the user is leaving.
    pub save: SaveState,
    pub status: String,
    /// Decoded frames by frame number, newest last in `cache_order`.
    pub images: BTreeMap<usize, Arc<FrameImage>>,
    pub cache_order: VecDeque<usize>,
    pub cache_capacity: usize,
    pub image_errors: BTreeMap<usize, String>,
    pub flags: Vec<FrameFlags>,
    pub flag_thresholds: FlagThresholds,
    pub measures: Vec<MeasureSeries>,
    pub mesh: Option<Arc<Mesh>>,
    /// Unique mesh edges, computed once when the mesh is set (drawing reads them).
    pub mesh_edges: Arc<Vec<[u32; 2]>>,
    /// What the head views frame; recomputed with `frame_head` when mesh or model change.
    pub head_framing: HeadFraming,
    /// Vertices landmarks may be labelled on (`None`: all): not a figure's helper or joint
    /// geometry (see `io::obj::labelable_vertices`).
    pub label_candidates: Option<Arc<Vec<bool>>>,
    /// Vertices whose triangles hide what is behind them from suggestions (`None`: all): the
    /// skin, eyeballs and teeth, not see-through shells (see `io::obj::occluding_vertices`).
    pub occluders: Option<Arc<Vec<bool>>>,
    pub model: Option<Arc<MorphableModel>>,
    pub map: Option<LandmarkMap>,
    pub head: HeadView,
    pub fit_settings: FitSettings,
    pub fit: FitState,
    pub analysis: AnalysisData,
    pub analysis_view: AnalysisView,
    /// Generation of the newest requested analysis; older replies are dropped.
    pub analysis_generation: u64,
    /// The quality cross-validation's tables (SAQP over the session's sentences), kept
    /// after the clip's own analysis tables whenever those are recomputed.
    pub quality: Vec<AnalysisTable>,
    /// A quality cross-validation is running on a worker.
    pub quality_running: bool,
    /// Where in the quality tables the previous clip left the cursor (table counted from
    /// the first quality table), until this clip's own tables arrive in front of them.
    pub quality_view: Option<AnalysisView>,
    /// The speech-driven head's series for the charts, and whether they are drawn.
    pub speech: SpeechSeries,
    pub show_speech: bool,
    /// The session's transferred heads the head view can show.
    pub heads: TransferredHeads,
    /// Playback: frames advance at the clip's rate.
    pub playing: bool,
    /// The side view (protrusion), when the clip has one.
    pub side: SideState,
    /// The session's clips by name, and which one this is.
    pub clip_names: Vec<String>,
    pub clip: usize,
    /// Set when the user asks for another clip: the run loop saves, then opens it.
    pub switch_clip: Option<usize>,
    pub term_size: (u16, u16),
    pub effects: Vec<Effect>,
}

impl App {
    /// A new app over a track; `tracked` is the tracker's original, `track` the effective one
    /// (equal when there are no corrections yet).
    pub fn new(title: impl Into<String>, tracked: Track, track: Track) -> Self {
        let mut app = Self {
            title: title.into(),
            tracked,
            track,
            reviewed: BTreeSet::new(),
            alignment: None,
            fps: 25.0,
            frame_pos: 0,
            selected: 62,
            scope: Scope::Point,
            view: View::Frames,
            image_view: ImageView::default(),
            overlays: Vec::new(),
            undo: Vec::new(),
            redo: Vec::new(),
            dragging: false,
            drag_open: false,
            image_size: None,
            save: SaveState::default(),
            status: String::new(),
            images: BTreeMap::new(),
            cache_order: VecDeque::new(),
            cache_capacity: 48,
            image_errors: BTreeMap::new(),
            flags: Vec::new(),
            flag_thresholds: FlagThresholds::default(),
            measures: Vec::new(),
            mesh: None,
            mesh_edges: Arc::new(Vec::new()),
            head_framing: HeadFraming::default(),
            label_candidates: None,
            occluders: None,
            model: None,
            map: None,
            head: HeadView::default(),
            fit_settings: FitSettings::default(),
            fit: FitState::default(),
            analysis: AnalysisData::default(),
            analysis_view: AnalysisView::default(),
            analysis_generation: 0,
            quality: Vec::new(),
            quality_running: false,
            quality_view: None,
            speech: SpeechSeries::Pending,
            show_speech: true,
            heads: TransferredHeads::default(),
            playing: false,
            side: SideState::None,
            clip_names: Vec::new(),
            clip: 0,
            switch_clip: None,
            term_size: (80, 24),
            effects: Vec::new(),
        };
        app.recompute_flags();
        app
    }

    /// Sets the head mesh and precomputes its unique edges for the wireframe.
    pub fn set_mesh(&mut self, mesh: Arc<Mesh>) {
        self.mesh_edges = Arc::new(super::head_state::wire_edges(&mesh, None));
        self.mesh = Some(mesh);
        self.frame_head();
    }

    /// Frames the head views on the face (see [`HeadFraming::of_face`]).
    pub fn frame_head(&mut self) {
        if let Some(mesh) = &self.mesh {
            self.head_framing =
                HeadFraming::of_face(mesh, self.model.as_deref(), self.map.as_ref());
        }
    }

    /// Image size for drawing: the decoded frames' size, else a box around all landmarks
    /// (so points can be drawn and edited while the first frame decodes).
    pub fn frame_dims(&self) -> (u32, u32) {
        if let Some(s) = self.image_size {
            return s;
        }
        let (mut w, mut h) = (1.0f64, 1.0f64);
        for p in self.track.frames.iter().flat_map(|f| f.points.iter()) {
            w = w.max(p.x);
            h = h.max(p.y);
        }
        ((w * 1.1).ceil() as u32, (h * 1.1).ceil() as u32)
    }

    /// Frame number of the current frame (0 when the track is empty).
    pub fn frame(&self) -> usize {
        self.track.frames.get(self.frame_pos).map_or(0, |f| f.frame)
    }

    pub fn n_frames(&self) -> usize {
        self.track.len()
    }

    /// The points the current scope moves, around the selected point.
    pub fn scope_indices(&self) -> Vec<usize> {
        use crate::landmarks::ibug::{INNER_LIP, OUTER_LIP};
        match self.scope {
            Scope::Point => vec![self.selected],
            Scope::Group => crate::reference::current()
                .names
                .group_of(self.selected)
                .map_or_else(|| vec![self.selected], |g| g.range.clone().collect()),
            Scope::Mouth => (OUTER_LIP.start..INNER_LIP.end).collect(),
            Scope::All => (0..N_LANDMARKS).collect(),
        }
    }

    /// Flags of frame number `frame`, if any.
    pub fn flags_of(&self, frame: usize) -> Option<&FrameFlags> {
        self.flags.binary_search_by_key(&frame, |f| f.frame).ok().map(|i| &self.flags[i])
    }

    /// Recomputes the per-frame flags from the track, fits and measures.
    /// Measure outliers are looked for in the video's W and H (from the effective landmarks)
    /// and in any extra series in `measures` (e.g. the fitted head's).
    pub fn recompute_flags(&mut self) {
        let fits: Vec<FrameFit> = self.fit.fits.values().cloned().collect();
        self.flags = crate::workflow::flags::clip_flags(
            &self.track,
            &fits,
            &self.measures,
            &self.flag_thresholds,
        );
    }

    /// The landmarks fits are made from and the video is measured on: the edited track with
    /// sealed lips closed as the fit settings say (`Session::fit_input_track`'s rule).
    pub fn fit_input_track(&self) -> Track {
        crate::landmarks::closure::with_sealed_lips(self.track.clone(), self.fit_settings.closure)
    }

    /// The decoded image of the current frame, when cached.
    pub fn current_image(&self) -> Option<&Arc<FrameImage>> {
        self.images.get(&self.frame())
    }

    /// Inserts a decoded frame, evicting the least recently inserted beyond capacity.
    pub fn cache_image(&mut self, frame: usize, image: Arc<FrameImage>) {
        if self.images.insert(frame, image).is_none() {
            self.cache_order.push_back(frame);
        }
        while self.cache_order.len() > self.cache_capacity {
            if let Some(old) = self.cache_order.pop_front() {
                if old == self.frame() {
                    self.cache_order.push_back(old);
                    continue;
                }
                self.images.remove(&old);
            }
        }
    }

    /// Queues a fresh analysis (when there are fits to analyse).
    pub fn request_analysis(&mut self) {
        if !self.fit.fits.is_empty() && self.model.is_some() && self.map.is_some() {
            self.analysis_generation += 1;
            self.effects.push(Effect::Analyse { generation: self.analysis_generation });
        }
    }

    /// Opened as the next clip of the same session: keeps how the user looked at the
    /// previous one (view, image zoom and pan, the head's angle; not a suggestion, which was
    /// for the other clip) and names the clip in the status line.
    pub fn continue_from(&mut self, previous: &App, clip_name: &str) {
        self.view = previous.view;
        self.image_view = previous.image_view;
        self.head = HeadView { suggested: None, ..previous.head };
        // The heads are the session's, set up once whatever the clip.
        if self.heads.names == previous.heads.names {
            self.heads = TransferredHeads { current: None, ..previous.heads.clone() };
        }
        self.show_speech = previous.show_speech;
        // The quality tables are the session's: a sentence opened from them keeps them, with
        // the cursor where it was, so the next sentence is one Enter away.
        self.quality = previous.quality.clone();
        let own_now = self.analysis.tables.len();
        self.analysis.tables.extend(self.quality.iter().cloned());
        let own = previous.analysis.tables.len().saturating_sub(previous.quality.len());
        if !previous.quality.is_empty() && previous.analysis_view.table >= own {
            let view = AnalysisView {
                table: previous.analysis_view.table - own,
                ..previous.analysis_view
            };
            self.analysis_view = AnalysisView { table: own_now + view.table, ..view };
            self.quality_view = Some(view);
        }
        self.status = format!("clip {} of {}: {clip_name}", self.clip + 1, self.clip_names.len());
    }

    /// The top overlay, if any.
    pub fn top_overlay(&self) -> Option<&Overlay> {
        self.overlays.last()
    }

    /// Phone label at the current frame, from the alignment.
    pub fn phone_label(&self) -> Option<String> {
        let a = self.alignment.as_ref()?;
        let f = self.track.frames.get(self.frame_pos)?;
        let t = f.timestamp.unwrap_or(f.frame as f64 / self.fps);
        a.phone_at(t).map(|p| p.label.clone())
    }
}
