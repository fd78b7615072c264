//! Interrupting a step in progress: a flag the caller raises from another thread (a signal
//! handler, a watcher, a user interface), polled by the event loop and, every
//! [`POLL_INTERVAL`] distance evaluations, by the shape narrow phase's searches.
//!
//! The flag of the world being stepped is visible to every thread working on its step (the
//! calling one, or each of its own pool's) for the length of the step only, so a search knows
//! no world and worlds stepped side by side never see each other's flags. A search that sees it
//! raised gives up at once; its answer is void, since the world then undoes the whole step.
//!
//! Each thread of a world's pool is handed the world's [`Slot`] once, when the pool starts, and a
//! step only fills the slot: showing the flag must not send work to the pool, since a broadcast
//! from a thread of another pool (Python's calls step from rayon's global pool) was seen to wait
//! forever.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// Distance evaluations of a search between two looks at the flag.
pub(crate) const POLL_INTERVAL: u32 = 4096;

/// Where the threads working on one world's steps find the flag of the step in progress: empty
/// between steps and in steps that cannot be undone.
#[derive(Debug, Default)]
pub(crate) struct Slot(Mutex<Option<Arc<AtomicBool>>>);

impl Slot {
    fn flag(&self) -> Option<Arc<AtomicBool>> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }

    fn fill(&self, flag: Option<Arc<AtomicBool>>) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = flag;
    }
}

thread_local! {
    static SLOT: RefCell<Option<Arc<Slot>>> = const { RefCell::new(None) };
}

/// The flag of the step this thread works on (none outside a watched step).
fn current_flag() -> Option<Arc<AtomicBool>> {
    SLOT.with(|slot| slot.borrow().as_ref().and_then(|slot| slot.flag()))
}

/// True when the step this thread works on was asked to stop.
#[inline]
pub(crate) fn raised() -> bool {
    current_flag().is_some_and(|f| f.load(Ordering::Relaxed))
}

/// The flag of the step this thread works on, read once: a loop that looks at it before every
/// event then pays an atomic load, not a thread-local lookup and a lock each time.
pub(crate) struct Watch(Option<Arc<AtomicBool>>);

impl Watch {
    /// The flag of the step this thread works on now (none outside a watched step).
    pub(crate) fn current() -> Watch {
        Watch(current_flag())
    }

    /// True when the step was asked to stop (as [`raised`]).
    #[inline]
    pub(crate) fn raised(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }
}

/// A pool of `threads` threads, each of which finds the flag of the step it works on in `slot`;
/// none when the system refuses the threads.
pub(crate) fn pool(threads: usize, slot: &Arc<Slot>) -> Option<rayon::ThreadPool> {
    let slot = slot.clone();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(move |_| SLOT.with(|s| *s.borrow_mut() = Some(slot.clone())))
        .build()
        .ok()
}

/// Runs `step` with `flag` in `slot`, so visible to the calling thread and to every thread of
/// the pool made with `slot`.
pub(crate) fn watching<R>(slot: &Arc<Slot>, flag: &Arc<AtomicBool>, step: impl FnOnce() -> R) -> R {
    slot.fill(Some(flag.clone()));
    // The caller may be working on another world's step (a thread of rayon's global pool).
    let outer = SLOT.with(|s| s.replace(Some(slot.clone())));
    let result = step();
    SLOT.with(|s| *s.borrow_mut() = outer);
    slot.fill(None);
    result
}
