//! TUI benchmarks: keypress-to-drawn time when changing frame (720×480 frames, 120×40
//! terminal, half-blocks, warm image cache; target median ≤ 16 ms) and the bytes written to
//! the terminal when one point moves (printed once; ratatui sends only changed cells); and
//! the cost of a Sixel or Kitty encoding of the image region (`tui_graphics`).

use criterion::{Criterion, criterion_group, criterion_main};
use lipmap::tui::draw;
use lipmap::tui::fixtures::{counting_terminal, synthetic_app};
use lipmap::tui::key_to_action;
use lipmap::tui::{Action, App, Keymap, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use std::hint::black_box;
use std::sync::atomic::Ordering;

const FRAMES: usize = 24;

fn apply(app: &mut App, a: Action) {
    let mut next = Some(a);
    while let Some(a) = next {
        next = update(app, a);
    }
}

fn app() -> App {
    let mut a = synthetic_app(FRAMES, 720, 480, true);
    a.term_size = (120, 40);
    a
}

fn bench_draw(c: &mut Criterion) {
    let keymap = Keymap::default();
    let mut group = c.benchmark_group("tui");

    let mut a = app();
    let (mut term, _) = counting_terminal(120, 40).unwrap();
    term.draw(|f| draw(&a, &keymap, f)).unwrap();
    let n_key = KeyEvent::new(KeyCode::Char('n'), KeyModifiers::NONE);
    group.bench_function("next_frame_key_to_drawn_720x480_120x40", |b| {
        b.iter(|| {
            if a.frame_pos + 1 >= a.n_frames() {
                apply(&mut a, Action::FirstFrame);
            }
            let act = key_to_action(&a, &keymap, black_box(&n_key)).unwrap();
            apply(&mut a, act);
            a.effects.clear();
            term.draw(|f| draw(&a, &keymap, f)).unwrap();
        })
    });

    // Bytes for one point moving one step, as ratatui's buffer diff sends them.
    let mut a = app();
    let (mut term, bytes) = counting_terminal(120, 40).unwrap();
    term.draw(|f| draw(&a, &keymap, f)).unwrap();
    let full = bytes.swap(0, Ordering::Relaxed);
    apply(&mut a, Action::Nudge { dx: 1, dy: 0 });
    term.draw(|f| draw(&a, &keymap, f)).unwrap();
    let moved = bytes.swap(0, Ordering::Relaxed);
    apply(&mut a, Action::NextFrame);
    term.draw(|f| draw(&a, &keymap, f)).unwrap();
    let next = bytes.swap(0, Ordering::Relaxed);
    println!(
        "bytes written at 120x40: first full draw {full}, one point moved one step {moved}, next frame {next}"
    );

    group.bench_function("nudge_point_and_draw_120x40", |b| {
        let mut dx = 1;
        b.iter(|| {
            dx = -dx;
            apply(&mut a, Action::Nudge { dx, dy: 0 });
            term.draw(|f| draw(&a, &keymap, f)).unwrap();
        })
    });
    group.finish();
}

/// Encoding the frame image for a terminal graphics protocol: one 120×40-cell region of a
/// 720×480 frame at 10×20 px cells (1200×800 px), rasterised with its 68 markers and
/// encoded; a marker moves every iteration so the cache never hits. Prints the bytes one
/// such image sends to the terminal.
fn bench_graphics(c: &mut Criterion) {
    use lipmap::tui::screens::frames::ImageView;
    use lipmap::tui::screens::frames::view::landmark_markers;
    use lipmap::tui::widgets::graphics::GraphicsState;
    use lipmap::tui::widgets::halfblock::Mapping;
    use ratatui::layout::Rect;
    use ratatui_image::picker::ProtocolType;

    let a = app();
    let image = a.current_image().unwrap().clone();
    let area = Rect::new(0, 0, 120, 40);
    let mapping = Mapping::new(area, 720, 480, &ImageView::default()).unwrap();
    let mut markers = landmark_markers(&a);
    let mut group = c.benchmark_group("tui_graphics");
    group.sample_size(20);
    for (name, protocol) in [("sixel", ProtocolType::Sixel), ("kitty", ProtocolType::Kitty)] {
        let mut gfx = GraphicsState::with_protocol(protocol, (10, 20), false);
        let (mut term, bytes) = counting_terminal(120, 40).unwrap();
        term.draw(|f| {
            gfx.render(&image, 0, mapping, &markers, f.buffer_mut());
        })
        .unwrap();
        println!(
            "{name}: one 120x40-cell image (1200x800 px) sends {} bytes",
            bytes.swap(0, Ordering::Relaxed)
        );
        let mut buf = ratatui::buffer::Buffer::empty(area);
        group.bench_function(format!("encode_{name}_120x40_cells_of_720x480"), |b| {
            let mut dx = 0.5;
            b.iter(|| {
                dx = -dx;
                markers[0].x += dx;
                gfx.render(&image, 0, mapping, black_box(&markers), &mut buf);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_draw, bench_graphics);
criterion_main!(benches);
