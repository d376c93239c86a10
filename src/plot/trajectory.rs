//! Trajectory charts: one panel per measure (W, H, P), one line per source (video, 3D),
//! a shared time axis in seconds, vertical phone boundaries with their labels on top.

use super::font::{draw_text, text_height, text_width};
use crate::alignment::Alignment;
use image::{Rgb, RgbImage};

/// One line in a panel: values per frame, `None` where the frame has no value.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub colour: [u8; 3],
    pub values: Vec<Option<f64>>,
}

/// One measure's panel.
#[derive(Clone, Debug)]
pub struct Panel {
    pub label: String,
    pub series: Vec<Series>,
}

/// A whole chart: panels stacked vertically over one time axis.
#[derive(Clone, Debug)]
pub struct TrajectoryPlot<'a> {
    pub title: String,
    pub fps: f64,
    pub alignment: Option<&'a Alignment>,
    pub panels: Vec<Panel>,
    pub width: u32,
    pub panel_height: u32,
    /// The x axis's unit, printed at its right end ("S" for time; frames map by `fps`).
    pub x_unit: &'a str,
}

const MARGIN_LEFT: u32 = 70;
const MARGIN_RIGHT: u32 = 20;
const HEADER: u32 = 44;
const FOOTER: u32 = 28;
const GAP: u32 = 16;
const SCALE: u32 = 2;
const INK: Rgb<u8> = Rgb([30, 30, 30]);
const GRID: Rgb<u8> = Rgb([215, 215, 215]);
const BOUNDARY: Rgb<u8> = Rgb([170, 170, 200]);

/// Renders the chart. Frames map to time by `frame / fps`; each panel's y range is the span
/// of its own finite values (a flat series gets a unit range so it still shows).
pub fn draw_trajectories(plot: &TrajectoryPlot) -> RgbImage {
    let n_panels = plot.panels.len().max(1) as u32;
    let height = HEADER + n_panels * plot.panel_height + (n_panels - 1) * GAP + FOOTER;
    let mut img = RgbImage::from_pixel(plot.width, height, Rgb([255, 255, 255]));
    let plot_w = plot.width.saturating_sub(MARGIN_LEFT + MARGIN_RIGHT).max(1);
    let n_frames = plot.panels.iter().flat_map(|p| &p.series).map(|s| s.values.len()).max();
    let duration = {
        let frames = n_frames.unwrap_or(1).max(2) as f64 - 1.0;
        let by_frames = frames / plot.fps.max(1e-9);
        plot.alignment.map_or(by_frames, |a| by_frames.max(a.duration()))
    };
    let x_of = |t: f64| MARGIN_LEFT as f64 + t / duration * plot_w as f64;

    draw_text(&mut img, MARGIN_LEFT as i64, 6, &plot.title, SCALE, INK);
    let mut legend_x = MARGIN_LEFT as i64;
    if let Some(first) = plot.panels.first() {
        for s in &first.series {
            let y = 8 + text_height(SCALE) as i64 + 6;
            fill_rect(&mut img, legend_x, y + 3, 14, 4, Rgb(s.colour));
            draw_text(&mut img, legend_x + 18, y, &s.name, SCALE, INK);
            legend_x += 18 + text_width(&s.name, SCALE) as i64 + 24;
        }
    }

    for (k, panel) in plot.panels.iter().enumerate() {
        let top = HEADER + k as u32 * (plot.panel_height + GAP);
        let bottom = top + plot.panel_height;
        let (lo, hi) = value_range(panel);
        let y_of = |v: f64| bottom as f64 - (v - lo) / (hi - lo) * plot.panel_height as f64;
        for frac in [0.0, 0.5, 1.0] {
            let y = y_of(lo + frac * (hi - lo)).round() as i64;
            draw_line(
                &mut img,
                MARGIN_LEFT as f64,
                y as f64,
                (MARGIN_LEFT + plot_w) as f64,
                y as f64,
                GRID,
            );
            let label = format!("{:.2}", lo + frac * (hi - lo));
            let tx = MARGIN_LEFT as i64 - 6 - text_width(&label, SCALE) as i64;
            // The end labels sit inside their panel's span, so neighbouring panels' labels
            // never meet across the gap.
            let h = text_height(SCALE) as i64;
            let ty = (y - h / 2).clamp(top as i64 + 1, bottom as i64 - h - 1);
            draw_text(&mut img, tx, ty, &label, SCALE, INK);
        }
        if let Some(a) = plot.alignment {
            for (i, ph) in a.phones.iter().enumerate() {
                let x = x_of(ph.start);
                draw_line(&mut img, x, top as f64, x, bottom as f64, BOUNDARY);
                if k == 0 || i == 0 {
                    let mid = x_of((ph.start + ph.end) / 2.0);
                    let w = text_width(&ph.label, 1) as f64;
                    let room = x_of(ph.end) - x;
                    if k == 0 && room >= w + 2.0 {
                        draw_text(
                            &mut img,
                            (mid - w / 2.0) as i64,
                            top as i64 + 3,
                            &ph.label,
                            1,
                            INK,
                        );
                    }
                }
            }
        }
        for s in &panel.series {
            let mut prev: Option<(f64, f64)> = None;
            for (f, v) in s.values.iter().enumerate() {
                match v.filter(|v| v.is_finite()) {
                    Some(v) => {
                        let p = (x_of(f as f64 / plot.fps), y_of(v));
                        if let Some(q) = prev {
                            draw_thick_line(&mut img, q, p, Rgb(s.colour));
                        }
                        prev = Some(p);
                    }
                    None => prev = None,
                }
            }
        }
        // Inside the panel, on white (the margin holds the value labels), below the phone
        // labels of the first panel.
        let label_top = top as i64 + if k == 0 && plot.alignment.is_some() { 14 } else { 4 };
        fill_rect(
            &mut img,
            MARGIN_LEFT as i64 + 2,
            label_top - 2,
            text_width(&panel.label, SCALE) + 8,
            text_height(SCALE) + 4,
            Rgb([255, 255, 255]),
        );
        draw_text(&mut img, MARGIN_LEFT as i64 + 6, label_top, &panel.label, SCALE, INK);
        draw_rect_outline(&mut img, MARGIN_LEFT, top, plot_w, plot.panel_height, INK);
    }
    let axis_y = (height - FOOTER + 6) as i64;
    let step = nice_step(duration);
    let mut t = 0.0;
    while t <= duration + 1e-9 {
        let label = if step >= 1.0 { format!("{t:.0}") } else { format!("{t:.1}") };
        let x = x_of(t) as i64 - text_width(&label, SCALE) as i64 / 2;
        draw_text(&mut img, x, axis_y, &label, SCALE, INK);
        t += step;
    }
    // Under the value labels, where no tick label can reach.
    draw_text(&mut img, 6, axis_y, plot.x_unit, SCALE, INK);
    img
}

fn value_range(panel: &Panel) -> (f64, f64) {
    let vals =
        panel.series.iter().flat_map(|s| s.values.iter().flatten()).filter(|v| v.is_finite());
    let (lo, hi) =
        vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-12 {
        (lo - 0.5, hi + 0.5)
    } else {
        let pad = (hi - lo) * 0.05;
        (lo - pad, hi + pad)
    }
}

/// A tick spacing of 1, 2 or 5 × 10^k giving about eight ticks.
fn nice_step(span: f64) -> f64 {
    let raw = (span / 8.0).max(1e-6);
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag)
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: u32, h: u32, c: Rgb<u8>) {
    for dy in 0..i64::from(h) {
        for dx in 0..i64::from(w) {
            put(img, x + dx, y + dy, c);
        }
    }
}

fn draw_rect_outline(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, c: Rgb<u8>) {
    let (x0, y0, x1, y1) = (x as f64, y as f64, (x + w) as f64, (y + h) as f64);
    draw_line(img, x0, y0, x1, y0, c);
    draw_line(img, x0, y1, x1, y1, c);
    draw_line(img, x0, y0, x0, y1, c);
    draw_line(img, x1, y0, x1, y1, c);
}

/// A one-pixel line by uniform stepping along the longer axis (simple and exact enough for charts).
fn draw_line(img: &mut RgbImage, x0: f64, y0: f64, x1: f64, y1: f64, c: Rgb<u8>) {
    let n = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as i64;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        put(img, (x0 + t * (x1 - x0)).round() as i64, (y0 + t * (y1 - y0)).round() as i64, c);
    }
}

fn draw_thick_line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    for (dx, dy) in [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0)] {
        draw_line(img, a.0 + dx, a.1 + dy, b.0 + dx, b.1 + dy, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::Phone;

    #[test]
    fn lines_land_where_values_say() {
        let al = Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.5, label: "B".into() },
                Phone { start: 0.5, end: 1.0, label: "AA".into() },
            ],
        };
        let values: Vec<Option<f64>> = (0..=10).map(|f| Some(f as f64 / 10.0)).collect();
        let plot = TrajectoryPlot {
            title: "test".into(),
            fps: 10.0,
            alignment: Some(&al),
            panels: vec![Panel {
                label: "W".into(),
                series: vec![Series { name: "video".into(), colour: [200, 0, 0], values }],
            }],
            width: 400,
            panel_height: 200,
            x_unit: "S",
        };
        let img = draw_trajectories(&plot);
        // A rising line: red ink near the panel's bottom-left and its top-right.
        let red = |x: u32, y: u32| {
            (x.saturating_sub(3)..x + 3).any(|xx| {
                (y.saturating_sub(3)..y + 3).any(|yy| img.get_pixel(xx, yy).0 == [200, 0, 0])
            })
        };
        let top = HEADER;
        let bottom = HEADER + 200;
        let (lo, hi) = (0.0 - 0.05, 1.0 + 0.05);
        let y_at = |v: f64| (bottom as f64 - (v - lo) / (hi - lo) * 200.0).round() as u32;
        assert!(red(MARGIN_LEFT, y_at(0.0)));
        assert!(red(400 - MARGIN_RIGHT, y_at(1.0)));
        assert!(!red(MARGIN_LEFT, top + 5));
        // The phone boundary at 0.5 s is drawn mid-panel.
        let xb =
            (MARGIN_LEFT as f64 + 0.5 * (400 - MARGIN_LEFT - MARGIN_RIGHT) as f64).round() as u32;
        assert_eq!(img.get_pixel(xb, bottom - 20).0, BOUNDARY.0);
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(8.0), 1.0);
        assert_eq!(nice_step(3.0), 0.5);
    }
}
