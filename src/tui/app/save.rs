//! `SaveState`: where the session's edits stand against the file on disk, and whether the
//! user is leaving. One value with methods named for the events that move it (an edit, a save
//! requested, saved, failed, quit), so the rules of autosave and of quitting live here alone.
//!
//! Saves run on a saver thread, so a save is in flight while the user keeps editing: a reply
//! clears only the edits its request covered, and replies of older requests than the newest
//! clear nothing.

/// The session's save and quit state; changed only through its methods.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SaveState {
    /// Changes since the last save finished (autosave when > 0 and idle).
    unsaved: u64,
    /// Generation of the newest requested save; its reply names it.
    generation: u64,
    /// A save is on its way to disk.
    in_flight: bool,
    /// `unsaved` when the newest save was requested: what its reply may clear.
    covered: u64,
    /// The last save failed: autosave waits for a new edit, and quitting does not retry.
    failed: bool,
    /// The user asked to leave; the save in flight decides when.
    quit_requested: bool,
    /// After a failed save the user was told that `q` once more leaves without saving.
    force_quit_armed: bool,
    /// Every change ever made (never cleared): the journal records one line per step.
    changes: u64,
    /// Everything is saved (or the user gave up on saving): the run loop may leave.
    should_quit: bool,
}

/// What to do on a quit request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuitStep {
    /// Leave now.
    Leave,
    /// Save first; leaving follows the save's reply.
    SaveFirst,
}

/// What to do after a save's reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AfterSave {
    /// Nothing more (not quitting, or the newest save is still on its way).
    Nothing,
    /// The user is quitting and everything is saved: leave.
    Leave,
    /// The user is quitting and edits came in meanwhile: save again.
    SaveAgain,
}

impl SaveState {
    /// A new undoable edit: one more change to save, and a new batch worth an autosave
    /// attempt after a failed save.
    pub fn edit_made(&mut self) {
        self.unsaved += 1;
        self.changes += 1;
        self.failed = false;
        self.force_quit_armed = false;
    }

    /// A change to save that starts no new edit batch (an undo or redo, a drag extending its
    /// edit, fits written to the session's cache): after a failed save it waits for an edit.
    pub fn change_made(&mut self) {
        self.unsaved += 1;
        self.changes += 1;
    }

    /// A save of everything so far is requested; returns the generation its reply will name.
    pub fn save_requested(&mut self) -> u64 {
        self.generation += 1;
        self.in_flight = true;
        self.covered = self.unsaved;
        self.generation
    }

    /// A save of `generation` reached the disk. Returns whether it was the newest request
    /// (then what it covered is saved; edits made meanwhile stay unsaved) and what follows.
    pub fn saved(&mut self, generation: u64) -> (bool, AfterSave) {
        let newest = generation >= self.generation;
        if newest {
            self.unsaved = self.unsaved.saturating_sub(self.covered);
            self.covered = 0;
            self.in_flight = false;
        }
        self.failed = false;
        let next = if !self.quit_requested {
            AfterSave::Nothing
        } else if self.unsaved == 0 {
            self.should_quit = true;
            AfterSave::Leave
        } else if !self.in_flight {
            AfterSave::SaveAgain
        } else {
            AfterSave::Nothing
        };
        (newest, next)
    }

    /// The save failed: the user stays (a pending quit or clip switch is called off).
    pub fn save_failed(&mut self) {
        self.in_flight = false;
        if self.quit_requested {
            // The user asked to leave and the save failed: the next request may force it.
            self.force_quit_armed = true;
        }
        self.quit_requested = false;
        self.failed = true;
    }

    /// The user asks to leave: at once when nothing is unsaved, else after a save. After a
    /// failed save one key never discards edits: the first request tries the save again,
    /// and only a request after that one failed too leaves without saving (a failing disk
    /// must not trap the user either).
    pub fn quit_requested(&mut self) -> QuitStep {
        if self.unsaved == 0 || (self.failed && self.force_quit_armed) {
            self.should_quit = true;
            QuitStep::Leave
        } else {
            self.force_quit_armed = self.failed;
            self.quit_requested = true;
            QuitStep::SaveFirst
        }
    }

    /// Whether the next quit request leaves without saving (the last save failed and the
    /// user was warned).
    pub fn force_quit_armed(&self) -> bool {
        self.force_quit_armed
    }

    /// Every change made since the editor opened, never reset by a save.
    pub fn changes(&self) -> u64 {
        self.changes
    }

    /// Whether an idle moment should start a save: something is unsaved, no save is on its
    /// way, and the last one did not fail (then the next edit re-arms it).
    pub fn autosave_due(&self) -> bool {
        self.unsaved > 0 && !self.in_flight && !self.failed
    }

    /// Changes not yet on disk.
    pub fn unsaved(&self) -> u64 {
        self.unsaved
    }

    /// Nothing left to save.
    pub fn is_clean(&self) -> bool {
        self.unsaved == 0
    }

    /// Generation of the newest requested save.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// A save is on its way to disk.
    pub fn in_flight(&self) -> bool {
        self.in_flight
    }

    /// The last save failed.
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// The run loop may leave.
    pub fn should_quit(&self) -> bool {
        self.should_quit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reply_clears_only_what_its_request_covered() {
        let mut s = SaveState::default();
        s.edit_made();
        s.edit_made();
        let g = s.save_requested();
        s.edit_made();
        assert_eq!(s.saved(g), (true, AfterSave::Nothing));
        assert_eq!(s.unsaved(), 1, "the edit made while saving stays unsaved");
        assert!(s.autosave_due());
    }

    #[test]
    fn an_older_reply_clears_nothing() {
        let mut s = SaveState::default();
        s.edit_made();
        let old = s.save_requested();
        s.edit_made();
        let new = s.save_requested();
        assert_eq!(s.saved(old), (false, AfterSave::Nothing));
        assert!(s.in_flight() && s.unsaved() == 2);
        assert_eq!(s.saved(new), (true, AfterSave::Nothing));
        assert!(s.is_clean() && !s.in_flight());
    }

    #[test]
    fn quitting_waits_for_the_save_and_a_failure_lets_the_user_go() {
        let mut s = SaveState::default();
        assert_eq!(s.quit_requested(), QuitStep::Leave);
        assert!(s.should_quit());
        let mut s = SaveState::default();
        s.edit_made();
        assert_eq!(s.quit_requested(), QuitStep::SaveFirst);
        let g = s.save_requested();
        assert!(!s.should_quit());
        assert_eq!(s.saved(g), (true, AfterSave::Leave));
        assert!(s.should_quit());
        let mut s = SaveState::default();
        s.edit_made();
        s.quit_requested();
        s.save_requested();
        s.save_failed();
        assert!(!s.should_quit() && s.failed() && !s.autosave_due());
        assert_eq!(s.quit_requested(), QuitStep::Leave);
    }

    #[test]
    fn after_a_failed_autosave_one_quit_only_retries() {
        let mut s = SaveState::default();
        s.edit_made();
        s.save_requested();
        s.save_failed();
        assert_eq!(s.quit_requested(), QuitStep::SaveFirst, "one q must not discard edits");
        assert!(!s.should_quit());
        s.save_requested();
        s.save_failed();
        assert!(s.force_quit_armed());
        assert_eq!(s.quit_requested(), QuitStep::Leave, "q after the warning forces");
        let mut s = SaveState::default();
        s.edit_made();
        s.save_requested();
        s.save_failed();
        s.quit_requested();
        let g = s.save_requested();
        assert_eq!(s.saved(g), (true, AfterSave::Leave), "a retry that works leaves");
    }

    #[test]
    fn only_a_new_edit_rearms_autosave_after_a_failure() {
        let mut s = SaveState::default();
        s.edit_made();
        s.save_requested();
        s.save_failed();
        s.change_made();
        assert!(!s.autosave_due(), "an undo is not a new batch");
        s.edit_made();
        assert!(s.autosave_due());
    }

    #[test]
    fn edits_during_a_quitting_save_are_saved_again() {
        let mut s = SaveState::default();
        s.edit_made();
        s.quit_requested();
        let g = s.save_requested();
        s.change_made();
        assert_eq!(s.saved(g), (true, AfterSave::SaveAgain));
        assert!(!s.should_quit());
    }
}
