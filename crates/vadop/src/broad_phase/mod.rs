//! Broad phases: which pairs of bodies might touch within a window, found from the proxy table.
//!
//! Every broad phase implements [`BroadPhase`] over the same flat [`crate::broad_phase::proxy::ProxyTable`],
//! read through [`Proxies`], which pairs it with the bodies' motions: at a window's start it
//! bins or sorts every proxy and reports each candidate pair once; when a body changes velocity
//! mid-window it enters the body's new proxy and reports that body's candidate partners, at a
//! cost that grows with the bodies near the new path. A broad phase may report a pair that never
//! touches, never misses one that does, and never reads a body's shape, mass or velocity stamp
//! history: bounds come from the proxies. Each candidate comes with the time window over which
//! the reported bounds hold, and only contacts inside it may be predicted from it, so a pair
//! reported through several pieces of a long path still yields each contact once.
//!
//! - [`grid::Grid`]: a hierarchical uniform grid over swept boxes, long paths cut into pieces;
//! - [`sweep_prune::SweepPrune`]: the paper's VADOP sweep and prune over a pool of axes (and its
//!   swept-k-DOP and swept-AABB variants);
//! - [`brute_force::BruteForce`]: every pair, the oracle.

pub mod box_columns;
pub mod brute_force;
mod candidates;
pub(crate) mod coherent_sort;
pub(crate) mod ghosts;
pub mod grid;
pub mod proxy;
pub mod sweep_prune;

use crate::bodies::BodyState;
use crate::broad_phase::proxy::{Foreseen, Proxies, Reported};
use crate::parallel::Workers;
use crate::window::Window;

/// Counters of a broad phase's window-start work.
#[derive(Debug, Default, Clone, Copy)]
pub struct PrepareCounts {
    /// Entries moved by insertion sort (sweep and prune) or binned (grid).
    pub moves: u64,
    /// Entries held after the preparation.
    pub entries: u64,
}

/// The interface every broad phase offers the frame pipeline.
pub trait BroadPhase: Sync {
    /// Window start: every live proxy has just been refreshed; bin or sort them (c_sort),
    /// spreading the work over `workers`.
    fn prepare(&mut self, proxies: Proxies, workers: &Workers) -> PrepareCounts;

    /// Calls `predict(a, b, window, out)` for every candidate pair of the window (c_test), each
    /// pair and piece of path once, spread over `workers`: each worker writes into an `out` of
    /// its own, and the outputs are appended to `out` in an order that does not depend on the
    /// number of workers. Returns the number of candidates. Call right after [`Self::prepare`].
    fn find_pairs<T: Send>(
        &mut self,
        proxies: Proxies,
        workers: &Workers,
        predict: impl Fn(Reported, Reported, Window, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64;

    /// [`Self::find_pairs`] with `predict(a, b, kept, out)` asked only of the candidates `screen`
    /// neither clears nor finds without an event in their window (the others counted all the
    /// same), `kept` being what [`PairScreen::kept`] makes of each: the window is the screen's to
    /// ask, not `predict`'s. A broad phase that can ask the screen of several candidates at once
    /// does ([`PairScreen::kept_four_avx`]).
    fn find_pairs_screened<T: Send, S: PairScreen>(
        &mut self,
        proxies: Proxies,
        workers: &Workers,
        screen: &S,
        predict: impl Fn(Reported, Reported, S::Kept, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64 {
        self.find_pairs(proxies, workers, screened_one_by_one(screen, predict), out)
    }

    /// Calls `report(other, window)` for every candidate partner of body `body`'s current proxy
    /// other than `skip`, without entering the proxy.
    fn query(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window));

    /// Body `body`'s proxy was just refreshed (it was added or changed velocity): reports its
    /// candidate partners other than `skip` as [`Self::query`] does, then enters it.
    fn update(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window));

    /// True when [`Self::prepare_foreseen`] can bin bodies' foreseen paths beside their proxies.
    fn bins_foreseen(&self) -> bool {
        false
    }

    /// [`Self::prepare`], with the paths of `foreseen` binned too, each as a further proxy of its
    /// body carrying its own stamp and state: [`Self::find_pairs`] then reports their pairs
    /// (never one of a body with itself), and [`Self::update`] the pieces of a foreseen path
    /// whose bounce is still to come ([`crate::broad_phase::proxy::ProxyTable::is_foreseen`]) as
    /// well as the current ones. Later entries go beside the window start's, which stay as they
    /// are until the next preparation. Asked only where [`Self::bins_foreseen`].
    fn prepare_foreseen(&mut self, _proxies: Proxies, _foreseen: &[Foreseen], _workers: &Workers) -> PrepareCounts {
        unreachable!("only asked of a broad phase that bins foreseen paths")
    }

    /// Bytes held (capacity, not just length).
    fn memory_bytes(&self) -> usize;
}

/// A test of two reported states alone that clears candidate pairs with no event, for a broad
/// phase to ask before anything else of a pair (see [`BroadPhase::find_pairs_screened`]), and
/// works out what the rest of the pair's test needs of the pairs it keeps.
pub trait PairScreen: Sync {
    /// What the screen works out of a pair it keeps.
    type Kept: Copy;

    /// True when the pair of `a` and `b` has no event.
    fn clears(&self, a: &BodyState, b: &BodyState) -> bool;

    /// What the screen works out of the pair of `a` and `b`, which it does not clear, when the
    /// pair can have an event in `window` (`None` otherwise); the same whichever of the two comes
    /// first.
    fn kept(&self, a: &BodyState, b: &BodyState, window: Window) -> Option<Self::Kept>;

    /// Bit k (k < 4) set when [`Self::clears`] the pair of `a[k]` and `b[k]`: its very
    /// verdicts, four at once in AVX's lanes.
    ///
    /// # Safety
    /// The processor has AVX.
    #[cfg(target_arch = "x86_64")]
    unsafe fn clears_four_avx(&self, a: [&BodyState; 4], b: [&BodyState; 4]) -> u32;

    /// [`Self::kept`] of the pairs of `a[k]` and `b[k]`, four at once in AVX's lanes, in lane k's
    /// window (`windows`: the starts, then the ends): bit k of the mask returned is clear where
    /// [`Self::kept`] is `None`, and set with its very answer in lane k of the answers otherwise
    /// (the other lanes' answers are anything).
    ///
    /// # Safety
    /// The processor has AVX.
    #[cfg(target_arch = "x86_64")]
    unsafe fn kept_four_avx(
        &self,
        a: [&BodyState; 4],
        b: [&BodyState; 4],
        windows: [std::arch::x86_64::__m256d; 2],
    ) -> (u32, [Self::Kept; 4]);
}

/// `predict` of the candidates `screen` does not clear, asked one by one.
#[inline(always)]
fn screened_one_by_one<'a, T, S: PairScreen>(
    screen: &'a S,
    predict: impl Fn(Reported, Reported, S::Kept, &mut Vec<T>) + Sync + Send + 'a,
) -> impl Fn(Reported, Reported, Window, &mut Vec<T>) + Sync + Send + 'a {
    move |x, y, window, out| {
        if screen.clears(x.state, y.state) {
            return;
        }
        if let Some(kept) = screen.kept(x.state, y.state, window) {
            predict(x, y, kept, out);
        }
    }
}
