//! Every pair is a candidate: the brute-force oracle, O(n^2) per window.
//!
//! It owns nothing but the list of live bodies, and must never prune: the tests compare every
//! other broad phase's contacts with the ones found through it.

use super::{BroadPhase, PrepareCounts};
use crate::broad_phase::proxy::{Proxies, Reported};
use crate::parallel::Workers;
use crate::window::Window;

/// All pairs.
#[derive(Debug, Default)]
pub struct BruteForce {
    live: Vec<u32>,
}

impl BroadPhase for BruteForce {
    fn prepare(&mut self, proxies: Proxies, _workers: &Workers) -> PrepareCounts {
        self.live.clear();
        self.live.extend((0..proxies.slots() as u32).filter(|&i| proxies.is_live(i as usize)));
        PrepareCounts { moves: 0, entries: self.live.len() as u64 }
    }

    fn find_pairs<T: Send>(
        &mut self,
        proxies: Proxies,
        workers: &Workers,
        predict: impl Fn(Reported, Reported, Window, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64 {
        let live = &self.live;
        workers.extend_ranges(live.len(), out, |rows, found| {
            for k in rows {
                let i = live[k] as usize;
                for &j in &live[k + 1..] {
                    let j = j as usize;
                    predict(
                        proxies.reported(i),
                        proxies.reported(j),
                        proxies.window_of(i).intersect(proxies.window_of(j)),
                        found,
                    );
                }
            }
        });
        let n = live.len() as u64;
        n * n.saturating_sub(1) / 2
    }

    fn update(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window)) {
        self.query(body, proxies, skip, report);
    }

    fn query(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, mut report: impl FnMut(Reported, Window)) {
        let window = proxies.window_of(body as usize);
        for other in 0..proxies.slots() as u32 {
            if other != body && Some(other) != skip && proxies.is_live(other as usize) {
                report(proxies.reported(other as usize), window.intersect(proxies.window_of(other as usize)));
            }
        }
    }

    fn memory_bytes(&self) -> usize {
        self.live.capacity() * 4
    }
}
