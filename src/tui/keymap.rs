//! The keymap as data: (mode, key) → `Action`. Defaults live in one table
//! (`default_bindings`); a TOML file overrides only the keys it names.
//!
//! File format, one table per mode (`global`, `frames`, `head`, `fit`, `analysis`, `help`):
//! ```toml
//! [frames]
//! "x" = "RevertPoint"
//! "ctrl-left" = { Pan = { dx = -1, dy = 0 } }
//! "y" = "none"        # unbind a default
//! ```
//! Key names: a character (`a`, `A`, `?`, `-`), or `space enter esc tab backtab backspace
//! delete insert home end pageup pagedown left right up down f1..f12`, with optional
//! `ctrl-`, `alt-`, `shift-` prefixes (`shift-` only on named keys: `A` already says it).

use super::action::Action;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use std::fmt;
use std::path::Path;

/// Which table a binding belongs to. Lookups try the overlay's table, then the view's, then
/// (for the fit view) the frames table, then `Global`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum KeyMode {
    Global,
    Frames,
    Head,
    Fit,
    Analysis,
    Side,
    Help,
}

impl KeyMode {
    pub const ALL: [KeyMode; 7] =
        [Self::Global, Self::Frames, Self::Head, Self::Fit, Self::Analysis, Self::Side, Self::Help];

    pub fn name(self) -> &'static str {
        match self {
            Self::Global => "global",
            Self::Frames => "frames",
            Self::Head => "head",
            Self::Fit => "fit",
            Self::Analysis => "analysis",
            Self::Side => "side",
            Self::Help => "help",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }
}

/// A key with its modifiers, normalised so that equal keypresses compare equal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KeyChord {
    pub code: KeyCode,
    pub mods: KeyModifiers,
}

impl KeyChord {
    /// Normalises: only ctrl/alt/shift count; shift is dropped on characters and back-tab,
    /// whose code already carries it (terminals disagree on reporting it).
    pub fn new(code: KeyCode, mods: KeyModifiers) -> Self {
        let mut mods = mods & (KeyModifiers::CONTROL | KeyModifiers::ALT | KeyModifiers::SHIFT);
        if matches!(code, KeyCode::Char(_) | KeyCode::BackTab) {
            mods.remove(KeyModifiers::SHIFT);
        }
        Self { code, mods }
    }

    pub fn from_event(ev: &KeyEvent) -> Self {
        Self::new(ev.code, ev.modifiers)
    }

    /// Parses a key name (see the module docs); `None` when unknown.
    pub fn parse(s: &str) -> Option<Self> {
        let mut rest = s;
        let mut mods = KeyModifiers::NONE;
        loop {
            let lower = rest.to_ascii_lowercase();
            let (prefix, m) = if lower.starts_with("ctrl-") {
                ("ctrl-", KeyModifiers::CONTROL)
            } else if lower.starts_with("alt-") {
                ("alt-", KeyModifiers::ALT)
            } else if lower.starts_with("shift-") {
                ("shift-", KeyModifiers::SHIFT)
            } else {
                break;
            };
            if rest.len() == prefix.len() {
                break;
            }
            mods |= m;
            rest = &rest[prefix.len()..];
        }
        let mut chars = rest.chars();
        let code = match (chars.next(), chars.next()) {
            (Some(c), None) => KeyCode::Char(c),
            _ => match rest.to_ascii_lowercase().as_str() {
                "space" => KeyCode::Char(' '),
                "enter" => KeyCode::Enter,
                "esc" => KeyCode::Esc,
                "tab" => KeyCode::Tab,
                "backtab" => KeyCode::BackTab,
                "backspace" => KeyCode::Backspace,
                "delete" => KeyCode::Delete,
                "insert" => KeyCode::Insert,
                "home" => KeyCode::Home,
                "end" => KeyCode::End,
                "pageup" => KeyCode::PageUp,
                "pagedown" => KeyCode::PageDown,
                "left" => KeyCode::Left,
                "right" => KeyCode::Right,
                "up" => KeyCode::Up,
                "down" => KeyCode::Down,
                f if f.starts_with('f') => KeyCode::F(f[1..].parse().ok().filter(|n| *n >= 1)?),
                _ => return None,
            },
        };
        if matches!(code, KeyCode::Char(_) | KeyCode::BackTab) && mods.contains(KeyModifiers::SHIFT)
        {
            return None;
        }
        Some(Self::new(code, mods))
    }
}

impl fmt::Display for KeyChord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.mods.contains(KeyModifiers::CONTROL) {
            f.write_str("ctrl-")?;
        }
        if self.mods.contains(KeyModifiers::ALT) {
            f.write_str("alt-")?;
        }
        if self.mods.contains(KeyModifiers::SHIFT) {
            f.write_str("shift-")?;
        }
        match self.code {
            KeyCode::Char(' ') => f.write_str("space"),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::Enter => f.write_str("enter"),
            KeyCode::Esc => f.write_str("esc"),
            KeyCode::Tab => f.write_str("tab"),
            KeyCode::BackTab => f.write_str("backtab"),
            KeyCode::Backspace => f.write_str("backspace"),
            KeyCode::Delete => f.write_str("delete"),
            KeyCode::Insert => f.write_str("insert"),
            KeyCode::Home => f.write_str("home"),
            KeyCode::End => f.write_str("end"),
            KeyCode::PageUp => f.write_str("pageup"),
            KeyCode::PageDown => f.write_str("pagedown"),
            KeyCode::Left => f.write_str("left"),
            KeyCode::Right => f.write_str("right"),
            KeyCode::Up => f.write_str("up"),
            KeyCode::Down => f.write_str("down"),
            KeyCode::F(n) => write!(f, "f{n}"),
            other => write!(f, "{other:?}"),
        }
    }
}

/// One binding.
#[derive(Clone, Debug, PartialEq)]
pub struct Binding {
    pub mode: KeyMode,
    pub key: KeyChord,
    pub action: Action,
}

/// The default bindings, in help order: (mode, key name, action).
pub fn default_bindings() -> Vec<(KeyMode, &'static str, Action)> {
    use Action as A;
    use KeyMode::*;
    let nudge = |dx, dy| A::Nudge { dx, dy };
    let pan = |dx, dy| A::Pan { dx, dy };
    let rot = |yaw, pitch| A::Rotate { yaw, pitch };
    let cur = |dx, dy| A::MoveCursor { dx, dy };
    let lip = |dx, dy| A::NudgeLipPoint { dx, dy };
    vec![
        (Global, "q", A::Quit),
        (Global, "?", A::ToggleHelp),
        (Global, "s", A::Save),
        (Global, "u", A::Undo),
        (Global, "ctrl-r", A::Redo),
        (Global, "f", A::RunFit),
        (Global, "1", A::ShowFrames),
        (Global, "2", A::ShowHead),
        (Global, "3", A::ShowFit),
        (Global, "4", A::ShowAnalysis),
        (Global, "5", A::ShowSide),
        (Global, ">", A::NextClip),
        (Global, "<", A::PrevClip),
        (Global, "n", A::NextFrame),
        (Global, "p", A::PrevFrame),
        (Global, "pagedown", A::NextFrame),
        (Global, "pageup", A::PrevFrame),
        (Global, "home", A::FirstFrame),
        (Global, "end", A::LastFrame),
        (Global, "]", A::NextFlagged),
        (Global, "[", A::PrevFlagged),
        (Global, "N", A::NextUnreviewed),
        (Global, "G", A::GotoFramePrompt),
        (Global, "esc", A::Cancel),
        (Global, "ctrl-c", A::Quit),
        // Frames view: correcting landmarks.
        (Frames, "left", nudge(-1, 0)),
        (Frames, "right", nudge(1, 0)),
        (Frames, "up", nudge(0, -1)),
        (Frames, "down", nudge(0, 1)),
        (Frames, "h", nudge(-1, 0)),
        (Frames, "l", nudge(1, 0)),
        (Frames, "k", nudge(0, -1)),
        (Frames, "j", nudge(0, 1)),
        (Frames, "shift-left", nudge(-10, 0)),
        (Frames, "shift-right", nudge(10, 0)),
        (Frames, "shift-up", nudge(0, -10)),
        (Frames, "shift-down", nudge(0, 10)),
        (Frames, "H", nudge(-10, 0)),
        (Frames, "L", nudge(10, 0)),
        (Frames, "K", nudge(0, -10)),
        (Frames, "J", nudge(0, 10)),
        (Frames, "tab", A::NextPoint),
        (Frames, "backtab", A::PrevPoint),
        (Frames, "g", A::GotoPointPrompt),
        (Frames, "m", A::CycleScope),
        (Frames, "v", A::ToggleVisible),
        (Frames, "y", A::CopyPointFromPrev),
        (Frames, "Y", A::CopyFrameFromPrev),
        (Frames, "t", A::PropagatePrompt),
        (Frames, "i", A::InterpolateSelected),
        (Frames, "I", A::InterpolateAll),
        (Frames, "x", A::RevertPoint),
        (Frames, "r", A::ToggleReviewed),
        (Frames, "+", A::ZoomIn),
        (Frames, "=", A::ZoomIn),
        (Frames, "-", A::ZoomOut),
        (Frames, "0", A::ZoomReset),
        (Frames, "c", A::CenterOnPoint),
        (Frames, "ctrl-left", pan(-1, 0)),
        (Frames, "ctrl-right", pan(1, 0)),
        (Frames, "ctrl-up", pan(0, -1)),
        (Frames, "ctrl-down", pan(0, 1)),
        (Frames, "alt-h", pan(-1, 0)),
        (Frames, "alt-l", pan(1, 0)),
        (Frames, "alt-k", pan(0, -1)),
        (Frames, "alt-j", pan(0, 1)),
        // Head view: rotate, label.
        (Head, "left", cur(-2, 0)),
        (Head, "right", cur(2, 0)),
        (Head, "up", cur(0, -2)),
        (Head, "down", cur(0, 2)),
        (Head, "h", cur(-2, 0)),
        (Head, "l", cur(2, 0)),
        (Head, "k", cur(0, -2)),
        (Head, "j", cur(0, 2)),
        (Head, "shift-left", cur(-10, 0)),
        (Head, "shift-right", cur(10, 0)),
        (Head, "shift-up", cur(0, -10)),
        (Head, "shift-down", cur(0, 10)),
        (Head, "a", rot(-15, 0)),
        (Head, "d", rot(15, 0)),
        (Head, "w", rot(0, -15)),
        (Head, "e", rot(0, 15)),
        (Head, "H", rot(-90, 0)),
        (Head, "L", rot(90, 0)),
        (Head, "tab", A::NextLabel),
        (Head, "backtab", A::PrevLabel),
        (Head, "g", A::GotoLabelPrompt),
        (Head, "enter", A::ConfirmLabel),
        (Head, "x", A::ClearLabel),
        (Head, "o", A::SuggestLabel),
        (Head, "O", A::SuggestAllLabels),
        (Head, "S", A::SaveMap),
        (Head, "R", A::LoadMap),
        (Head, "+", A::ZoomIn),
        (Head, "=", A::ZoomIn),
        (Head, "-", A::ZoomOut),
        (Head, "0", A::ResetView),
        // Analysis view.
        (Analysis, "down", A::RowDown),
        (Analysis, "up", A::RowUp),
        (Analysis, "j", A::RowDown),
        (Analysis, "k", A::RowUp),
        (Analysis, "tab", A::NextTable),
        (Analysis, "o", A::SortNextColumn),
        (Analysis, "O", A::SortReverse),
        (Analysis, "enter", A::OpenRow),
        // Side view: correct the upper lip's foremost point.
        (Side, "left", lip(-1, 0)),
        (Side, "right", lip(1, 0)),
        (Side, "up", lip(0, -1)),
        (Side, "down", lip(0, 1)),
        (Side, "h", lip(-1, 0)),
        (Side, "l", lip(1, 0)),
        (Side, "k", lip(0, -1)),
        (Side, "j", lip(0, 1)),
        (Side, "shift-left", lip(-10, 0)),
        (Side, "shift-right", lip(10, 0)),
        (Side, "shift-up", lip(0, -10)),
        (Side, "shift-down", lip(0, 10)),
        (Side, "x", A::RevertLipPoint),
        (Side, "r", A::ToggleReviewed),
        // Help overlay.
        (Help, "j", A::ScrollDown),
        (Help, "k", A::ScrollUp),
        (Help, "down", A::ScrollDown),
        (Help, "up", A::ScrollUp),
        (Help, "?", A::ToggleHelp),
        (Help, "esc", A::ToggleHelp),
        (Help, "q", A::ToggleHelp),
    ]
}

/// Errors reading a keymap file: the file and what was wrong where.
#[derive(Debug, thiserror::Error)]
pub enum KeymapError {
    #[error("{path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("{path}: {source}")]
    Toml { path: String, source: toml::de::Error },
    #[error(
        "{path}: [{table}] is not a mode (expected global, frames, head, fit, analysis, side, help)"
    )]
    Mode { path: String, table: String },
    #[error("{path}: [{table}] `{key}`: unknown key name")]
    Key { path: String, table: String, key: String },
    #[error("{path}: [{table}] `{key}`: {message}")]
    Action { path: String, table: String, key: String, message: String },
}

/// The active bindings.
#[derive(Clone, Debug, PartialEq)]
pub struct Keymap {
    pub bindings: Vec<Binding>,
}

impl Default for Keymap {
    fn default() -> Self {
        let bindings = default_bindings()
            .into_iter()
            .map(|(mode, key, action)| Binding {
                mode,
                // The table is tested to parse; an unparsable entry would be a bug caught there.
                key: KeyChord::parse(key)
                    .unwrap_or(KeyChord::new(KeyCode::Null, KeyModifiers::NONE)),
                action,
            })
            .collect();
        Self { bindings }
    }
}

impl Keymap {
    /// The defaults with the file's bindings applied over them.
    ///
    /// # Errors
    /// `KeymapError` naming the file, the table and the key at fault.
    pub fn load(path: &Path) -> Result<Self, KeymapError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|source| KeymapError::Read { path: p.clone(), source })?;
        let mut km = Self::default();
        km.apply_toml(&text, &p)?;
        Ok(km)
    }

    /// Applies overrides from TOML text (`path` is only used in errors).
    ///
    /// # Errors
    /// As `load`.
    pub fn apply_toml(&mut self, text: &str, path: &str) -> Result<(), KeymapError> {
        let table: toml::Table = toml::from_str(text)
            .map_err(|source| KeymapError::Toml { path: path.to_string(), source })?;
        for (mode_name, entries) in table {
            let mode = KeyMode::parse(&mode_name).ok_or_else(|| KeymapError::Mode {
                path: path.to_string(),
                table: mode_name.clone(),
            })?;
            let Some(entries) = entries.as_table() else {
                return Err(KeymapError::Mode { path: path.to_string(), table: mode_name });
            };
            for (key_name, value) in entries {
                let key = KeyChord::parse(key_name).ok_or_else(|| KeymapError::Key {
                    path: path.to_string(),
                    table: mode_name.clone(),
                    key: key_name.clone(),
                })?;
                self.bindings.retain(|b| !(b.mode == mode && b.key == key));
                if value.as_str() == Some("none") {
                    continue;
                }
                let action =
                    value.clone().try_into::<Action>().map_err(|e| KeymapError::Action {
                        path: path.to_string(),
                        table: mode_name.clone(),
                        key: key_name.clone(),
                        message: e.to_string(),
                    })?;
                self.bindings.push(Binding { mode, key, action });
            }
        }
        Ok(())
    }

    /// The action bound to `key` in `mode` alone.
    pub fn get(&self, mode: KeyMode, key: KeyChord) -> Option<&Action> {
        self.bindings.iter().find(|b| b.mode == mode && b.key == key).map(|b| &b.action)
    }

    /// The first binding of `key` along a chain of modes.
    pub fn lookup(&self, modes: &[KeyMode], key: KeyChord) -> Option<&Action> {
        modes.iter().find_map(|&m| self.get(m, key))
    }

    /// Bindings of one mode, in table order.
    pub fn of_mode(&self, mode: KeyMode) -> impl Iterator<Item = &Binding> {
        self.bindings.iter().filter(move |b| b.mode == mode)
    }

    /// The first key bound to `action` along a chain of modes, for hints.
    pub fn key_for(&self, modes: &[KeyMode], action: &Action) -> Option<KeyChord> {
        modes.iter().find_map(|&m| self.of_mode(m).find(|b| &b.action == action).map(|b| b.key))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn default_key_names_parse_and_round_trip() {
        for (mode, name, _) in default_bindings() {
            let k = KeyChord::parse(name)
                .unwrap_or_else(|| panic!("[{}] `{name}` does not parse", mode.name()));
            assert_eq!(k.to_string(), name, "[{}] `{name}` is not canonical", mode.name());
            assert_eq!(KeyChord::parse(&k.to_string()), Some(k));
        }
        for name in ["ctrl--", "-", "alt-shift-f5", "space", "ctrl-alt-enter", "Q", "shift-tab"] {
            let k = KeyChord::parse(name).unwrap();
            assert_eq!(KeyChord::parse(&k.to_string()), Some(k), "{name}");
        }
        assert_eq!(KeyChord::parse("shift-a"), None, "shift on a character is written `A`");
        assert_eq!(KeyChord::parse("hyper-x"), None);
        assert_eq!(KeyChord::parse("f0"), None);
    }

    /// Every default binding in order, one line each: the snapshot records the bindings the
    /// keymap had before it became a data file, so the file must reproduce them exactly.
    #[test]
    fn default_bindings_are_unchanged() {
        let lines: Vec<String> = Keymap::default()
            .bindings
            .iter()
            .map(|b| format!("[{}] {} = {:?}", b.mode.name(), b.key, b.action))
            .collect();
        insta::assert_snapshot!(lines.join("\n"));
    }

    #[test]
    fn no_key_is_bound_twice_in_a_mode() {
        let mut seen = HashSet::new();
        for b in Keymap::default().bindings {
            assert!(seen.insert((b.mode, b.key)), "[{}] {} bound twice", b.mode.name(), b.key);
        }
    }

    #[test]
    fn events_normalise_like_names() {
        let ev = KeyEvent::new(KeyCode::Char('?'), KeyModifiers::SHIFT);
        assert_eq!(KeyChord::from_event(&ev), KeyChord::parse("?").unwrap());
        let ev = KeyEvent::new(KeyCode::BackTab, KeyModifiers::SHIFT);
        assert_eq!(KeyChord::from_event(&ev), KeyChord::parse("backtab").unwrap());
        let ev = KeyEvent::new(KeyCode::Char('r'), KeyModifiers::CONTROL);
        assert_eq!(
            Keymap::default().get(KeyMode::Global, KeyChord::from_event(&ev)),
            Some(&Action::Redo)
        );
    }

    #[test]
    fn a_file_overrides_only_what_it_names() {
        let mut km = Keymap::default();
        let text = r#"
            [frames]
            "x" = "ToggleReviewed"
            "ctrl-left" = { Pan = { dx = -3, dy = 0 } }
            "y" = "none"
            [global]
            "F" = "RunFit"
        "#;
        km.apply_toml(text, "keys.toml").unwrap();
        let get = |m, k| km.get(m, KeyChord::parse(k).unwrap()).cloned();
        assert_eq!(get(KeyMode::Frames, "x"), Some(Action::ToggleReviewed));
        assert_eq!(get(KeyMode::Frames, "ctrl-left"), Some(Action::Pan { dx: -3, dy: 0 }));
        assert_eq!(get(KeyMode::Frames, "y"), None);
        assert_eq!(get(KeyMode::Global, "F"), Some(Action::RunFit));
        // Untouched defaults stay.
        assert_eq!(get(KeyMode::Global, "f"), Some(Action::RunFit));
        assert_eq!(get(KeyMode::Frames, "v"), Some(Action::ToggleVisible));
        let mut seen = HashSet::new();
        assert!(km.bindings.iter().all(|b| seen.insert((b.mode, b.key))));
    }

    #[test]
    fn bad_files_name_the_table_and_key() {
        let mut km = Keymap::default();
        let e = km.apply_toml("[frames]\n\"hyper-q\" = \"Quit\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().contains("k.toml: [frames] `hyper-q`"), "{e}");
        let e = km.apply_toml("[frames]\n\"q\" = \"Fly\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().contains("[frames] `q`"), "{e}");
        let e = km.apply_toml("[nowhere]\n\"q\" = \"Quit\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().contains("[nowhere]"), "{e}");
        let e = km.apply_toml("[frames]\n\"q\" = \"PromptSubmit\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().contains("`q`"), "internal actions are not bindable: {e}");
    }
}
