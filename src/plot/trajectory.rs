//! Trajectory charts: stacked panels (one measure each) over one shared x axis, one line per
//! source, phone boundaries through every panel and the phone labels, as written, in a strip
//! above. Every chart carries a title, a legend, a y-axis label per panel and an x-axis label
//! centred under the axis, so a PNG read on its own says what it shows.
//!
//! Drawn by hand on an `RgbImage` rather than through a charting crate: the layout needs
//! per-panel y scales over one time axis, phone intervals labelled at their middles in as
//! many rows as they need, and labels at whole pixels so tests can find them
//! ([`super::font::find_text`]); that is a few hundred lines here, and `plotters` would add
//! four crates for the axes alone.

use super::font::{draw_text, draw_text_up, text_height, text_width};
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
    /// The y axis's label: the measure and its unit or normalisation, one turned line per
    /// `\n`-separated part ("W mouth width\nmin–max scaled, 0–1"); a line longer than the
    /// panel is drawn smaller to fit.
    pub y_label: String,
    /// A note written inside the panel's top-left corner (e.g. a fit statistic), if any.
    pub caption: Option<String>,
    pub series: Vec<Series>,
}

/// A whole chart: panels stacked vertically over one x axis.
#[derive(Clone, Debug)]
pub struct TrajectoryPlot<'a> {
    /// What is compared, on which clip.
    pub title: String,
    /// Points per x unit: a series' value `k` is drawn at x = k / `fps`.
    pub fps: f64,
    pub alignment: Option<&'a Alignment>,
    pub panels: Vec<Panel>,
    pub width: u32,
    pub panel_height: u32,
    /// The x axis's label with its unit ("time (s)"), centred under the axis.
    pub x_label: String,
}

/// Text sizes in pixels.
pub const TITLE_PX: f32 = 17.0;
pub const LABEL_PX: f32 = 14.0;
pub const TICK_PX: f32 = 12.0;
pub const PHONE_PX: f32 = 13.0;

pub const INK: Rgb<u8> = Rgb([30, 30, 30]);
const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);
const BOUNDARY: Rgb<u8> = Rgb([170, 170, 200]);
const PAD: u32 = 6;
const GAP: u32 = 12;
const MARGIN_RIGHT: u32 = 24;
/// Phone-label rows tried before a label that fits nowhere is left out.
const PHONE_ROWS: usize = 2;

/// Where a chart's parts landed, for callers and tests.
#[derive(Clone, Debug, PartialEq)]
pub struct ChartLayout {
    /// Left edge of the plotting area (right of the y labels and tick values).
    pub plot_left: u32,
    pub plot_width: u32,
    /// Top and bottom of each panel.
    pub panels: Vec<(u32, u32)>,
    /// Phone labels drawn (as written) and left out for lack of room.
    pub phones_drawn: Vec<String>,
    pub phones_left_out: usize,
}

/// Renders the chart. Each panel's y range is the span of its own finite values (a flat
/// series gets a unit range so it still shows).
pub fn draw_trajectories(plot: &TrajectoryPlot) -> RgbImage {
    draw_trajectories_with_layout(plot).0
}

/// [`draw_trajectories`], with where its parts landed.
pub fn draw_trajectories_with_layout(plot: &TrajectoryPlot) -> (RgbImage, ChartLayout) {
    let n_frames = plot.panels.iter().flat_map(|p| &p.series).map(|s| s.values.len()).max();
    let duration = {
        let frames = n_frames.unwrap_or(1).max(2) as f64 - 1.0;
        let by_frames = frames / plot.fps.max(1e-9);
        plot.alignment.map_or(by_frames, |a| by_frames.max(a.duration()))
    };
    let ticks: Vec<Vec<(f64, String)>> =
        plot.panels.iter().map(|p| y_ticks(value_range(p))).collect();
    let tick_w = ticks.iter().flatten().map(|(_, s)| text_width(s, TICK_PX)).max().unwrap_or(0);
    let label_h = text_height(LABEL_PX);
    let y_lines = plot.panels.iter().map(|p| p.y_label.lines().count()).max().unwrap_or(1).max(1);
    let y_band = y_lines as u32 * label_h;
    let plot_left = PAD + y_band + PAD + tick_w + PAD;
    let plot_w = plot.width.saturating_sub(plot_left + MARGIN_RIGHT).max(1);
    let x_of = |t: f64| plot_left as f64 + t / duration * plot_w as f64;

    let title_h = text_height(TITLE_PX);
    let phone_h = text_height(PHONE_PX);
    let legend_top = PAD + title_h + PAD;
    let strip_top = legend_top + label_h + PAD;
    let strip_h = if plot.alignment.is_some() { PHONE_ROWS as u32 * (phone_h + 2) + 2 } else { 0 };
    let first_top = strip_top + strip_h;
    let n_panels = plot.panels.len().max(1) as u32;
    let panels_bottom = first_top + n_panels * plot.panel_height + (n_panels - 1) * GAP;
    let tick_h = text_height(TICK_PX);
    let height = panels_bottom + 4 + tick_h + PAD + label_h + PAD;
    let mut img = RgbImage::from_pixel(plot.width, height, WHITE);

    draw_text(&mut img, i64::from(plot_left), i64::from(PAD), &plot.title, TITLE_PX, INK);
    draw_legend(&mut img, plot, plot_left, legend_top);

    let mut layout = ChartLayout {
        plot_left,
        plot_width: plot_w,
        panels: Vec::new(),
        phones_drawn: Vec::new(),
        phones_left_out: 0,
    };
    if let Some(a) = plot.alignment {
        let (drawn, left_out) = draw_phone_strip(&mut img, a, &x_of, strip_top, phone_h);
        layout.phones_drawn = drawn;
        layout.phones_left_out = left_out;
    }

    for (k, panel) in plot.panels.iter().enumerate() {
        let top = first_top + k as u32 * (plot.panel_height + GAP);
        let bottom = top + plot.panel_height;
        layout.panels.push((top, bottom));
        let (lo, hi) = value_range(panel);
        let y_of = |v: f64| bottom as f64 - (v - lo) / (hi - lo) * plot.panel_height as f64;
        for (v, label) in &ticks[k] {
            let y = y_of(*v).round();
            draw_line(&mut img, plot_left as f64, y, (plot_left + plot_w) as f64, y, GRID);
            draw_line(&mut img, plot_left as f64 - 4.0, y, plot_left as f64, y, INK);
            let tx = i64::from(plot_left) - 6 - i64::from(text_width(label, TICK_PX));
            let ty = (y as i64 - i64::from(tick_h) / 2)
                .clamp(i64::from(top) - 2, i64::from(bottom) - i64::from(tick_h) + 2);
            draw_text(&mut img, tx, ty, label, TICK_PX, INK);
        }
        if let Some(a) = plot.alignment {
            for ph in &a.phones {
                let x = x_of(ph.start);
                draw_line(&mut img, x, top as f64, x, bottom as f64, BOUNDARY);
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
        if let Some(caption) = &panel.caption {
            let (w, h) = (text_width(caption, LABEL_PX), label_h);
            let (cx, cy) = (i64::from(plot_left) + 4, i64::from(top) + 3);
            fill_rect(&mut img, cx - 2, cy - 1, w + 4, h + 2, WHITE);
            draw_text(&mut img, cx, cy, caption, LABEL_PX, INK);
        }
        draw_rect_outline(&mut img, plot_left, top, plot_w, plot.panel_height, INK);
        draw_y_label(&mut img, &panel.y_label, top, plot.panel_height);
    }

    let step = nice_step(duration, 8.0);
    let decimals = decimals_for(step);
    let mut i = 0;
    loop {
        let t = i as f64 * step;
        if t > duration + 1e-9 {
            break;
        }
        let x = x_of(t);
        draw_line(&mut img, x, panels_bottom as f64, x, panels_bottom as f64 + 4.0, INK);
        let label = format!("{t:.decimals$}");
        let lx = x as i64 - i64::from(text_width(&label, TICK_PX)) / 2;
        draw_text(&mut img, lx, i64::from(panels_bottom) + 5, &label, TICK_PX, INK);
        i += 1;
    }
    let xw = text_width(&plot.x_label, LABEL_PX);
    let xl = i64::from(plot_left) + (i64::from(plot_w) - i64::from(xw)) / 2;
    draw_text(
        &mut img,
        xl,
        i64::from(panels_bottom + 4 + tick_h + PAD),
        &plot.x_label,
        LABEL_PX,
        INK,
    );
    (img, layout)
}

/// A panel's y label turned up in the margin's leftmost band, one column per line, each
/// centred on the panel and drawn smaller when longer than it.
fn draw_y_label(img: &mut RgbImage, label: &str, top: u32, panel_h: u32) {
    let label_h = text_height(LABEL_PX);
    for (k, line) in label.lines().enumerate() {
        let room = panel_h.saturating_sub(4).max(1);
        let w = text_width(line, LABEL_PX);
        let px = if w > room { (LABEL_PX * room as f32 / w as f32).max(8.0) } else { LABEL_PX };
        let lw = text_width(line, px);
        let ly = i64::from(top) + (i64::from(panel_h) - i64::from(lw)) / 2;
        let lx = i64::from(PAD + k as u32 * label_h + (label_h - text_height(px)));
        draw_text_up(img, lx, ly, line, px, INK);
    }
}

/// One swatch and name per distinct series (name and colour) of the first panel.
fn draw_legend(img: &mut RgbImage, plot: &TrajectoryPlot, left: u32, top: u32) {
    let mut x = i64::from(left);
    let mut seen: Vec<(&str, [u8; 3])> = Vec::new();
    let h = text_height(LABEL_PX) as i64;
    for s in plot.panels.first().map(|p| &p.series[..]).unwrap_or_default() {
        if seen.contains(&(s.name.as_str(), s.colour)) {
            continue;
        }
        seen.push((s.name.as_str(), s.colour));
        fill_rect(img, x, i64::from(top) + h / 2 - 2, 16, 4, Rgb(s.colour));
        draw_text(img, x + 20, i64::from(top), &s.name, LABEL_PX, INK);
        x += 20 + i64::from(text_width(&s.name, LABEL_PX)) + 20;
    }
}

/// The phone labels as written, centred on their intervals: on the first row where they fit
/// inside their interval or clear of the row's last label, else left out. Returns the labels
/// drawn and how many were left out (silences, written empty, count as neither).
fn draw_phone_strip(
    img: &mut RgbImage,
    a: &Alignment,
    x_of: &dyn Fn(f64) -> f64,
    top: u32,
    row_h: u32,
) -> (Vec<String>, usize) {
    let mut row_right = [f64::NEG_INFINITY; PHONE_ROWS];
    let (mut drawn, mut left_out) = (Vec::new(), 0);
    for ph in &a.phones {
        let label = ph.label.trim();
        if label.is_empty() {
            continue;
        }
        let w = f64::from(text_width(label, PHONE_PX));
        let mid = (x_of(ph.start) + x_of(ph.end)) / 2.0;
        let left = (mid - w / 2.0).round();
        match (0..PHONE_ROWS).find(|&r| left >= row_right[r] + 3.0) {
            Some(r) => {
                let y = top + r as u32 * (row_h + 2);
                draw_text(img, left as i64, i64::from(y), label, PHONE_PX, INK);
                row_right[r] = left + w;
                drawn.push(label.to_string());
            }
            None => left_out += 1,
        }
    }
    (drawn, left_out)
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

/// Round values inside `(lo, hi)`, about four, with their labels.
fn y_ticks((lo, hi): (f64, f64)) -> Vec<(f64, String)> {
    let step = nice_step(hi - lo, 4.0);
    let decimals = decimals_for(step);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            // `-0.0` prints with its sign.
            let v = if v == 0.0 { 0.0 } else { v };
            (v, format!("{v:.decimals$}"))
        })
        .collect()
}

/// A tick spacing of 1, 2 or 5 × 10^k giving about `n` ticks over `span`.
fn nice_step(span: f64, n: f64) -> f64 {
    let raw = (span / n).max(1e-6);
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag)
}

/// Decimals that show a tick step exactly (0 for steps of 1 and more).
fn decimals_for(step: f64) -> usize {
    (-step.log10().floor()).max(0.0) as usize
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
    use super::super::font::find_text;
    use super::*;
    use crate::alignment::Phone;

    fn chart(labels: &[&str]) -> (RgbImage, ChartLayout) {
        let n = labels.len() as f64;
        let al = Alignment {
            phones: labels
                .iter()
                .enumerate()
                .map(|(i, l)| Phone {
                    start: i as f64 / n,
                    end: (i + 1) as f64 / n,
                    label: l.to_string(),
                })
                .collect(),
        };
        let values: Vec<Option<f64>> = (0..=10).map(|f| Some(f as f64 / 10.0)).collect();
        let plot = TrajectoryPlot {
            title: "s1: video vs 3D head".into(),
            fps: 10.0,
            alignment: Some(&al),
            panels: vec![Panel {
                y_label: "W mouth width\nmin–max scaled".into(),
                caption: Some("r 0.93".into()),
                series: vec![Series { name: "video".into(), colour: [200, 0, 0], values }],
            }],
            width: 500,
            panel_height: 200,
            x_label: "time (s)".into(),
        };
        draw_trajectories_with_layout(&plot)
    }

    #[test]
    fn lines_land_where_values_say() {
        let (img, layout) = chart(&["B", "AA"]);
        let red = |x: u32, y: u32| {
            (x.saturating_sub(3)..x + 3).any(|xx| {
                (y.saturating_sub(3)..y + 3).any(|yy| img.get_pixel(xx, yy).0 == [200, 0, 0])
            })
        };
        let (top, bottom) = layout.panels[0];
        let (lo, hi) = (0.0 - 0.05, 1.0 + 0.05);
        let y_at = |v: f64| (bottom as f64 - (v - lo) / (hi - lo) * 200.0).round() as u32;
        let right = layout.plot_left + layout.plot_width;
        assert!(red(layout.plot_left, y_at(0.0)));
        assert!(red(right, y_at(1.0)));
        assert!(!red(layout.plot_left, top + 5));
        // The phone boundary at 0.5 s is drawn mid-panel.
        let xb = (layout.plot_left as f64 + 0.5 * layout.plot_width as f64).round() as u32;
        assert_eq!(img.get_pixel(xb, bottom - 20).0, BOUNDARY.0);
    }

    #[test]
    fn title_axis_labels_caption_and_phones_are_drawn_as_written() {
        let (img, layout) = chart(&["m", "ə", "θ", "œ", "i", "o", "AA1", ""]);
        assert!(find_text(&img, "s1: video vs 3D head", TITLE_PX, INK, false).is_some());
        assert!(find_text(&img, "r 0.93", LABEL_PX, INK, false).is_some());
        assert!(find_text(&img, "video", LABEL_PX, INK, false).is_some());
        let (x, y) = find_text(&img, "W mouth width", LABEL_PX, INK, true).unwrap();
        assert!(x < layout.plot_left && y > layout.panels[0].0, "y label at ({x}, {y})");
        let (x2, _) = find_text(&img, "min–max scaled", LABEL_PX, INK, true).unwrap();
        assert!(x < x2 && x2 < layout.plot_left, "second line right of the first");
        // The x label is centred under the axis, not at the far left.
        let (x, y) = find_text(&img, "time (s)", LABEL_PX, INK, false).unwrap();
        let centre = layout.plot_left + layout.plot_width / 2;
        assert!(x < centre && x + text_width("time (s)", LABEL_PX) > centre, "x label at {x}");
        assert!(y > layout.panels[0].1);
        for t in ["0.0", "0.5", "1.0"] {
            assert!(find_text(&img, t, TICK_PX, INK, false).is_some(), "tick {t}");
        }
        for p in ["m", "ə", "θ", "œ", "i", "o", "AA1"] {
            assert!(find_text(&img, p, PHONE_PX, INK, false).is_some(), "phone {p}");
        }
        assert_eq!(layout.phones_drawn, ["m", "ə", "θ", "œ", "i", "o", "AA1"]);
        assert_eq!(layout.phones_left_out, 0);
    }

    #[test]
    fn a_y_label_longer_than_its_panel_is_drawn_smaller_inside_it() {
        let long = "a y label longer than its panel";
        let plot = TrajectoryPlot {
            title: "t".into(),
            fps: 1.0,
            alignment: None,
            panels: vec![Panel {
                y_label: long.into(),
                caption: None,
                series: vec![Series {
                    name: "s".into(),
                    colour: [0, 0, 200],
                    values: vec![Some(1.0)],
                }],
            }],
            width: 300,
            panel_height: 150,
            x_label: "x".into(),
        };
        let (img, layout) = draw_trajectories_with_layout(&plot);
        assert!(find_text(&img, long, LABEL_PX, INK, true).is_none());
        let px = LABEL_PX * 146.0 / text_width(long, LABEL_PX) as f32;
        assert!((8.0..LABEL_PX).contains(&px), "{px}");
        let (_, y) = find_text(&img, long, px, INK, true).expect("drawn smaller");
        let (top, bottom) = layout.panels[0];
        assert!(y >= top && y + text_width(long, px) <= bottom, "{y} in {top}..{bottom}");
    }

    #[test]
    fn crowded_phones_take_a_second_row_then_are_left_out() {
        let labels: Vec<String> = (0..120).map(|i| format!("AY{}", i % 3)).collect();
        let refs: Vec<&str> = labels.iter().map(String::as_str).collect();
        let (_, layout) = chart(&refs);
        assert!(layout.phones_drawn.len() > 10, "{}", layout.phones_drawn.len());
        assert_eq!(layout.phones_drawn.len() + layout.phones_left_out, 120);
        assert!(layout.phones_left_out > 0);
    }

    #[test]
    fn ticks_are_round_numbers() {
        assert_eq!(nice_step(8.0, 8.0), 1.0);
        assert_eq!(nice_step(3.0, 8.0), 0.5);
        let t: Vec<String> = y_ticks((-0.05, 1.05)).into_iter().map(|(_, s)| s).collect();
        assert_eq!(t, ["0.0", "0.5", "1.0"]);
        let t: Vec<String> = y_ticks((1.2, 4.9)).into_iter().map(|(_, s)| s).collect();
        assert_eq!(t, ["2", "3", "4"]);
    }
}
