//! The frames screen's state: the selected point and what moves with it, the image's zoom
//! and pan, a mouse drag under way, the decoded frames (the fit screen shows them too), and
//! the face box a user draws for the tracker (held by its overlay, `Overlay::FaceBox`).

use crate::tui::app::FrameImage;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

/// What the frames screen (and the fit screen, which shares its keys) keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct FramesScreen {
    /// The selected landmark (0-based iBUG).
    pub selected: usize,
    pub scope: Scope,
    pub image_view: ImageView,
    /// An open undo entry a mouse drag keeps extending.
    pub dragging: bool,
    /// The current drag has already pushed its undo entry.
    pub drag_open: bool,
    pub cache: FrameCache,
}

impl Default for FramesScreen {
    fn default() -> Self {
        Self {
            // The upper lip's inner middle: where correcting usually starts.
            selected: 62,
            scope: Scope::Point,
            image_view: ImageView::default(),
            dragging: false,
            drag_open: false,
            cache: FrameCache::default(),
        }
    }
}

/// Decoded frames by frame number (the newest last in `order`), the frames that failed to
/// decode and why, and the size of the clip's frames once known.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameCache {
    pub images: BTreeMap<usize, Arc<FrameImage>>,
    pub order: VecDeque<usize>,
    pub capacity: usize,
    pub errors: BTreeMap<usize, String>,
    /// Size of the clip's frames, known once one is decoded (or from the session).
    pub size: Option<(u32, u32)>,
}

impl Default for FrameCache {
    fn default() -> Self {
        Self {
            images: BTreeMap::new(),
            order: VecDeque::new(),
            capacity: 48,
            errors: BTreeMap::new(),
            size: None,
        }
    }
}

impl FrameCache {
    /// Inserts a decoded frame, evicting the least recently inserted beyond capacity but
    /// never frame `shown`.
    pub fn insert(&mut self, frame: usize, image: Arc<FrameImage>, shown: usize) {
        if self.images.insert(frame, image).is_none() {
            self.order.push_back(frame);
        }
        while self.order.len() > self.capacity {
            if let Some(old) = self.order.pop_front() {
                if old == shown {
                    self.order.push_back(old);
                    continue;
                }
                self.images.remove(&old);
            }
        }
    }

    /// Forgets every decoded frame.
    pub fn clear(&mut self) {
        self.images.clear();
        self.order.clear();
    }

    /// Whether frame `frame` is decoded or known not to decode.
    pub fn has(&self, frame: usize) -> bool {
        self.images.contains_key(&frame) || self.errors.contains_key(&frame)
    }
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

/// A face box being drawn for the tracker, in image pixels: a square (the shape of the boxes
/// the predictor was trained from), its centre and side, and the corner a mouse drag started
/// from while one is under way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceBoxDraft {
    pub cx: f64,
    pub cy: f64,
    pub side: f64,
    pub anchor: Option<(f64, f64)>,
}

impl FaceBoxDraft {
    /// Smallest side a box may be given, in image pixels.
    pub const MIN_SIDE: f64 = 8.0;

    /// The square with one corner at `anchor` reaching toward `(x, y)` (its side the larger
    /// of the two extents), as a mouse drag draws it.
    pub fn dragged(anchor: (f64, f64), x: f64, y: f64) -> Self {
        let side = (x - anchor.0).abs().max((y - anchor.1).abs()).max(Self::MIN_SIDE);
        let sx = if x >= anchor.0 { 1.0 } else { -1.0 };
        let sy = if y >= anchor.1 { 1.0 } else { -1.0 };
        Self {
            cx: anchor.0 + sx * side / 2.0,
            cy: anchor.1 + sy * side / 2.0,
            side,
            anchor: Some(anchor),
        }
    }

    /// Left, top and side.
    pub fn rect(&self) -> [f64; 3] {
        [self.cx - self.side / 2.0, self.cy - self.side / 2.0, self.side]
    }
}
