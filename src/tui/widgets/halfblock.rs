//! Half-block image widget: each terminal cell shows two image pixels stacked (`▀` with the
//! upper colour as foreground and the lower as background), with zoom, pan and markers.
//!
//! `Mapping` is the one place screen cells and image pixels are converted, so drawing and
//! mouse hit-testing agree. Image coordinates: pixel centres at integers, y down.

use crate::tui::app::FrameImage;

use crate::tui::screens::frames::ImageView;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::widgets::Widget;

/// Image ↔ screen conversion for one area, image size and view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping {
    pub area: Rect,
    /// Display pixels per image pixel (a display pixel is half a cell, about square).
    pub scale: f64,
    /// Image point shown at the centre of the area.
    pub cx: f64,
    pub cy: f64,
}

impl Mapping {
    /// `None` when the area or the image is empty.
    pub fn new(area: Rect, image_w: u32, image_h: u32, view: &ImageView) -> Option<Self> {
        if area.width == 0 || area.height == 0 || image_w == 0 || image_h == 0 {
            return None;
        }
        let (w, h) = (f64::from(area.width), 2.0 * f64::from(area.height));
        let fit = (w / f64::from(image_w)).min(h / f64::from(image_h));
        let (cx, cy) = view
            .center
            .unwrap_or(((f64::from(image_w) - 1.0) / 2.0, (f64::from(image_h) - 1.0) / 2.0));
        Some(Self { area, scale: fit * view.zoom.max(1e-3), cx, cy })
    }

    /// Display-pixel coordinates (relative to the area, continuous) of an image point.
    pub fn image_to_display(&self, x: f64, y: f64) -> (f64, f64) {
        let (w, h) = (f64::from(self.area.width), 2.0 * f64::from(self.area.height));
        ((x - self.cx) * self.scale + w / 2.0, (y - self.cy) * self.scale + h / 2.0)
    }

    /// Image point at display-pixel coordinates (relative to the area).
    pub fn display_to_image(&self, dx: f64, dy: f64) -> (f64, f64) {
        let (w, h) = (f64::from(self.area.width), 2.0 * f64::from(self.area.height));
        ((dx - w / 2.0) / self.scale + self.cx, (dy - h / 2.0) / self.scale + self.cy)
    }

    /// The screen cell `(col, row)` and half (true = upper) showing an image point, when inside.
    pub fn image_to_cell(&self, x: f64, y: f64) -> Option<(u16, u16, bool)> {
        let (dx, dy) = self.image_to_display(x, y);
        let (dx, dy) = (dx.floor(), dy.floor());
        if dx < 0.0
            || dy < 0.0
            || dx >= f64::from(self.area.width)
            || dy >= 2.0 * f64::from(self.area.height)
        {
            return None;
        }
        let (dx, dy) = (dx as u16, dy as u16);
        Some((self.area.x + dx, self.area.y + dy / 2, dy % 2 == 0))
    }

    /// The image point at the centre of screen cell `(col, row)`, when the cell is in the area.
    pub fn cell_to_image(&self, col: u16, row: u16) -> Option<(f64, f64)> {
        let inside = col >= self.area.x
            && row >= self.area.y
            && col < self.area.x + self.area.width
            && row < self.area.y + self.area.height;
        inside.then(|| {
            self.display_to_image(
                f64::from(col - self.area.x) + 0.5,
                2.0 * f64::from(row - self.area.y) + 1.0,
            )
        })
    }

    /// Image pixels per display pixel.
    pub fn step_px(&self) -> f64 {
        1.0 / self.scale
    }

    /// Image pixels one keyboard step moves a point: one image pixel, or one display pixel
    /// where that is finer (zoomed in, for sub-pixel work). Never more than an image pixel,
    /// so a step means the same on an 80-column terminal as on a large one.
    pub fn nudge_px(&self) -> f64 {
        self.step_px().min(1.0)
    }
}

/// A symbol drawn over the image at an image point.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub symbol: &'static str,
    pub style: Style,
}

/// The widget: an optional image (black while loading) and markers drawn in order.
pub struct HalfBlockImage<'a> {
    pub image: Option<&'a FrameImage>,
    pub mapping: Mapping,
    pub markers: &'a [Marker],
}

/// For each display pixel along one axis, the image pixel range it averages (at least one).
fn footprints(n_display: u16, to_image: impl Fn(f64) -> f64, size: u32) -> Vec<Option<(u32, u32)>> {
    (0..n_display)
        .map(|d| {
            let a = to_image(f64::from(d));
            let b = to_image(f64::from(d) + 1.0);
            // Pixel i covers [i - 0.5, i + 0.5).
            let lo = (a + 0.5).floor().max(0.0);
            let hi = (b + 0.5).floor().min(f64::from(size));
            if hi <= 0.0 || lo >= f64::from(size) {
                return None;
            }
            let lo = lo as u32;
            let hi = (hi as u32).max(lo + 1).min(size);
            (lo < hi).then_some((lo, hi))
        })
        .collect()
}

impl HalfBlockImage<'_> {
    fn average(img: &FrameImage, xs: (u32, u32), ys: (u32, u32)) -> Color {
        let (mut r, mut g, mut b, mut n) = (0u32, 0u32, 0u32, 0u32);
        // Sub-sample big footprints: a 4×4 grid is plenty for a terminal cell.
        let sx = ((xs.1 - xs.0) / 4).max(1);
        let sy = ((ys.1 - ys.0) / 4).max(1);
        let w = img.width as usize;
        let mut y = ys.0;
        while y < ys.1 {
            let row = y as usize * w;
            let mut x = xs.0;
            while x < xs.1 {
                let i = 3 * (row + x as usize);
                r += u32::from(img.rgb[i]);
                g += u32::from(img.rgb[i + 1]);
                b += u32::from(img.rgb[i + 2]);
                n += 1;
                x += sx;
            }
            y += sy;
        }
        let n = n.max(1);
        Color::Rgb((r / n) as u8, (g / n) as u8, (b / n) as u8)
    }
}

impl Widget for HalfBlockImage<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let m = Mapping { area, ..self.mapping };
        let black = Color::Rgb(0, 0, 0);
        if let Some(img) = self.image.filter(|i| i.rgb.len() >= 3 * (i.width * i.height) as usize) {
            let cols = footprints(area.width, |d| m.display_to_image(d, 0.0).0, img.width);
            let rows = footprints(area.height * 2, |d| m.display_to_image(0.0, d).1, img.height);
            for r in 0..area.height {
                let (up, lo) = (rows[2 * r as usize], rows[2 * r as usize + 1]);
                for c in 0..area.width {
                    let xs = cols[c as usize];
                    let colour = |ys: Option<(u32, u32)>| match (xs, ys) {
                        (Some(xs), Some(ys)) => Self::average(img, xs, ys),
                        _ => black,
                    };
                    if let Some(cell) = buf.cell_mut((area.x + c, area.y + r)) {
                        cell.set_symbol("▀").set_fg(colour(up)).set_bg(colour(lo));
                    }
                }
            }
        } else {
            for r in 0..area.height {
                for c in 0..area.width {
                    if let Some(cell) = buf.cell_mut((area.x + c, area.y + r)) {
                        cell.set_symbol(" ").set_bg(black);
                    }
                }
            }
        }
        for mk in self.markers {
            if let Some((col, row, _)) = m.image_to_cell(mk.x, mk.y)
                && let Some(cell) = buf.cell_mut((col, row))
            {
                cell.set_symbol(mk.symbol);
                if let Some(fg) = mk.style.fg {
                    cell.set_fg(fg);
                }
                if let Some(bg) = mk.style.bg {
                    cell.set_bg(bg);
                }
                cell.modifier = cell.modifier.union(mk.style.add_modifier);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_round_trips_and_fits_the_image() {
        let area = Rect::new(2, 1, 40, 10);
        let m = Mapping::new(area, 80, 40, &ImageView::default()).unwrap();
        // 40 cols × 20 display rows: 80×40 image fits at scale 0.5.
        assert!((m.scale - 0.5).abs() < 1e-12);
        let (x, y) = m.display_to_image(13.0, 7.0);
        let (dx, dy) = m.image_to_display(x, y);
        assert!((dx - 13.0).abs() < 1e-9 && (dy - 7.0).abs() < 1e-9);
        assert_eq!(m.image_to_cell(0.0, 0.0), Some((2, 1, true)));
        assert_eq!(m.image_to_cell(-10.0, 0.0), None);
        let (ix, iy) = m.cell_to_image(2 + 20, 1 + 5).unwrap();
        assert!((ix - 40.5).abs() < 1.0 && (iy - 21.5).abs() < 1.0);
    }

    #[test]
    fn renders_colours_into_half_cells() {
        // Top half red, bottom half blue, 2×2 image into a 2×1 area.
        let img = FrameImage {
            width: 2,
            height: 2,
            rgb: vec![255, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0, 255],
        };
        let area = Rect::new(0, 0, 2, 1);
        let m = Mapping::new(area, 2, 2, &ImageView::default()).unwrap();
        let mut buf = Buffer::empty(area);
        HalfBlockImage { image: Some(&img), mapping: m, markers: &[] }.render(area, &mut buf);
        let cell = &buf[(0, 0)];
        assert_eq!(cell.symbol(), "▀");
        assert_eq!(cell.fg, Color::Rgb(255, 0, 0));
        assert_eq!(cell.bg, Color::Rgb(0, 0, 255));
    }
}
