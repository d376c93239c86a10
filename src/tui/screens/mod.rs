//! The five screens, one folder each: `frames`, `head`, `fit`, `analysis`, `side`. A screen
//! owns its state (`state.rs`, held in `App` under its name), its handlers (`update.rs`, the
//! functions the `actions!` table routes to) and its drawing (`view.rs`, reading the `App`).
//!
//! Here: which screen is shown (`View`), the layout the image screens share with mouse
//! hit-testing, drawing the shown screen, and the actions that go to whichever screen is
//! shown (zooming).

pub mod analysis;
pub mod fit;
pub mod frames;
pub mod head;
pub mod side;

use super::draw::screen_layout;
use super::widgets::halfblock::Mapping;
use crate::tui::app::App;
use ratatui::Frame;
use ratatui::layout::Rect;

/// The screen shown, switched with 1–5.
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

/// Draws the shown screen into `area`.
pub fn draw_shown(app: &App, frame: &mut Frame, area: Rect) {
    match app.view {
        View::Frames => frames::view::draw(app, frame, area),
        View::Head => head::view::draw(app, frame, area),
        View::Fit => fit::view::draw(app, frame, area),
        View::Analysis => analysis::view::draw(app, frame, area),
        View::Side => side::view::draw(app, frame, area),
    }
}

/// The frames, fit and side views: image on the left, a side panel on the right (narrower on
/// small terminals, absent below 50 columns or when the user hid it).
pub fn image_and_side(app: &App, body: Rect) -> (Rect, Rect) {
    let side_w = if !app.side_panel {
        0
    } else if body.width >= 120 {
        36
    } else if body.width >= 50 {
        26
    } else {
        0
    };
    let image = Rect::new(body.x, body.y, body.width - side_w, body.height);
    let side = Rect::new(body.x + body.width - side_w, body.y, side_w, body.height);
    (image, side)
}

/// The image mapping of the current frame for a terminal of `size`, in the frames and fit
/// views; `None` in other views or when there is nothing to map.
pub fn image_mapping(app: &App, size: (u16, u16)) -> Option<Mapping> {
    if !matches!(app.view, View::Frames | View::Fit) {
        return None;
    }
    let layout = screen_layout(app, Rect::new(0, 0, size.0, size.1));
    let (image, _) = image_and_side(app, layout.body);
    let (w, h) = app.frame_dims();
    Mapping::new(image, w, h, &app.frames.image_view)
}

/// Zooms the shown screen in: the head on the head screen, the image elsewhere.
pub fn zoom_in(app: &mut App) {
    match app.view {
        View::Head => head::update::zoom_in(app),
        _ => frames::update::zoom(app, 2.0),
    }
}

/// Zooms the shown screen out.
pub fn zoom_out(app: &mut App) {
    match app.view {
        View::Head => head::update::zoom_out(app),
        _ => frames::update::zoom(app, 0.5),
    }
}

/// Back to the unzoomed screen.
pub fn zoom_reset(app: &mut App) {
    match app.view {
        View::Head => head::update::zoom_reset(app),
        _ => frames::update::zoom_reset(app),
    }
}
