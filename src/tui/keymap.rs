//! The keymap as data: (mode, key) → `Action`. The defaults are `data/keymap.toml`, built into
//! the binary (`BUILTIN`) and parsed at startup; a file named with `--keymap` has the same
//! format and overrides only the keys it names.
//!
//! File format, one table per mode (`global`, `frames`, `head`, `fit`, `analysis`, `side`,
//! `help`), bindings in the order the help lists them:
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
    /// While a face box is being drawn on the frames view.
    FaceBox,
}

impl KeyMode {
    pub const ALL: [KeyMode; 8] = [
        Self::Global,
        Self::Frames,
        Self::Head,
        Self::Fit,
        Self::Analysis,
        Self::Side,
        Self::Help,
        Self::FaceBox,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Global => "global",
            Self::Frames => "frames",
            Self::Head => "head",
            Self::Fit => "fit",
            Self::Analysis => "analysis",
            Self::Side => "side",
            Self::Help => "help",
            Self::FaceBox => "facebox",
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

/// The default keymap file, built into the binary.
pub const BUILTIN: &str = include_str!("../../data/keymap.toml");
/// How errors name the built-in file.
const BUILTIN_NAME: &str = "data/keymap.toml (built in)";

/// Errors reading a keymap file: the file and what was wrong where.
#[derive(Debug, thiserror::Error)]
pub enum KeymapError {
    #[error("{path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("{path}: {source}")]
    Toml { path: String, source: toml::de::Error },
    #[error(
        "{path}: [{table}] is not a mode (expected global, frames, head, fit, analysis, side, help, facebox)"
    )]
    Mode { path: String, table: String },
    #[error("{path}: [{table}] `{key}`: unknown key name")]
    Key { path: String, table: String, key: String },
    #[error("{path}: [{table}] `{key}`: {message}")]
    Action { path: String, table: String, key: String, message: String },
    #[error(
        "{path}: no key quits in the {view} view (every `Quit` is unbound or shadowed there); keep one, e.g. [global] \"q\" = \"Quit\""
    )]
    NoWayOut { path: String, view: &'static str },
}

/// The mode chains keys are looked up along in each view (`update::input::mode_chain`
/// without overlays), for the check that every view keeps a way out.
const VIEW_CHAINS: [&[KeyMode]; 5] = [
    &[KeyMode::Frames, KeyMode::Global],
    &[KeyMode::Head, KeyMode::Global],
    &[KeyMode::Fit, KeyMode::Frames, KeyMode::Global],
    &[KeyMode::Analysis, KeyMode::Global],
    &[KeyMode::Side, KeyMode::Global],
];

/// The active bindings.
#[derive(Clone, Debug, PartialEq)]
pub struct Keymap {
    pub bindings: Vec<Binding>,
}

/// One entry of a keymap file: `None` unbinds the key.
type Entry = (KeyMode, KeyChord, Option<Action>);

/// A mode's table as read: each value with its place in the text, since TOML tables come back
/// sorted by key and the file's order is the help's order.
type SpannedTables = std::collections::BTreeMap<
    String,
    std::collections::BTreeMap<String, toml::Spanned<toml::Value>>,
>;

/// The entries of keymap TOML text in the order they are written (`path` names the file in
/// errors).
fn parse_entries(text: &str, path: &str) -> Result<Vec<Entry>, KeymapError> {
    let tables: SpannedTables = toml::from_str(text)
        .map_err(|source| KeymapError::Toml { path: path.to_string(), source })?;
    let mut entries = Vec::new();
    for (mode_name, table) in tables {
        let mode = KeyMode::parse(&mode_name).ok_or_else(|| KeymapError::Mode {
            path: path.to_string(),
            table: mode_name.clone(),
        })?;
        for (key_name, value) in table {
            let at = value.span().start;
            let key = KeyChord::parse(&key_name).ok_or_else(|| KeymapError::Key {
                path: path.to_string(),
                table: mode_name.clone(),
                key: key_name.clone(),
            })?;
            let value = value.into_inner();
            let action = if value.as_str() == Some("none") {
                None
            } else {
                Some(value.try_into::<Action>().map_err(|e| KeymapError::Action {
                    path: path.to_string(),
                    table: mode_name.clone(),
                    key: key_name.clone(),
                    message: e.to_string(),
                })?)
            };
            entries.push((at, (mode, key, action)));
        }
    }
    entries.sort_by_key(|(at, _)| *at);
    Ok(entries.into_iter().map(|(_, e)| e).collect())
}

impl Default for Keymap {
    /// The built-in keymap (`Keymap::builtin`); empty if the built-in file were broken, which
    /// its tests rule out (`run` loads it with `builtin` and reports such an error).
    fn default() -> Self {
        Self::builtin().unwrap_or(Self { bindings: Vec::new() })
    }
}

impl Keymap {
    /// The default bindings, from the built-in `data/keymap.toml`.
    ///
    /// # Errors
    /// `KeymapError` naming the built-in file, when it does not parse.
    pub fn builtin() -> Result<Self, KeymapError> {
        let mut km = Self { bindings: Vec::new() };
        km.apply_toml(BUILTIN, BUILTIN_NAME)?;
        Ok(km)
    }

    /// The defaults with the file's bindings applied over them.
    ///
    /// # Errors
    /// `KeymapError` naming the file, the table and the key at fault.
    pub fn load(path: &Path) -> Result<Self, KeymapError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|source| KeymapError::Read { path: p.clone(), source })?;
        let mut km = Self::builtin()?;
        km.apply_toml(&text, &p)?;
        km.check_way_out(&p)?;
        Ok(km)
    }

    /// Refuses bindings that leave a view with no key bound to `Quit` along its chain: a
    /// keymap must never lock the user inside the TUI.
    ///
    /// # Errors
    /// `NoWayOut` naming the first such view.
    pub fn check_way_out(&self, path: &str) -> Result<(), KeymapError> {
        for chain in VIEW_CHAINS {
            let quits = chain
                .iter()
                .flat_map(|&m| self.of_mode(m))
                .any(|b| self.lookup(chain, b.key) == Some(&Action::Quit));
            if !quits {
                return Err(KeymapError::NoWayOut {
                    path: path.to_string(),
                    view: chain[0].name(),
                });
            }
        }
        Ok(())
    }

    /// Applies bindings from TOML text in its order: each replaces the key's binding in its
    /// mode, or unbinds it (`"none"`). `path` is only used in errors.
    ///
    /// # Errors
    /// As `load`.
    pub fn apply_toml(&mut self, text: &str, path: &str) -> Result<(), KeymapError> {
        for (mode, key, action) in parse_entries(text, path)? {
            self.bindings.retain(|b| !(b.mode == mode && b.key == key));
            if let Some(action) = action {
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
    fn builtin_file_parses_with_canonical_key_names() {
        let km = Keymap::builtin().unwrap();
        let tables: toml::Table = toml::from_str(BUILTIN).unwrap();
        let names: usize = tables.values().map(|t| t.as_table().map_or(0, |t| t.len())).sum();
        assert_eq!(km.bindings.len(), names, "every entry binds a key");
        for (mode, table) in &tables {
            for name in table.as_table().unwrap().keys() {
                let k = KeyChord::parse(name)
                    .unwrap_or_else(|| panic!("[{mode}] `{name}` does not parse"));
                assert_eq!(k.to_string(), *name, "[{mode}] `{name}` is not canonical");
                assert_eq!(KeyChord::parse(&k.to_string()), Some(k));
            }
        }
    }

    #[test]
    fn a_keymap_cannot_unbind_every_way_out() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("keys.toml");
        std::fs::write(&file, "[global]\n\"q\" = \"none\"\n\"ctrl-c\" = \"none\"\n").unwrap();
        let e = Keymap::load(&file).unwrap_err().to_string();
        assert!(e.starts_with(&file.display().to_string()) && e.contains("no key quits"), "{e}");
        // Shadowed in one view is as bad as unbound.
        std::fs::write(&file, "[head]\n\"q\" = \"Save\"\n\"ctrl-c\" = \"Save\"\n").unwrap();
        let e = Keymap::load(&file).unwrap_err().to_string();
        assert!(e.contains("head view"), "{e}");
        // Moving Quit to another key is fine.
        std::fs::write(
            &file,
            "[global]\n\"q\" = \"none\"\n\"ctrl-c\" = \"none\"\n\"Q\" = \"Quit\"\n",
        )
        .unwrap();
        assert!(Keymap::load(&file).is_ok());
        assert!(Keymap::builtin().unwrap().check_way_out("builtin").is_ok());
    }

    #[test]
    fn key_names_round_trip() {
        for name in ["ctrl--", "-", "alt-shift-f5", "space", "ctrl-alt-enter", "Q", "shift-tab"] {
            let k = KeyChord::parse(name).unwrap();
            assert_eq!(KeyChord::parse(&k.to_string()), Some(k), "{name}");
        }
        assert_eq!(KeyChord::parse("shift-a"), None, "shift on a character is written `A`");
        assert_eq!(KeyChord::parse("hyper-x"), None);
        assert_eq!(KeyChord::parse("f0"), None);
    }

    #[test]
    fn help_text_comes_from_the_file() {
        // A binding added by a file shows in the help, described by its action.
        let mut km = Keymap::builtin().unwrap();
        km.apply_toml("[analysis]\n\"ctrl-o\" = \"OpenRow\"\n", "k.toml").unwrap();
        let last = km.of_mode(KeyMode::Analysis).last().unwrap();
        assert_eq!(
            (last.key.to_string(), last.action.describe()),
            ("ctrl-o".to_string(), "open the row's frame in the frames view".to_string())
        );
    }

    #[test]
    fn a_file_keeps_its_order() {
        let mut km = Keymap { bindings: Vec::new() };
        km.apply_toml("[global]\n\"z\" = \"Quit\"\n\"a\" = \"Save\"\n", "k.toml").unwrap();
        let keys: Vec<String> = km.bindings.iter().map(|b| b.key.to_string()).collect();
        assert_eq!(keys, ["z", "a"]);
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
        let e = km.apply_toml("q = \"Quit\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().starts_with("k.toml: "), "a key outside a table: {e}");
        let e = km.apply_toml("[frames]\n\"q\" = \"PromptSubmit\"\n", "k.toml").unwrap_err();
        assert!(e.to_string().contains("`q`"), "internal actions are not bindable: {e}");
    }
}
