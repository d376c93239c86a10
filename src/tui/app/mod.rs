//! `App`: the TUI's whole state as plain data (no widgets, no terminal handles): the five
//! screens (each owns its state, in `screens/`), the overlay stack, and what the screens
//! share: the clip's landmarks, the session's model, map and mesh, the fits, the edit
//! history (`history`) and where saving stands (`save`).
//!
//! Only `update::update` changes an `App`; drawing reads it. Side effects (decode a frame, run
//! a fit, save) are queued in `App::effects` and carried out by the run loop and its jobs.

pub mod history;
pub mod save;

pub use history::{Edit, LabelChange};
pub use save::SaveState;

use super::overlays::Overlay;
use super::screens::View;
use super::screens::analysis::AnalysisScreen;
use super::screens::fit::FitScreen;
use super::screens::frames::{FramesScreen, Scope};
use super::screens::head::{HeadFraming, HeadScreen};
use super::screens::side::SideState;
use crate::alignment::Alignment;
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::flags::{
    FlagThresholds, FrameFlags, FrameRgb, LipEdgeOffset, MeasureSeries, RgbPixels, add_reasons,
    flags_of_lip_edges, lip_edge_offsets,
};
use crate::landmarks::{N_LANDMARKS, Track};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use std::collections::{BTreeMap, BTreeSet};
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

impl RgbPixels for FrameImage {
    fn frame_rgb(&self) -> FrameRgb<'_> {
        FrameRgb { width: self.width, height: self.height, rgb: &self.rgb }
    }
}

/// Where frame images come from. Implementations must be cheap to share across threads;
/// `load` runs on a job's thread, never on the UI thread.
pub trait FrameProvider: Send + Sync {
    /// Decodes the image of frame number `frame`.
    ///
    /// # Errors
    /// When the frame does not exist or cannot be decoded.
    fn load(&self, frame: usize) -> anyhow::Result<FrameImage>;
}

/// Work for the run loop to hand to the jobs or the session.
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
    /// Suggest the map from `labels` on a job (`lipmap map suggest`'s use case); `landmark`:
    /// the one landmark `o` asked for, `None` for every unlabelled one (`O`).
    SuggestMap {
        labels: crate::model::LandmarkMap,
        landmark: Option<usize>,
    },
    /// Re-align frame `frame` to its corrected points with lipmap's tracker.
    Realign {
        frame: usize,
    },
    /// Track frame `frame` from the face box `[left, top, side]` (image pixels), then the
    /// following frames from it.
    TrackFromBox {
        frame: usize,
        face: [f64; 3],
    },
    Quit,
}

/// The clip's fits by frame number, and the frames edited since their fit (a fit of only
/// those is enough). Every screen reads them; the fit screen asks for new ones.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fits {
    pub by_frame: BTreeMap<usize, FrameFit>,
    pub stale: BTreeSet<usize>,
}

/// Everything the TUI shows and edits.
pub struct App {
    // ---- the clip, which every screen shows ----
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
    pub flags: Vec<FrameFlags>,
    /// The image evidence by frame, (face size, lip-edge offset)
    /// (`landmarks::flags::lip_edge_offsets`): the whole clip's from a job at start, each
    /// decoded frame's re-measured as flags are recomputed; the flags judge each against the
    /// registration of them all.
    pub lip_edges: BTreeMap<usize, (f64, LipEdgeOffset)>,
    pub flag_thresholds: FlagThresholds,
    pub measures: Vec<MeasureSeries>,
    /// The session's clips by name, which one this is, and the one to open next when the
    /// user asked for another (the run loop saves, then opens it).
    pub clip_names: Vec<String>,
    pub clip: usize,
    pub switch_clip: Option<usize>,
    /// The map the user asked to label instead (the run loop saves, then reopens the
    /// session labelling it).
    pub switch_map: Option<crate::session::MapRole>,

    // ---- the session's resources and the fits made with them ----
    pub model: Option<Arc<MorphableModel>>,
    /// The map the head view labels (`head.label_role` says whose).
    pub map: Option<LandmarkMap>,
    /// The model's map while the head view labels a head's own map; see [`App::fit_map`].
    pub model_map: Option<LandmarkMap>,
    pub mesh: Option<Arc<Mesh>>,
    /// The session's head with its own map while the head view labels the model map of a
    /// session whose head is another mesh: what the analysis view's facial indices are taken
    /// on, as `lipmap indices` takes them.
    pub other_head: Option<(Arc<Mesh>, LandmarkMap)>,
    pub fit_settings: FitSettings,
    /// The session's lip-contact precision over its clips (px), which sealed lips carry in
    /// the fit's landmarks (`Session::lip_contact_precision`); `None` when they show none.
    pub lip_contact_px: Option<f64>,
    pub fits: Fits,

    // ---- editing, saving, playing ----
    pub undo: Vec<Edit>,
    pub redo: Vec<Edit>,
    /// Unsaved changes, the save in flight, and whether the user is leaving.
    pub save: SaveState,
    pub status: String,
    /// Playback: frames advance at the clip's rate.
    pub playing: bool,

    // ---- the screens: the one shown, the overlays over it, and each one's state ----
    pub view: View,
    pub overlays: Vec<Overlay>,
    pub frames: FramesScreen,
    pub head: HeadScreen,
    pub fit: FitScreen,
    pub analysis: AnalysisScreen,
    /// The side view (protrusion), when the clip has one.
    pub side: SideState,

    pub term_size: (u16, u16),
    /// Whether the views show their side panel (the user hides it for room).
    pub side_panel: bool,
    /// Work `update` queued for the run loop.
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
            flags: Vec::new(),
            lip_edges: BTreeMap::new(),
            flag_thresholds: FlagThresholds::default(),
            measures: Vec::new(),
            clip_names: Vec::new(),
            clip: 0,
            switch_clip: None,
            switch_map: None,
            model: None,
            map: None,
            model_map: None,
            mesh: None,
            other_head: None,
            fit_settings: FitSettings::default(),
            lip_contact_px: None,
            fits: Fits::default(),
            undo: Vec::new(),
            redo: Vec::new(),
            save: SaveState::default(),
            status: String::new(),
            playing: false,
            view: View::Frames,
            overlays: Vec::new(),
            frames: FramesScreen::default(),
            head: HeadScreen::default(),
            fit: FitScreen::default(),
            analysis: AnalysisScreen::default(),
            side: SideState::None,
            term_size: (80, 24),
            side_panel: true,
            effects: Vec::new(),
        };
        app.recompute_flags();
        app
    }

    /// The model's map, what fits use: the labelled map when the head view labels the model,
    /// else the model's own.
    pub fn fit_map(&self) -> Option<&LandmarkMap> {
        match self.head.label_role {
            crate::session::MapRole::Model => self.map.as_ref(),
            crate::session::MapRole::Head => self.model_map.as_ref(),
        }
    }

    /// Sets the head mesh, every vertex labelable and hiding what is behind it.
    pub fn set_mesh(&mut self, mesh: Arc<Mesh>) {
        self.set_label_mesh(mesh, None, None);
    }

    /// Sets the mesh the head view labels: `candidates` (`None`: all) may carry a landmark,
    /// `occluders` (`None`: all) are drawn and hide what is behind them. Precomputes its
    /// wireframe edges (candidates only: a figure's proxy shells and joint markers would
    /// hide the face's own), its triangles, where its face is, and frames the view on it.
    pub fn set_label_mesh(
        &mut self,
        mesh: Arc<Mesh>,
        candidates: Option<Arc<Vec<bool>>>,
        occluders: Option<Arc<Vec<bool>>>,
    ) {
        let keep = candidates.as_deref().map(Vec::as_slice);
        self.head.edges = Arc::new(super::screens::head::state::wire_edges(&mesh, keep));
        self.head.triangles = Arc::new(crate::fit::suggest::surface_triangles(
            &mesh.triangles(),
            occluders.as_deref().map(Vec::as_slice),
        ));
        self.head.face = super::screens::head::state::face_of_mesh(&mesh, keep);
        self.head.label_candidates = candidates;
        self.head.occluders = occluders;
        self.mesh = Some(mesh);
        self.frame_head();
    }

    /// Frames the head screen on the face (see [`HeadFraming::of_face`]).
    pub fn frame_head(&mut self) {
        if let Some(mesh) = &self.mesh {
            self.head.framing = HeadFraming::of_face(
                mesh,
                self.model.as_deref(),
                self.map.as_ref(),
                self.head.face.as_ref(),
            );
        }
    }

    /// Image size for drawing: the decoded frames' size, else a box around all landmarks
    /// (so points can be drawn and edited while the first frame decodes).
    pub fn frame_dims(&self) -> (u32, u32) {
        if let Some(s) = self.frames.cache.size {
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
        let selected = self.frames.selected;
        match self.frames.scope {
            Scope::Point => vec![selected],
            Scope::Group => {
                let names = &crate::reference::current().names;
                names
                    .group_of(selected)
                    .map_or_else(|| vec![selected], |g| g.range.clone().collect())
            }
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
    /// The image checks are re-run on the decoded frames (an edit is on a shown, so decoded,
    /// frame); the others keep their last finding.
    pub fn recompute_flags(&mut self) {
        let fits: Vec<FrameFit> = self.fits.by_frame.values().cloned().collect();
        self.flags = crate::workflow::flags::clip_flags(
            &self.track,
            &fits,
            &self.measures,
            &self.flag_thresholds,
        );
        let images = &self.frames.cache.images;
        for f in images.keys() {
            self.lip_edges.remove(f);
        }
        let found =
            lip_edge_offsets(&self.track, |f| images.get(&f).cloned(), &self.flag_thresholds);
        self.lip_edges.extend(found.into_iter().map(|(f, size, o)| (f, (size, o))));
        let all: Vec<(usize, f64, LipEdgeOffset)> =
            self.lip_edges.iter().map(|(f, (size, o))| (*f, *size, *o)).collect();
        add_reasons(&mut self.flags, flags_of_lip_edges(&all, &self.flag_thresholds));
    }

    /// The landmarks fits are made from and the video is measured on: the edited track with
    /// sealed lips closed as the fit settings say (`Session::fit_input_track`'s rule).
    pub fn fit_input_track(&self) -> Track {
        let seal = self.fit_settings.closure == crate::landmarks::closure::Closure::Seal;
        let pooled = self.lip_contact_px.filter(|_| seal);
        crate::landmarks::closure::with_sealed_lips(
            self.track.clone(),
            self.fit_settings.closure,
            pooled,
        )
    }

    /// The decoded image of the current frame, when cached.
    pub fn current_image(&self) -> Option<&Arc<FrameImage>> {
        self.frames.cache.images.get(&self.frame())
    }

    /// Inserts a decoded frame into the frames screen's cache (never evicting the current
    /// frame's).
    pub fn cache_image(&mut self, frame: usize, image: Arc<FrameImage>) {
        let shown = self.frame();
        self.frames.cache.insert(frame, image, shown);
    }

    /// The effects `update` queued, for the run loop to perform (it takes them once each).
    pub fn take_effects(&mut self) -> Vec<Effect> {
        std::mem::take(&mut self.effects)
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
