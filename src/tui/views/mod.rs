//! Drawing: `draw(&App, &mut Frame)` lays out the title, the current view, the flag strip
//! and the status line, then the overlays (help, prompt) on top. Views only read the `App`.
//!
//! Layout functions are shared with `update` so mouse hit-testing matches what is drawn.

pub mod analysis;
pub mod fit;
pub mod frames;
pub mod head;
pub mod help;
pub mod side;
pub mod status;

use super::app::{App, Overlay, View};
use super::keymap::Keymap;
use super::widgets::halfblock::Mapping;
use ratatui::Frame;
use ratatui::layout::Rect;

/// The fixed parts of the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenLayout {
    pub title: Rect,
    pub body: Rect,
    pub strip: Rect,
    pub status: Rect,
}

/// Title on top, flag strip and status line at the bottom, the view in between.
pub fn screen_layout(area: Rect) -> ScreenLayout {
    let h = area.height;
    let row = |y: u16, height: u16| Rect::new(area.x, area.y + y, area.width, height);
    if h < 4 {
        return ScreenLayout {
            title: row(0, 0),
            body: row(0, h),
            strip: row(h, 0),
            status: row(h, 0),
        };
    }
    ScreenLayout {
        title: row(0, 1),
        body: row(1, h - 3),
        strip: row(h - 2, 1),
        status: row(h - 1, 1),
    }
}

/// The frames and fit views: image on the left, a side panel on the right (narrower on small
/// terminals, absent below 50 columns).
pub fn image_and_side(body: Rect) -> (Rect, Rect) {
    let side_w = if body.width >= 120 {
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
    let layout = screen_layout(Rect::new(0, 0, size.0, size.1));
    let (image, _) = image_and_side(layout.body);
    let (w, h) = app.frame_dims();
    Mapping::new(image, w, h, &app.image_view)
}

/// Draws the whole screen.
pub fn draw(app: &App, keymap: &Keymap, frame: &mut Frame) {
    let area = frame.area();
    let layout = screen_layout(area);
    status::draw_title(app, frame, layout.title);
    match app.view {
        View::Frames => frames::draw(app, frame, layout.body),
        View::Head => head::draw(app, frame, layout.body),
        View::Fit => fit::draw(app, frame, layout.body),
        View::Analysis => analysis::draw(app, frame, layout.body),
        View::Side => side::draw(app, frame, layout.body),
    }
    status::draw_strip(app, frame, layout.strip);
    status::draw_status(app, keymap, frame, layout.status);
    for overlay in &app.overlays {
        match overlay {
            Overlay::Help { scroll } => help::draw(app, keymap, *scroll, frame, area),
            Overlay::Prompt { kind, input } => {
                status::draw_prompt(*kind, input, frame, layout.status)
            }
        }
    }
}
