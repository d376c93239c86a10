//! The view of a frame as pixels for a graphics protocol: the image the `Mapping` shows,
//! cell for cell, with the half-block markers drawn as shapes on top.

use crate::tui::app::FrameImage;
use crate::tui::widgets::halfblock::{Mapping, Marker};
use image::RgbImage;
use ratatui::style::{Color, Modifier};

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
pub(super) mod tests {
    use super::*;
    use crate::tui::screens::frames::ImageView;
    use ratatui::layout::Rect;
    use ratatui::style::Style;

    /// A 40×20 image whose pixel `(x, y)` is `(6x, 12y, 77)`, so each pixel is identifiable.
    pub(crate) fn gradient() -> FrameImage {
        let (w, h) = (40u32, 20u32);
        let mut rgb = Vec::new();
        for y in 0..h {
            for x in 0..w {
                rgb.extend([(6 * x) as u8, (12 * y) as u8, 77]);
            }
        }
        FrameImage { width: w, height: h, rgb }
    }

    pub(crate) fn marker(x: f64, y: f64, symbol: &'static str, style: Style) -> Marker {
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
}
