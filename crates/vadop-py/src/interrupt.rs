//! Long core calls made interruptible: the work runs on a thread of its own while the caller,
//! the GIL released, looks at signals, so a Ctrl-C stops even one long step within milliseconds.
//! It must never hold the GIL while the work runs, nor hand back the work's result once a signal
//! came: the signal's exception wins, and the core has undone the interrupted step.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};
use vadop::World;

/// How long a call steps without the GIL before it looks at signals (Ctrl-C).
const SIGNAL_CHECK: Duration = Duration::from_millis(50);
/// How long a step's caller waits for it without sleeping.
const BUSY_WAIT: Duration = Duration::from_micros(200);

/// Runs `work` on `world` in a thread of its own while this one (the GIL released) looks at
/// signals every [`SIGNAL_CHECK`]: a Ctrl-C raises the world's interrupt flag, which stops even
/// one long step within milliseconds and undoes it, and the signal's exception
/// (`KeyboardInterrupt`) is raised instead of what `work` returns.
pub(crate) fn interruptible<T: Send>(
    world: &mut World,
    work: impl FnOnce(&mut World) -> PyResult<T> + Send,
) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    world.set_interrupt(Some(stop.clone()));
    let mut signal = None;
    let (done, finished) = mpsc::channel::<()>();
    let (mut result, stepped) = (None, &mut *world);
    // A thread of rayon's global pool runs the work: waking one costs less than starting one.
    rayon::in_place_scope(|scope| {
        let result = &mut result;
        scope.spawn(move |_| {
            *result = Some(work(stepped));
            drop(done);
        });
        // Most steps are short: waiting for them without sleeping saves waking up again.
        let start = Instant::now();
        while matches!(finished.try_recv(), Err(mpsc::TryRecvError::Empty)) && start.elapsed() < BUSY_WAIT {
            std::thread::yield_now();
        }
        while let Err(mpsc::RecvTimeoutError::Timeout) = finished.recv_timeout(SIGNAL_CHECK) {
            if signal.is_none() {
                if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                    stop.store(true, Ordering::Relaxed);
                    signal = Some(e);
                }
            }
        }
    });
    let result = result.expect("the scope ran the work");
    world.set_interrupt(None);
    match signal {
        Some(e) => Err(e),
        None => result,
    }
}
