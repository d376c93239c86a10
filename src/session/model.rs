//! The serde shape of a session file: `Session`, its `Clip`s and their views, and the model,
//! map and fit references. Paths are absolute here and relative to the file on disk.
//!
//! A clip's tracked landmarks and cached fits live in files beside the session
//! ([`super::clip_data`]); the JSON holds a reference and a summary of each (an older
//! session's inline arrays are read too, and moved to files by the next save).
//! `landmarks_file` records where the landmarks came from. Edits live in `corrections`.

use super::cache::FitCacheEntry;
use super::clip_data::{ClipData, FitsSummary, TrackSummary};
use super::corrections::Corrections;
use super::migrate::CURRENT_SCHEMA;
use super::store::{rel_path, rel_path_opt};
use crate::alignment::Alignment;
use crate::fit::FitSettings;
use crate::landmarks::Track;
use crate::model::landmark_map::LandmarkMap;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Everything a user does on one set of clips. See docs/session-format.md.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Session {
    /// Format version; a newer one is refused, older ones are migrated on load.
    pub schema_version: u32,
    /// Display name (defaults to the file name without `.lipmap.json`).
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub clips: Vec<Clip>,
    /// The head mesh (OBJ) the motion finally drives: the model's own mesh (one map serves
    /// both) or another mesh with its own map (`head_map`).
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub head_mesh: Option<PathBuf>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<ModelRef>,
    /// The model's map: which model vertex is which iBUG point, what `fit` uses. When the
    /// head is the model's own mesh it is the head's map too.
    #[serde(default)]
    pub landmark_map: MapRef,
    /// The head's own map, present exactly when the head is another mesh than the model (a
    /// scan, a MakeHuman figure): what `transfer` and `indices` read on the head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_map: Option<MapRef>,
    #[serde(default)]
    pub fit_settings: FitSettings,
    /// Schema 2 kept every clip's cached fits here; a load moves them into their clips.
    #[serde(default, rename = "fit_cache", skip_serializing)]
    pub(crate) legacy_fit_cache: Vec<LegacyFitCacheEntry>,
    /// Data owned by other parts of lipmap (TUI layout, ...), kept verbatim.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub extensions: BTreeMap<String, Value>,
    /// Heads the motion was transferred onto (`lipmap transfer`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transferred_heads: Vec<super::transferred::TransferredHead>,
    /// The speech model last trained or evaluated on this session (`lipmap speech train`,
    /// `speech eval`): the TUI drives the clip's head from its audio with it.
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub speech_model: Option<PathBuf>,
    /// Folder the session's relative paths were resolved against (the file's folder).
    #[serde(skip)]
    pub(crate) base_dir: PathBuf,
    /// Where new per-frame data goes before the save, for a session this process will save.
    #[serde(skip)]
    pub(crate) spill: super::Spill,
    /// Clips whose fit cache file was missing on load (clip name, file): their cache is
    /// empty, so their frames are fitted again.
    #[serde(skip)]
    pub lost_fit_caches: Vec<(String, PathBuf)>,
    /// The tracker's lip-contact precision over the clips, made on first use and forgotten
    /// when a clip changes (`Session::lip_contact_precision`).
    #[serde(skip)]
    pub(crate) contact_precision: super::DerivedOnce<Option<f64>>,
}

/// A schema-2 cache entry: the clip it belongs to, then the entry.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub(crate) struct LegacyFitCacheEntry {
    pub clip: String,
    #[serde(flatten)]
    pub entry: FitCacheEntry,
}

/// One recording: its frames, the tracker's landmarks, the corrections and the phones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clip {
    /// Unique within the session.
    pub name: String,
    /// The front view, which the landmarks and fits refer to.
    pub front: View,
    /// An optional side view (for protrusion), with its own rate and offset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<View>,
    /// The landmarks as the tracker gave them; never edited (see `corrections`). Read with
    /// [`Clip::tracked`], replaced with [`Clip::set_tracked`].
    #[serde(default, with = "tracked_field")]
    tracked: ClipData<Track>,
    /// The file the tracked landmarks were imported from.
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub landmarks_file: Option<PathBuf>,
    #[serde(default)]
    pub corrections: Corrections,
    /// Side-view frame → the upper lip's foremost point as the user set it (image px),
    /// overriding the automatic profile point; the automatic one is recomputed, never stored
    /// over. Kept apart from the side-view setup so a new setup keeps the corrections.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub profile_corrections: BTreeMap<usize, crate::math::Point2>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alignment: Option<Alignment>,
    /// The file the alignment was imported from (TextGrid, .lab, CSV).
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub alignment_file: Option<PathBuf>,
    /// The speech recorded with the clip (speech-driven animation trains on clips that have it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub audio: Option<ClipAudio>,
    /// Per-clip data owned by other parts of lipmap (side-view protrusion setup and values,
    /// ...), kept verbatim.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub extensions: BTreeMap<String, Value>,
    /// Cached fits of the clip, one entry per fit settings (see `cache`), oldest first.
    #[serde(default, skip_serializing_if = "ClipData::is_empty", with = "fits_field")]
    pub(crate) fit_cache: ClipData<Vec<FitCacheEntry>>,
}

/// One camera's frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    pub source: FramesRef,
    /// Frames per second.
    pub fps: f64,
    /// `[width, height]` in pixels, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[u32; 2]>,
    /// Seconds from the front view's frame 0 to this view's frame 0 (0 for the front view).
    #[serde(default)]
    pub offset_s: f64,
}

/// A clip's audio: a WAV file, as found when it was added (rate and channels are checked
/// again when it is read).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClipAudio {
    #[serde(with = "rel_path")]
    pub file: PathBuf,
    pub sample_rate: u32,
    pub channels: u16,
    /// Seconds from the front view's frame 0 to the audio's first sample.
    #[serde(default)]
    pub offset_s: f64,
}

/// Where a view's frames are.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FramesRef {
    /// A folder of PNG/JPEG/PPM images, natural name order.
    Images {
        #[serde(with = "rel_path")]
        dir: PathBuf,
    },
    /// A video file, decoded with ffmpeg.
    Video {
        #[serde(with = "rel_path")]
        file: PathBuf,
    },
}

impl FramesRef {
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Images { dir } => dir,
            Self::Video { file } => file,
        }
    }
}

/// The morphable model to fit.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelRef {
    /// eos `.bin`, `.npz`, or a folder of pose OBJs.
    #[serde(with = "rel_path")]
    pub path: PathBuf,
    /// Blendshapes (expression part), when separate.
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub blendshapes: Option<PathBuf>,
}

/// Which mesh vertex is which iBUG point: an eos TOML mapping file and/or an inline map
/// (0-based iBUG index -> vertex) that the TUI's labelling edits. When `inline` is present
/// it is the whole map (labelling starts from a copy of the file's map, so an unmapped point
/// can be removed); `file` then only records where it started from.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MapRef {
    #[serde(default, with = "rel_path_opt", skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inline: Option<BTreeMap<usize, usize>>,
}

/// Which of a session's meshes a map belongs to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MapRole {
    /// The morphable model's mesh: the map `fit` uses.
    #[default]
    Model,
    /// The head the motion drives: the map `transfer` and `indices` use.
    Head,
}

impl MapRole {
    pub fn name(self) -> &'static str {
        match self {
            Self::Model => "model",
            Self::Head => "head",
        }
    }
}

impl MapRef {
    /// The inline map as a `LandmarkMap`, if there is one.
    pub fn inline_map(&self) -> Option<LandmarkMap> {
        self.inline.as_ref().map(|m| LandmarkMap { to_vertex: m.clone() })
    }

    /// The map to fit with: the inline map if present, else the file's (read with
    /// `io::landmark_map_toml`), else `None`.
    ///
    /// # Errors
    /// The file's `FormatError` (path and line).
    pub fn resolve(&self) -> Result<Option<LandmarkMap>, crate::io::FormatError> {
        match (&self.inline, &self.file) {
            (Some(_), _) => Ok(self.inline_map()),
            (None, Some(path)) => crate::io::landmark_map_toml::read_landmark_map(path).map(Some),
            (None, None) => Ok(None),
        }
    }

    /// Replaces the inline map (after labelling in the TUI).
    pub fn set_inline(&mut self, map: &LandmarkMap) {
        self.inline = Some(map.to_vertex.clone());
    }
}

impl Session {
    /// An empty session to be saved at `file` (relative paths will be relative to its folder).
    pub fn new(file: &std::path::Path) -> Self {
        let abs = super::absolute(file);
        let name = session_name_of(&abs);
        Self {
            schema_version: CURRENT_SCHEMA,
            name,
            clips: Vec::new(),
            head_mesh: None,
            model: None,
            landmark_map: MapRef::default(),
            head_map: None,
            fit_settings: FitSettings::default(),
            extensions: BTreeMap::new(),
            transferred_heads: Vec::new(),
            speech_model: None,
            legacy_fit_cache: Vec::new(),
            base_dir: abs.parent().map(PathBuf::from).unwrap_or_default(),
            spill: super::Spill::default(),
            lost_fit_caches: Vec::new(),
            contact_precision: Default::default(),
        }
    }

    /// The map of the mesh `role` names: the model's map, or the head's own map when the
    /// head is another mesh (else the model's, which then serves both).
    pub fn map_of(&self, role: MapRole) -> &MapRef {
        match (role, &self.head_map) {
            (MapRole::Head, Some(m)) => m,
            _ => &self.landmark_map,
        }
    }

    /// [`Session::map_of`], to change it.
    pub fn map_of_mut(&mut self, role: MapRole) -> &mut MapRef {
        match (role, &mut self.head_map) {
            (MapRole::Head, Some(m)) => m,
            _ => &mut self.landmark_map,
        }
    }

    /// Whether the head is another mesh than the model, with a map of its own.
    pub fn head_has_own_map(&self) -> bool {
        self.head_map.is_some()
    }

    /// Folder the session's paths are relative to on disk.
    pub fn base_dir(&self) -> &std::path::Path {
        &self.base_dir
    }
}

/// `NAME` of `.../NAME.lipmap.json`.
pub fn session_name_of(file: &std::path::Path) -> String {
    let n = file.file_name().and_then(|n| n.to_str()).unwrap_or("session");
    n.strip_suffix(".lipmap.json").or_else(|| n.strip_suffix(".json")).unwrap_or(n).to_string()
}

impl Clip {
    /// A clip with no landmarks yet.
    pub fn new(name: impl Into<String>, front: View) -> Self {
        Self {
            name: name.into(),
            front,
            side: None,
            tracked: ClipData::default(),
            landmarks_file: None,
            corrections: Corrections::default(),
            profile_corrections: BTreeMap::new(),
            alignment: None,
            alignment_file: None,
            audio: None,
            extensions: BTreeMap::new(),
            fit_cache: ClipData::default(),
        }
    }

    /// The landmarks as the tracker gave them, read from the session's data folder when they
    /// are not in memory.
    ///
    /// # Errors
    /// The clip's track file cannot be read or is not what the session says.
    pub fn tracked(&self) -> Result<std::sync::Arc<Track>, super::SessionError> {
        self.tracked.get()
    }

    /// Replaces the tracked landmarks (an import, the tracker); kept in memory until the
    /// session is saved.
    pub fn set_tracked(&mut self, track: Track) {
        self.tracked = ClipData::new(track);
    }

    /// The file holding the tracked landmarks, once they are in one (a saved session).
    pub fn tracked_file(&self) -> Option<PathBuf> {
        self.tracked.file()
    }

    /// How many frames are tracked and the last of them, without reading the landmarks.
    pub fn tracked_summary(&self) -> TrackSummary {
        self.tracked.summary()
    }

    /// Reads and checks the clip's data files (whatever is in memory is taken as it is):
    /// returns the tracked frames and the cached fits they hold. Nothing stays in memory.
    ///
    /// # Errors
    /// A data file cannot be read or is not what the session says.
    pub fn check_data(&self) -> Result<(usize, usize), super::SessionError> {
        let frames = self.tracked.get()?.len();
        let fits = self.fit_cache.get()?.iter().map(|e| e.frames.len()).sum();
        Ok((frames, fits))
    }

    /// The clip's tracked landmarks as data (for the session's store).
    pub(crate) fn tracked_data(&self) -> &ClipData<Track> {
        &self.tracked
    }
}

impl View {
    /// A view at `fps` with no offset.
    pub fn new(source: FramesRef, fps: f64) -> Self {
        Self { source, fps, size: None, offset_s: 0.0 }
    }
}

/// The JSON form of a clip's tracked landmarks: `{"file", "frames", "last_frame"}` naming
/// the track file, or (older sessions, hand-written files) the frames inline in the
/// [`compact_track`] form.
pub(crate) mod tracked_field {
    use super::{ClipData, Track, TrackSummary, rel_path};
    use crate::landmarks::MAX_FRAME;
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::path::PathBuf;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct TrackRef {
        #[serde(with = "rel_path")]
        file: PathBuf,
        frames: usize,
        last_frame: usize,
    }

    pub fn serialize<S: Serializer>(data: &ClipData<Track>, s: S) -> Result<S::Ok, S::Error> {
        match (data.file(), data.unsaved()) {
            (_, Some(track)) => super::compact_track::serialize(&track, s),
            (Some(file), None) => {
                let sum = data.summary();
                let last_frame = sum.last_frame.unwrap_or_default();
                TrackRef { file, frames: sum.frames, last_frame }.serialize(s)
            }
            (None, None) => unreachable!("data neither in memory nor in a file"),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ClipData<Track>, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = ClipData<Track>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a track file reference or a list of tracked frames")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                seq: A,
            ) -> Result<ClipData<Track>, A::Error> {
                super::compact_track::Frames.visit_seq(seq).map(ClipData::new)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<ClipData<Track>, A::Error> {
                let r = TrackRef::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                crate::session::data_dir::check_reference(&r.file, "track")
                    .map_err(A::Error::custom)?;
                if r.last_frame > MAX_FRAME {
                    return Err(A::Error::custom(format!(
                        "last_frame {} is past the largest frame lipmap accepts ({MAX_FRAME})",
                        r.last_frame
                    )));
                }
                if r.frames == 0 || r.frames > r.last_frame + 1 {
                    return Err(A::Error::custom(format!(
                        "frames {} is not within 1 to last_frame + 1 ({})",
                        r.frames,
                        r.last_frame + 1
                    )));
                }
                let summary = TrackSummary { frames: r.frames, last_frame: Some(r.last_frame) };
                Ok(ClipData::in_file(r.file, summary))
            }
        }
        d.deserialize_any(V)
    }
}

/// The JSON form of a clip's cached fits: `{"file", "entries"}` naming the fits file, or
/// (hand-written files) the entries inline.
pub(crate) mod fits_field {
    use super::{ClipData, FitCacheEntry, FitsSummary, rel_path};
    use crate::session::cache::MAX_CACHED_SETTINGS_PER_CLIP;
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::path::PathBuf;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct FitsRef {
        #[serde(with = "rel_path")]
        file: PathBuf,
        entries: usize,
    }

    pub fn serialize<S: Serializer>(
        data: &ClipData<Vec<FitCacheEntry>>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        match (data.file(), data.unsaved()) {
            (_, Some(entries)) => entries.serialize(s),
            (Some(file), None) => FitsRef { file, entries: data.summary().entries }.serialize(s),
            (None, None) => unreachable!("data neither in memory nor in a file"),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<ClipData<Vec<FitCacheEntry>>, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = ClipData<Vec<FitCacheEntry>>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a fits file reference or a list of cache entries")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                seq: A,
            ) -> Result<Self::Value, A::Error> {
                let entries = Vec::<FitCacheEntry>::deserialize(
                    serde::de::value::SeqAccessDeserializer::new(seq),
                )?;
                Ok(ClipData::new(entries))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<Self::Value, A::Error> {
                let r = FitsRef::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                crate::session::data_dir::check_reference(&r.file, "fits")
                    .map_err(A::Error::custom)?;
                if !(1..=MAX_CACHED_SETTINGS_PER_CLIP).contains(&r.entries) {
                    return Err(A::Error::custom(format!(
                        "entries {} is not within 1 to {MAX_CACHED_SETTINGS_PER_CLIP}",
                        r.entries
                    )));
                }
                Ok(ClipData::in_file(r.file, FitsSummary { entries: r.entries }))
            }
        }
        d.deserialize_any(V)
    }
}

/// On-disk form of a `Track` inline in the JSON (sessions before schema 3, hand-written
/// files): per frame `xy` (x0, y0, x1, y1, ...), then only what differs from a plain visible
/// tracked point, so typical files carry no per-point objects.
pub(crate) mod compact_track {
    use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, PointSource, Track};
    use serde::de::Error as _;
    use serde::{Deserialize, Serialize, Serializer};
    use std::collections::BTreeMap;

    #[derive(Serialize, Deserialize)]
    struct Frame {
        frame: usize,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        timestamp: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        confidence: Option<f32>,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        success: bool,
        /// lipmap's tracker's self-check (`FrameLandmarks::rerun_disagreement`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        rerun_disagreement: Option<f32>,
        xy: Vec<f64>,
        /// Indices of points marked not visible.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        hidden: Vec<usize>,
        /// Per-point tracker confidence (`null` where absent); omitted when none has one.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        point_confidence: Option<Vec<Option<f32>>>,
        /// Points whose source is not `tracked` (e.g. imported from an edited lipmap CSV).
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        sources: BTreeMap<usize, PointSource>,
    }

    fn yes() -> bool {
        true
    }

    fn is_true(b: &bool) -> bool {
        *b
    }

    #[derive(Serialize)]
    struct FramesOut<'a>(#[serde(serialize_with = "ser_frames")] &'a [FrameLandmarks]);

    fn ser_frames<S: Serializer>(frames: &&[FrameLandmarks], s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let mut seq = s.serialize_seq(Some(frames.len()))?;
        for f in frames.iter() {
            seq.serialize_element(&to_compact(f))?;
        }
        seq.end()
    }

    fn to_compact(f: &FrameLandmarks) -> Frame {
        let any_conf = f.points.iter().any(|p| p.confidence.is_some());
        Frame {
            frame: f.frame,
            timestamp: f.timestamp,
            confidence: f.confidence,
            success: f.success,
            rerun_disagreement: f.rerun_disagreement,
            xy: f.points.iter().flat_map(|p| [p.x, p.y]).collect(),
            hidden: f
                .points
                .iter()
                .enumerate()
                .filter(|(_, p)| !p.visible)
                .map(|(i, _)| i)
                .collect(),
            point_confidence: any_conf.then(|| f.points.iter().map(|p| p.confidence).collect()),
            sources: f
                .points
                .iter()
                .enumerate()
                .filter(|(_, p)| p.source != PointSource::Tracked)
                .map(|(i, p)| (i, p.source))
                .collect(),
        }
    }

    fn from_compact(c: Frame) -> Result<FrameLandmarks, String> {
        let n = c.frame;
        if c.xy.len() != 2 * N_LANDMARKS {
            return Err(format!(
                "frame {n}: `xy` has {} numbers, expected {}",
                c.xy.len(),
                2 * N_LANDMARKS
            ));
        }
        let mut points: Vec<LandmarkPoint> =
            c.xy.chunks_exact(2).map(|xy| LandmarkPoint::tracked(xy[0], xy[1])).collect();
        for i in c.hidden {
            points
                .get_mut(i)
                .ok_or_else(|| format!("frame {n}: hidden point index {i} out of range"))?
                .visible = false;
        }
        if let Some(conf) = c.point_confidence {
            if conf.len() != N_LANDMARKS {
                return Err(format!(
                    "frame {n}: `point_confidence` has {} entries, expected {N_LANDMARKS}",
                    conf.len()
                ));
            }
            for (p, c) in points.iter_mut().zip(conf) {
                p.confidence = c;
            }
        }
        for (i, s) in c.sources {
            points
                .get_mut(i)
                .ok_or_else(|| format!("frame {n}: source of point index {i} out of range"))?
                .source = s;
        }
        Ok(FrameLandmarks {
            frame: n,
            timestamp: c.timestamp,
            confidence: c.confidence,
            success: c.success,
            rerun_disagreement: c.rerun_disagreement,
            points,
            lip_contact_px: None,
        })
    }

    pub fn serialize<S: Serializer>(track: &Track, s: S) -> Result<S::Ok, S::Error> {
        FramesOut(&track.frames).serialize(s)
    }

    /// A visitor that converts each frame as it is parsed, so the compact form of the whole
    /// clip is never held in memory beside the result.
    pub(crate) struct Frames;
    impl<'de> serde::de::Visitor<'de> for Frames {
        type Value = Track;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a list of tracked frames")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Track, A::Error> {
            let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 20));
            let mut last: Option<usize> = None;
            while let Some(c) = seq.next_element::<Frame>()? {
                if last.is_some_and(|l| c.frame <= l) {
                    return Err(A::Error::custom(format!(
                        "tracked frame {} is out of order or repeated",
                        c.frame
                    )));
                }
                last = Some(c.frame);
                out.push(from_compact(c).map_err(A::Error::custom)?);
            }
            Ok(Track { frames: out })
        }
    }
}
