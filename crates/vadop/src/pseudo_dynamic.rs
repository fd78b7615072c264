//! The pseudo-dynamic baseline: discrete overlap checks at frame instants, like freeSOLID.
//!
//! It owns one list of bodies sorted by the low end of their x extent (kept sorted by insertion
//! sort across frames) and the set of pairs found overlapping at the previous instant. At each
//! frame end it sweeps the list, confirms AABB overlap on y and z and then sphere overlap. It
//! never predicts contact times: whatever touches and separates between two instants is missed,
//! which is exactly what the accuracy comparison measures.

use crate::bodies::Bodies;
use crate::coherent_sort::coherent_sort;

/// Frame-instant AABB sweep and prune.
#[derive(Debug, Default)]
pub struct PseudoDynamic {
    /// Live body ids sorted by `low_x`.
    order: Vec<u32>,
    /// Low end of each slot's x extent at the current instant.
    low_x: Vec<f64>,
    /// Pairs (i < j) overlapping at the previous instant, ascending.
    previous: Vec<(u32, u32)>,
    /// Pairs overlapping now, ascending.
    current: Vec<(u32, u32)>,
}

impl PseudoDynamic {
    /// Adds a body to the sweep list.
    pub fn add_body(&mut self, body: u32) {
        self.order.push(body);
    }

    /// Updates the sort keys of all bodies at their current positions (c_update), dropping
    /// removed bodies.
    pub fn update(&mut self, bodies: &Bodies) {
        self.order.retain(|&b| bodies.alive[b as usize]);
        self.low_x.resize(bodies.slots(), 0.0);
        for &b in &self.order {
            let b = b as usize;
            self.low_x[b] = bodies.position[b].x - bodies.radius[b];
        }
    }

    /// Re-sorts the list (c_sort); returns the number of insertion-sort moves.
    pub fn sort(&mut self) -> u64 {
        let keys = &self.low_x;
        coherent_sort(&mut self.order, |&a, &b| keys[a as usize] < keys[b as usize])
    }

    /// Finds the pairs overlapping now (c_test). Returns the number of AABB-overlapping pairs
    /// examined. Read them with [`Self::overlapping`] and [`Self::is_new`].
    pub fn find_overlaps(&mut self, bodies: &Bodies) -> u64 {
        std::mem::swap(&mut self.previous, &mut self.current);
        self.current.clear();
        let mut examined = 0u64;
        for (k, &i) in self.order.iter().enumerate() {
            let (pi, ri) = (bodies.position[i as usize], bodies.radius[i as usize]);
            let high_x = pi.x + ri;
            for &j in &self.order[k + 1..] {
                if self.low_x[j as usize] > high_x {
                    break;
                }
                let (pj, rj) = (bodies.position[j as usize], bodies.radius[j as usize]);
                let reach = ri + rj;
                if (pi.y - pj.y).abs() > reach || (pi.z - pj.z).abs() > reach {
                    continue;
                }
                examined += 1;
                if pi.distance_squared(pj) < reach * reach {
                    self.current.push(if i < j { (i, j) } else { (j, i) });
                }
            }
        }
        self.current.sort_unstable();
        examined
    }

    /// Pairs overlapping at the current instant, ascending.
    pub fn overlapping(&self) -> &[(u32, u32)] {
        &self.current
    }

    /// True when `pair` did not overlap at the previous instant.
    pub fn is_new(&self, pair: (u32, u32)) -> bool {
        self.previous.binary_search(&pair).is_err()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.order.capacity() * 4 + self.low_x.capacity() * 8 + (self.previous.capacity() + self.current.capacity()) * 8
    }
}
