//! Every view drawn into ratatui's TestBackend at 80×24 and 160×48 and compared with the
//! committed snapshots in tests/snapshots/ (review changes with `cargo insta review`).

use lipmap::tui::app::App;
use lipmap::tui::draw;
use lipmap::tui::fixtures::synthetic_app;
use lipmap::tui::{Action, Keymap, update};
use ratatui::Terminal;
use ratatui::backend::TestBackend;

const SIZES: [(u16, u16); 2] = [(80, 24), (160, 48)];

fn app_at(size: (u16, u16)) -> App {
    let mut a = synthetic_app(24, 176, 144, true);
    a.term_size = size;
    a
}

fn apply(app: &mut App, actions: &[Action]) {
    for a in actions {
        let mut next = Some(a.clone());
        while let Some(a) = next {
            next = update(app, a);
        }
    }
}

fn render(app: &App) -> Terminal<TestBackend> {
    let mut t = Terminal::new(TestBackend::new(app.term_size.0, app.term_size.1)).unwrap();
    t.draw(|f| draw(app, &Keymap::default(), f)).unwrap();
    t
}

fn check(name: &str, actions: &[Action]) {
    for size in SIZES {
        let mut app = app_at(size);
        apply(&mut app, actions);
        let t = render(&app);
        insta::assert_snapshot!(format!("{name}_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn frames_view() {
    check("frames", &[]);
}

#[test]
fn frames_view_zoomed_on_the_mouth_after_an_edit() {
    check(
        "frames_zoomed",
        &[Action::ZoomIn, Action::ZoomIn, Action::Nudge { dx: 3, dy: 2 }, Action::CycleScope],
    );
}

#[test]
fn frames_view_on_a_flagged_frame() {
    check("frames_flagged", &[Action::NextFlagged]);
}

#[test]
fn frames_view_while_decoding() {
    for size in SIZES {
        let mut app = app_at(size);
        app.frames.cache.images.clear();
        app.frames.cache.order.clear();
        let t = render(&app);
        insta::assert_snapshot!(format!("frames_loading_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn frames_view_with_the_side_panel_hidden() {
    check("frames_no_panel", &[Action::ToggleSidePanel]);
}

#[test]
fn a_long_status_message_wraps_instead_of_being_cut() {
    let long = "suggested 59 landmarks (lowest confidence 0.31), left 9: 4 anatomy, 5 not \
                visible; e.g. 61 not tracked as visible in this frame; u undoes";
    for size in SIZES {
        let mut app = app_at(size);
        app.status = long.into();
        let t = render(&app);
        let text: String = t.backend().buffer().content().iter().map(|c| c.symbol()).collect();
        let squeezed: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(squeezed.contains("this frame; u undoes"), "{size:?}: the end is shown");
        insta::assert_snapshot!(format!("status_wrapped_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn a_status_message_longer_than_its_rows_says_it_is_cut() {
    let mut app = app_at((80, 24));
    app.status = "every word of this warning matters ".repeat(12) + "last";
    let t = render(&app);
    let buffer = t.backend().buffer();
    let row = |y: u16| -> String { (0..80).map(|x| buffer[(x, y)].symbol()).collect() };
    let rows = lipmap::tui::draw::MAX_STATUS_ROWS;
    assert!(row(24 - rows).starts_with("every word"), "{}", row(24 - rows));
    assert!(row(23).trim_end().ends_with('…'), "{}", row(23));
    assert!(!row(23).contains("last"));
}

#[test]
fn help_overlay() {
    check("help", &[Action::ToggleHelp]);
}

#[test]
fn prompt_line() {
    check("prompt", &[Action::PropagatePrompt, Action::PromptChar('1'), Action::PromptChar('2')]);
}

#[test]
fn head_view() {
    check("head", &[Action::ShowHead, Action::Rotate { yaw: 30, pitch: 15 }]);
}

#[test]
fn head_view_help() {
    check("head_help", &[Action::ShowHead, Action::ToggleHelp]);
}

#[test]
fn fit_view() {
    check("fit", &[Action::ShowFit]);
}

#[test]
fn fit_view_running() {
    for size in SIZES {
        let mut app = app_at(size);
        app.fits.by_frame.clear();
        app.fit.running = true;
        app.fit.progress = (7, 24);
        apply(&mut app, &[Action::ShowFit]);
        let t = render(&app);
        insta::assert_snapshot!(format!("fit_running_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn analysis_view() {
    check("analysis", &[Action::ShowAnalysis, Action::RowDown, Action::RowDown]);
}

#[test]
fn analysis_view_empty() {
    for size in SIZES {
        let mut app = app_at(size);
        app.analysis.data = Default::default();
        apply(&mut app, &[Action::ShowAnalysis]);
        let t = render(&app);
        insta::assert_snapshot!(format!("analysis_empty_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn tiny_terminal_does_not_panic() {
    for size in [(1, 1), (10, 3), (20, 5), (49, 12)] {
        for view in [Action::ShowFrames, Action::ShowHead, Action::ShowFit, Action::ShowAnalysis] {
            let mut app = app_at(size);
            apply(&mut app, &[view, Action::ToggleHelp]);
            render(&app);
        }
    }
}

#[test]
fn moving_one_point_sends_only_a_few_cells() {
    use lipmap::tui::fixtures::counting_terminal;
    use std::sync::atomic::Ordering;
    let keymap = Keymap::default();
    let mut app = synthetic_app(4, 320, 240, true);
    app.term_size = (120, 40);
    let (mut term, bytes) = counting_terminal(120, 40).unwrap();
    term.draw(|f| draw(&app, &keymap, f)).unwrap();
    let full = bytes.swap(0, Ordering::Relaxed);
    apply(&mut app, &[Action::Nudge { dx: 0, dy: 2 }]);
    term.draw(|f| draw(&app, &keymap, f)).unwrap();
    let moved = bytes.swap(0, Ordering::Relaxed);
    // The point's old and new cells, the side panel's numbers, the status line.
    assert!(moved < 2_000, "one point moved: {moved} bytes (full draw {full})");
    assert!(full > 20 * moved, "full draw {full} vs one point {moved}");
}

#[test]
fn side_view_with_a_corrected_point() {
    for size in SIZES {
        let mut app = app_at(size);
        app.fps = 25.0;
        app.side = lipmap::tui::screens::side::SideState::Ready(Box::new(
            lipmap::tui::fixtures::synthetic_side(24, 176, 144),
        ));
        apply(&mut app, &[Action::ShowSide, Action::NextFrame]);
        let plain = render(&app);
        insta::assert_snapshot!(format!("side_{}x{}", size.0, size.1), plain.backend());
        apply(&mut app, &[Action::NudgeLipPoint { dx: 10, dy: 0 }]);
        let t = render(&app);
        insta::assert_snapshot!(format!("side_corrected_{}x{}", size.0, size.1), t.backend());
    }
}

#[test]
fn a_long_title_gives_way_to_the_view_tabs() {
    let mut app = app_at((80, 24));
    app.title = "a_session_with_a_long_name · s1_place_red_at_m_zero_soon_and_more".into();
    app.side = lipmap::tui::screens::side::SideState::Measuring;
    let t = render(&app);
    let top: String = (0..80).map(|x| t.backend().buffer()[(x, 0)].symbol().to_string()).collect();
    assert!(top.contains("4 analysis") && top.contains("5 side"), "{top}");
    assert!(top.contains("a_session_with_a_long_name") && top.contains('…'), "{top}");
}

#[test]
fn analysis_view_with_the_speech_driven_head() {
    use lipmap::tui::fixtures::synthetic_speech;
    check(
        "analysis_speech",
        &[Action::SpeechReady { series: synthetic_speech(24) }, Action::ShowAnalysis],
    );
}

#[test]
fn head_view_showing_a_transferred_head() {
    use lipmap::tui::fixtures::{synthetic_model, synthetic_prepared_head};
    use lipmap::tui::jobs::{HeadFrameJob, transfer_frame_for_tui};
    use lipmap::tui::screens::head::TransferredHeads;
    use std::sync::Arc;
    for size in SIZES {
        let mut app = app_at(size);
        app.head.heads = TransferredHeads::named(vec!["sphere".into()]);
        let prepared = Arc::new(synthetic_prepared_head());
        apply(
            &mut app,
            &[
                Action::ShowHead,
                Action::CycleHead,
                Action::HeadPrepared { index: 0, head: Ok(prepared.clone()) },
            ],
        );
        // The jaw of the source opened all the way at frame 0.
        let mut fit = app.fits.by_frame[&0].clone();
        fit.expression = vec![1.0];
        let job = HeadFrameJob { head: 0, prepared, model: Arc::new(synthetic_model()), fit };
        apply(&mut app, &[Action::HeadFrameReady(transfer_frame_for_tui(&job))]);
        let t = render(&app);
        insta::assert_snapshot!(format!("head_transferred_{}x{}", size.0, size.1), t.backend());
    }
}
