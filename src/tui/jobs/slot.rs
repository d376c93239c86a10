//! `Slot`: a one-request inbox a job's thread waits on; a new request replaces the pending one,
//! so flipping through 50 frames decodes the newest and a drag does not queue 50 fits.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};

/// A single pending request, replaced by newer ones.
pub(super) struct Slot<T> {
    pending: Mutex<Option<T>>,
    wake: Condvar,
    closed: AtomicBool,
}

impl<T> Slot<T> {
    pub(super) fn new() -> Self {
        Self { pending: Mutex::new(None), wake: Condvar::new(), closed: AtomicBool::new(false) }
    }

    pub(super) fn put(&self, req: T) {
        if let Ok(mut p) = self.pending.lock() {
            *p = Some(req);
            self.wake.notify_one();
        }
    }

    /// Blocks until a request arrives; `None` once closed.
    pub(super) fn take(&self) -> Option<T> {
        let mut p = self.pending.lock().ok()?;
        loop {
            if self.closed.load(Ordering::Acquire) {
                return None;
            }
            if let Some(r) = p.take() {
                return Some(r);
            }
            p = self.wake.wait(p).ok()?;
        }
    }

    pub(super) fn has_pending(&self) -> bool {
        self.pending.lock().map(|p| p.is_some()).unwrap_or(false)
    }

    pub(super) fn close(&self) {
        self.closed.store(true, Ordering::Release);
        if let Ok(_p) = self.pending.lock() {
            self.wake.notify_all();
        }
    }
}
