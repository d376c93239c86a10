//! The head view's transferred heads: cycling model → each head → model, setting a head up
//! (once, on a job) and asking for the current frame's shape, which playback then follows.

use crate::tui::app::{App, Effect};

use crate::tui::screens::View;

use crate::tui::screens::head::{HeadFrame, HeadSetup, PreparedHead};
use std::sync::Arc;

/// A head's set-up arrived (or why it failed); the status line says so when it is shown.
pub fn head_prepared(app: &mut App, index: usize, head: Result<Arc<PreparedHead>, String>) {
    let Some(setup) = app.head.heads.setups.get_mut(index) else { return };
    let name = app.head.heads.names[index].clone();
    *setup = match head {
        Ok(p) => {
            if app.head.heads.shown == Some(index) {
                app.status = format!(
                    "transferred head `{name}` ({}, {} vertices) set up",
                    p.mode,
                    p.mesh.vertices.len()
                );
            }
            HeadSetup::Ready(p)
        }
        Err(e) => {
            if app.head.heads.shown == Some(index) {
                app.status = format!("transferred head `{name}`: {e}");
            }
            HeadSetup::Failed(e)
        }
    };
    request_head_frame(app);
}

/// A frame of the shown head; a late one for another head is dropped.
pub fn head_frame_ready(app: &mut App, frame: HeadFrame) {
    if app.head.heads.shown == Some(frame.head) {
        app.head.heads.current = Some(frame);
    }
}

/// Shows the next head, asking for its set-up the first time it is shown.
pub fn cycle_head(app: &mut App) {
    if app.head.heads.names.is_empty() {
        app.status = "no transferred heads in this session \
                      (add one with `lipmap transfer SESSION --head HEAD.obj --out DIR`)"
            .into();
        return;
    }
    app.head.heads.shown = app.head.heads.next_shown();
    app.head.heads.current = None;
    let Some(h) = app.head.heads.shown else {
        app.status = "the model (labelling)".into();
        return;
    };
    let name = &app.head.heads.names[h];
    app.status = match &app.head.heads.setups[h] {
        HeadSetup::NotStarted => {
            app.head.heads.setups[h] = HeadSetup::Preparing;
            app.effects.push(Effect::PrepareHead(h));
            format!("setting up the transfer onto `{name}`…")
        }
        HeadSetup::Preparing => format!("setting up the transfer onto `{name}`…"),
        HeadSetup::Ready(p) => format!("transferred head `{name}` ({})", p.mode),
        HeadSetup::Failed(e) => format!("transferred head `{name}`: {e}"),
    };
    request_head_frame(app);
}

/// Asks for the shown transferred head's shape at the current frame, when the head view
/// shows a set-up head, the frame has a good fit and its shape is not there yet.
pub fn request_head_frame(app: &mut App) {
    if app.view != View::Head {
        return;
    }
    let Some((head, _)) = app.head.heads.shown_ready() else { return };
    let frame = app.frame();
    if app.head.heads.current.as_ref().is_some_and(|c| c.head == head && c.frame == frame) {
        return;
    }
    if app.fits.by_frame.get(&frame).is_some_and(|f| f.is_usable()) {
        app.effects.push(Effect::TransferFrame { head, frame });
    }
}

#[cfg(test)]
mod tests {
    use crate::tui::action::Action;
    use crate::tui::app::Effect;
    use crate::tui::fixtures::{synthetic_app, synthetic_prepared_head};
    use crate::tui::screens::View;
    use crate::tui::screens::head::{HeadFrame, HeadSetup, TransferredHeads};
    use crate::tui::update::update;
    use std::sync::Arc;

    #[test]
    fn the_key_cycles_model_then_each_head_and_sets_each_up_once() {
        let mut app = synthetic_app(10, 320, 240, true);
        app.view = View::Head;
        update(&mut app, Action::CycleHead);
        assert_eq!(app.head.heads.shown, None);
        assert!(app.status.contains("no transferred heads"), "{}", app.status);

        app.head.heads = TransferredHeads::named(vec!["base".into(), "scan".into()]);
        update(&mut app, Action::CycleHead);
        assert_eq!(app.head.heads.shown, Some(0));
        assert_eq!(app.effects, vec![Effect::PrepareHead(0)]);
        assert_eq!(app.head.heads.setups[0], HeadSetup::Preparing);
        // Labels go on the model, never on a transferred head; turning it works.
        let (cursor, yaw) = (app.head.view.cursor, app.head.view.yaw);
        update(&mut app, Action::MoveCursor { dx: 5, dy: 0 });
        update(&mut app, Action::Rotate { yaw: 15, pitch: 0 });
        assert_eq!(app.head.view.cursor, cursor);
        assert!((app.head.view.yaw - yaw - 15.0).abs() < 1e-9);
        app.effects.clear();
        update(&mut app, Action::CycleHead);
        update(&mut app, Action::CycleHead);
        assert_eq!(app.head.heads.shown, None, "after the last head, the model again");
        update(&mut app, Action::CycleHead);
        assert_eq!(app.head.heads.shown, Some(0));
        assert_eq!(app.effects, vec![Effect::PrepareHead(1)], "head 0 is not set up twice");
    }

    #[test]
    fn playback_asks_for_each_fitted_frame_of_the_shown_head() {
        let mut app = synthetic_app(10, 320, 240, true);
        app.view = View::Head;
        app.head.heads = TransferredHeads::named(vec!["base".into()]);
        update(&mut app, Action::CycleHead);
        app.effects.clear();
        let head = Ok(Arc::new(synthetic_prepared_head()));
        update(&mut app, Action::HeadPrepared { index: 0, head });
        assert!(app.status.contains("set up"), "{}", app.status);
        // Frame 0 is fitted in the synthetic app: its shape is asked for at once.
        assert!(app.effects.contains(&Effect::TransferFrame { head: 0, frame: 0 }));
        app.effects.clear();
        update(&mut app, Action::TogglePlay);
        assert!(app.playing);
        update(&mut app, Action::PlayTick);
        assert_eq!(app.frame(), 1);
        assert!(app.effects.contains(&Effect::TransferFrame { head: 0, frame: 1 }));
        // A late reply for another head is dropped; one for the shown head is kept.
        let shape = Ok(Arc::new(crate::model::Mesh::default()));
        update(&mut app, Action::HeadFrameReady(HeadFrame { head: 1, frame: 1, shape }));
        assert_eq!(app.head.heads.current, None);
        let shape = Ok(Arc::new(crate::model::Mesh::default()));
        update(&mut app, Action::HeadFrameReady(HeadFrame { head: 0, frame: 1, shape }));
        assert_eq!(app.head.heads.current.as_ref().map(|c| c.frame), Some(1));
        // The frame of the reply is there: no second request for it.
        app.effects.clear();
        super::request_head_frame(&mut app);
        assert!(app.effects.is_empty());
        // Playback stops at the clip's end.
        for _ in 0..20 {
            update(&mut app, Action::PlayTick);
        }
        assert!(!app.playing);
        assert_eq!(app.frame_pos, app.n_frames() - 1);
    }
}
