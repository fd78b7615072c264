//! Interrupting a step in progress: a flag the caller raises from another thread (a signal
//! handler, a watcher, a user interface), polled by the event loop and, every
//! [`POLL_INTERVAL`] distance evaluations, by the shape narrow phase's searches.
//!
//! The flag of the world being stepped is visible to every thread working on its step (the
//! calling one, or each of its own pool's) for the length of the step only, so a search knows
//! no world and worlds stepped side by side never see each other's flags. A search that sees it
//! raised gives up at once; its answer is void, since the world then undoes the whole step.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Distance evaluations of a search between two looks at the flag.
pub(crate) const POLL_INTERVAL: u32 = 4096;

thread_local! {
    static FLAG: RefCell<Option<Arc<AtomicBool>>> = const { RefCell::new(None) };
}

/// True when the step this thread works on was asked to stop.
#[inline]
pub(crate) fn raised() -> bool {
    FLAG.with(|flag| flag.borrow().as_ref().is_some_and(|f| f.load(Ordering::Relaxed)))
}

/// The flag of the step this thread works on, read once: a loop that looks at it before every
/// event then pays an atomic load, not a thread-local lookup each time.
pub(crate) struct Watch(Option<Arc<AtomicBool>>);

impl Watch {
    /// The flag of the step this thread works on now (none outside a watched step).
    pub(crate) fn current() -> Watch {
        Watch(FLAG.with(|flag| flag.borrow().clone()))
    }

    /// True when the step was asked to stop (as [`raised`]).
    #[inline]
    pub(crate) fn raised(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }
}

/// Runs `step` with `flag` visible to the calling thread and every thread of `pool`.
pub(crate) fn watching<R>(flag: &Arc<AtomicBool>, pool: Option<&rayon::ThreadPool>, step: impl FnOnce() -> R) -> R {
    let set = |value: Option<Arc<AtomicBool>>| FLAG.with(|f| *f.borrow_mut() = value);
    set(Some(flag.clone()));
    if let Some(pool) = pool {
        pool.broadcast(|_| set(Some(flag.clone())));
    }
    let result = step();
    if let Some(pool) = pool {
        pool.broadcast(|_| set(None));
    }
    set(None);
    result
}
