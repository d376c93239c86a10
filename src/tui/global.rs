//! Actions that work on every screen: saving and quitting (and how saves went), switching
//! screens and clips, moving through the frames and playing them, undo and redo (the edits
//! themselves are in `app::history`), the terminal's size and status messages.
use super::app::history::undo_redo;
use crate::tui::action::Action;
use crate::tui::app::save::{AfterSave, QuitStep};
use crate::tui::app::{App, Effect};
use crate::tui::screens::View;
use crate::tui::screens::analysis::update::request_analysis;
use crate::tui::screens::analysis::{AnalysisTable, AnalysisView};
use crate::tui::screens::frames::ImageView;
use crate::tui::screens::frames::update::select_point;
use crate::tui::screens::head::transferred::request_head_frame;
use crate::tui::screens::head::{HeadView, TransferredHeads};
use crate::tui::screens::side::SideState;

pub fn quit(app: &mut App) -> Option<Action> {
    app.switch_clip = None;
    app.switch_map = None;
    leave(app)
}

pub fn save(app: &mut App) {
    request_save(app);
}

/// A pause in editing: autosave, unless a drag is under way or the last save failed (then
/// autosave waits for the next edit rather than retrying in a loop).
pub fn idle(app: &mut App) {
    if app.save.autosave_due() && !app.frames.dragging {
        request_save(app);
    }
}

pub fn undo(app: &mut App) {
    undo_redo(app, true);
}

pub fn redo(app: &mut App) {
    undo_redo(app, false);
}

pub fn show_frames(app: &mut App) {
    app.view = View::Frames;
}

pub fn show_head(app: &mut App) {
    app.view = View::Head;
    request_head_frame(app);
}

pub fn show_fit(app: &mut App) {
    app.view = View::Fit;
}

pub fn show_analysis(app: &mut App) {
    app.view = View::Analysis;
    if let Some(why) = super::screens::analysis::update::speech_absent_reason(app) {
        app.status = why;
    }
}

pub fn show_side(app: &mut App) {
    match &app.side {
        SideState::None => app.status = "this clip has no side view".into(),
        _ => {
            app.view = View::Side;
            request_images(app);
        }
    }
}

pub fn next_clip(app: &mut App) -> Option<Action> {
    step_clip(app, 1)
}

pub fn prev_clip(app: &mut App) -> Option<Action> {
    step_clip(app, app.clip_names.len().saturating_sub(1))
}

/// The clip `by` places on (wrapping), or why there is none.
fn step_clip(app: &mut App, by: usize) -> Option<Action> {
    let n = app.clip_names.len();
    if n <= 1 {
        app.status = "the session has one clip".into();
        return None;
    }
    Some(Action::SwitchClip { clip: (app.clip + by) % n })
}

/// The run loop saves, then opens clip `clip` once this one is left.
pub fn switch_clip(app: &mut App, clip: usize) -> Option<Action> {
    app.switch_clip = Some(clip);
    leave(app)
}

/// Leaves for the run loop to reopen the session (another clip, or another map to label):
/// saves first when there is anything unsaved.
pub fn leave_to_reopen(app: &mut App) -> Option<Action> {
    leave(app)
}

/// Leaves, or saves first and leaves on the save's reply.
fn leave(app: &mut App) -> Option<Action> {
    match app.save.quit_requested() {
        QuitStep::Leave => {
            app.effects.push(Effect::Quit);
            None
        }
        // Autosave normally leaves nothing unsaved; save the last batch before leaving.
        QuitStep::SaveFirst => Some(Action::Save),
    }
}

/// Queues a save of everything edited so far; its reply (`Saved`) names its generation.
pub(crate) fn request_save(app: &mut App) {
    let generation = app.save.save_requested();
    app.effects.push(Effect::Save { generation });
}

pub fn saved(app: &mut App, generation: u64) -> Option<Action> {
    let (newest, next) = app.save.saved(generation);
    if newest {
        // The tables follow the corrections (the head's side uses the fits as they are until
        // the next fit).
        request_analysis(app);
    }
    // The status line's right side shows the save state; keep the message.
    match next {
        AfterSave::Leave => app.effects.push(Effect::Quit),
        AfterSave::SaveAgain => return Some(Action::Save),
        AfterSave::Nothing => {}
    }
    None
}

pub fn save_failed(app: &mut App, error: String) {
    app.save.save_failed();
    app.switch_clip = None;
    app.switch_map = None;
    app.status = if app.save.force_quit_armed() {
        format!(
            "save failed: {error} (q again quits without saving; the edits stay in the \
             session's journal and are restored when it is opened again)"
        )
    } else {
        format!("save failed: {error} (s retries; q retries, then quits)")
    };
}

pub fn next_frame(app: &mut App) {
    go_to_pos(app, app.frame_pos.saturating_add(1));
}

pub fn prev_frame(app: &mut App) {
    go_to_pos(app, app.frame_pos.saturating_sub(1));
}

pub fn first_frame(app: &mut App) {
    go_to_pos(app, 0);
}

pub fn last_frame(app: &mut App) {
    go_to_pos(app, app.n_frames().saturating_sub(1));
}

/// Moves to the next flagged frame and selects the point its first point-naming reason
/// names (a jump, lips out of order, a lower lip off the opening).
pub fn next_flagged(app: &mut App) {
    let cur = app.frame();
    match app.flags.iter().find(|f| f.frame > cur).map(|f| f.frame) {
        Some(f) => go_to_flagged(app, f),
        None => app.status = "no flagged frame after this one".into(),
    }
}

pub fn prev_flagged(app: &mut App) {
    let cur = app.frame();
    match app.flags.iter().rev().find(|f| f.frame < cur).map(|f| f.frame) {
        Some(f) => go_to_flagged(app, f),
        None => app.status = "no flagged frame before this one".into(),
    }
}

fn go_to_flagged(app: &mut App, frame: usize) {
    go_to_frame(app, frame);
    let point = app.flags_of(frame).and_then(|f| f.reasons.iter().find_map(|r| r.point()));
    if let Some(p) = point {
        select_point(app, p);
    }
}

pub fn next_unreviewed(app: &mut App) {
    let n = app.n_frames();
    let next = (1..=n)
        .map(|k| (app.frame_pos + k) % n.max(1))
        .find(|&p| !app.reviewed.contains(&app.track.frames[p].frame));
    match next {
        Some(p) => go_to_pos(app, p),
        None => app.status = "every frame is reviewed".into(),
    }
}

/// Hides the views' side panel (the image or head takes its room), or shows it again.
pub fn toggle_side_panel(app: &mut App) {
    app.side_panel = !app.side_panel;
    app.status = if app.side_panel { "side panel shown" } else { "side panel hidden" }.into();
}

pub fn toggle_play(app: &mut App) {
    app.playing = !app.playing && app.n_frames() > 1;
    if app.playing {
        if app.frame_pos + 1 >= app.n_frames() {
            go_to_pos(app, 0);
        }
        app.status = format!("playing at {:.0} fps", app.fps);
    }
}

/// The next frame while playing; the end of the clip stops playback where it is.
pub fn play_tick(app: &mut App) {
    if !app.playing {
        return;
    }
    if app.frame_pos + 1 >= app.n_frames() {
        app.playing = false;
        app.status = "end of the clip".into();
    } else {
        go_to_pos(app, app.frame_pos + 1);
    }
}

/// Goes to frame number `frame`, or says there is none.
pub fn go_to_frame(app: &mut App, frame: usize) {
    match app.track.frames.binary_search_by_key(&frame, |f| f.frame) {
        Ok(p) => go_to_pos(app, p),
        Err(_) => app.status = format!("no frame `{frame}`"),
    }
}

/// Moves to a position in the track and asks for the frame (and neighbours) to be decoded.
fn go_to_pos(app: &mut App, pos: usize) {
    let n = app.n_frames();
    if n == 0 {
        return;
    }
    app.frame_pos = pos.min(n - 1);
    request_images(app);
}

/// Queues decoding of the current frame and prefetch of its neighbours, uncached ones only.
pub fn request_images(app: &mut App) {
    let p = app.frame_pos;
    let wanted: Vec<usize> = [Some(p), p.checked_add(1), p.checked_add(2), p.checked_sub(1)]
        .into_iter()
        .flatten()
        .filter_map(|q| app.track.frames.get(q).map(|f| f.frame))
        .filter(|f| {
            !app.frames.cache.images.contains_key(f) && !app.frames.cache.errors.contains_key(f)
        })
        .collect();
    if !wanted.is_empty() {
        app.effects.push(Effect::LoadFrames(wanted));
    }
    if app.view == View::Side
        && let Some(side) = app.side.view()
        && let Some(k) = side.frame_for(app.frame(), app.fps)
        && !side.images.contains_key(&k)
        && !side.image_errors.contains_key(&k)
    {
        app.effects.push(Effect::LoadSideFrame(k));
    }
    request_head_frame(app);
}

/// The run loop opened the clip in a terminal of `width × height`: the current frame and its
/// neighbours, and the analysis, are asked for.
pub fn opened(app: &mut App, width: u16, height: u16) {
    app.term_size = (width, height);
    request_images(app);
    request_analysis(app);
}

/// How the user looked at a clip, carried to the next clip of the session opened in the same
/// terminal: the screen shown, the image's zoom and pan, the head's angle (not a suggestion,
/// which was for the other clip), the transferred heads' set-ups (the session's, made once
/// whatever the clip), whether the speech-driven series are drawn, and the quality tables
/// (the session's too) with the cursor in them, so the next sentence is one Enter away.
#[derive(Clone, Debug, PartialEq)]
pub struct Carried {
    view: View,
    image_view: ImageView,
    head_view: HeadView,
    /// The map labelled: the head's angle and cursor mean nothing on another mesh.
    label_role: crate::session::MapRole,
    heads: TransferredHeads,
    show_speech: bool,
    quality: Vec<AnalysisTable>,
    /// Where the cursor was among the quality tables (table counted from the first of them).
    quality_cursor: Option<AnalysisView>,
    clip_name: String,
}

impl Carried {
    /// What `previous` carries to the clip named `clip_name`.
    pub fn of(previous: &App, clip_name: &str) -> Self {
        let a = &previous.analysis;
        let own = a.data.tables.len().saturating_sub(a.quality.len());
        let quality_cursor = (!a.quality.is_empty() && a.cursor.table >= own)
            .then(|| AnalysisView { table: a.cursor.table - own, ..a.cursor });
        Self {
            view: previous.view,
            image_view: previous.frames.image_view,
            head_view: HeadView { suggested: None, ..previous.head.view },
            label_role: previous.head.label_role,
            heads: TransferredHeads { current: None, ..previous.head.heads.clone() },
            show_speech: a.show_speech,
            quality: a.quality.clone(),
            quality_cursor,
            clip_name: clip_name.to_string(),
        }
    }
}

/// Opened as the next clip of the same session: looks as the previous one did, and the
/// status line names the clip.
pub fn carry(app: &mut App, from: Box<Carried>) {
    let c = *from;
    app.view = c.view;
    app.frames.image_view = c.image_view;
    if app.head.label_role == c.label_role {
        app.head.view = c.head_view;
    } else {
        app.head.view.label = c.head_view.label;
        app.head.view.wireframe = c.head_view.wireframe;
    }
    if app.head.heads.names == c.heads.names {
        app.head.heads = c.heads;
    }
    let a = &mut app.analysis;
    a.show_speech = c.show_speech;
    let own_now = a.data.tables.len();
    a.data.tables.extend(c.quality.iter().cloned());
    a.quality = c.quality;
    if let Some(view) = c.quality_cursor {
        a.cursor = AnalysisView { table: own_now + view.table, ..view };
        a.quality_cursor = Some(view);
    }
    app.status = if app.head.label_role == c.label_role {
        format!("clip {} of {}: {}", app.clip + 1, app.clip_names.len(), c.clip_name)
    } else {
        format!(
            "labelling the {} map on {} (m: the {} map)",
            app.head.label_role.name(),
            app.head.label_mesh_name,
            c.label_role.name()
        )
    };
}

pub fn resize(app: &mut App, width: u16, height: u16) {
    app.term_size = (width, height);
}

pub fn status(app: &mut App, text: String) {
    app.status = text;
}
