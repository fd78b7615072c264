//! The collapse rule: with restitution below 1 a group of bodies can collide infinitely often in
//! finite time (inelastic collapse: three spheres in a line between walls, a dense column), and
//! even elastic bodies jammed with no free space between them and the walls exchange velocities
//! forever at one instant. An exact event loop would never reach the frame's end.
//!
//! Rule (simulate mode): the first [`COLLAPSE_CAP`] contacts of a pair of bodies within one frame
//! use the world's restitution. At the next one the pair *merges into resting contact*: the two
//! bodies, with every body already merged with either of them this frame, move on together with
//! their common centre-of-mass velocity for the rest of the frame. A merged group that touches a
//! wall while moving into it stops moving into that wall (its velocity component along the wall's
//! normal becomes zero). Momentum is conserved by every merge (walls absorb what they stop, as in
//! any wall contact); energy is only ever lost. Each merge and each such wall stop is counted in
//! [`crate::FrameStats::collapse_contacts`]. Groups dissolve at the end of the frame.
//!
//! Why every frame ends: bodies of a group share one velocity exactly, so they never touch each
//! other again; each further pair contact is one of a pair's first 64, or merges two groups; and a
//! group stops at most once per wall. Ordinary scenes never reach the cap: a pair touching 64
//! times within one frame is a collapse, not a collision.
//!
//! This module owns the per-frame counts and the groups, nothing else: it never changes a body.

use std::collections::HashMap;

/// Contacts of one pair of bodies per frame that use the world's restitution.
pub const COLLAPSE_CAP: u32 = 64;

/// Contact counts and merged groups of the current frame.
#[derive(Debug, Default)]
pub(crate) struct CollapseGuard {
    counts: HashMap<(u32, u32), u32>,
    /// Group of each merged body (bodies never merged have none).
    group_of: HashMap<u32, usize>,
    /// Members of each group, ascending.
    groups: Vec<Vec<u32>>,
}

impl CollapseGuard {
    /// Forgets the previous frame's counts and groups.
    pub(crate) fn clear(&mut self) {
        self.counts.clear();
        self.group_of.clear();
        self.groups.clear();
    }

    /// Counts one contact of the pair `a < b`; true once the pair is past the cap and must merge.
    pub(crate) fn must_merge(&mut self, a: u32, b: u32) -> bool {
        let count = self.counts.entry((a, b)).or_insert(0);
        *count += 1;
        *count > COLLAPSE_CAP
    }

    /// Merges the groups of `a` and `b` and returns the members of the result, ascending.
    pub(crate) fn merge(&mut self, a: u32, b: u32) -> &[u32] {
        let group = match (self.group_of.get(&a).copied(), self.group_of.get(&b).copied()) {
            (Some(x), Some(y)) if x == y => x,
            (Some(x), Some(y)) => {
                let moved = std::mem::take(&mut self.groups[y]);
                for &body in &moved {
                    self.group_of.insert(body, x);
                }
                self.groups[x].extend(moved);
                self.groups[x].sort_unstable();
                x
            }
            (Some(x), None) | (None, Some(x)) => {
                let body = if self.group_of.contains_key(&a) { b } else { a };
                self.group_of.insert(body, x);
                self.groups[x].push(body);
                self.groups[x].sort_unstable();
                x
            }
            (None, None) => {
                self.groups.push(vec![a, b]);
                self.group_of.insert(a, self.groups.len() - 1);
                self.group_of.insert(b, self.groups.len() - 1);
                self.groups.len() - 1
            }
        };
        &self.groups[group]
    }

    /// The members of the group `body` was merged into this frame, if any.
    pub(crate) fn group(&self, body: u32) -> Option<&[u32]> {
        self.group_of.get(&body).map(|&g| self.groups[g].as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_merge_after_the_cap_and_groups_join() {
        let mut guard = CollapseGuard::default();
        for _ in 0..COLLAPSE_CAP {
            assert!(!guard.must_merge(1, 2));
        }
        assert!(guard.must_merge(1, 2));
        assert_eq!(guard.merge(1, 2), &[1, 2]);
        assert_eq!(guard.merge(5, 7), &[5, 7]);
        assert_eq!(guard.merge(7, 0), &[0, 5, 7]);
        assert_eq!(guard.merge(2, 5), &[0, 1, 2, 5, 7]);
        assert_eq!(guard.group(7), Some(&[0, 1, 2, 5, 7][..]));
        assert_eq!(guard.group(3), None);
        guard.clear();
        assert_eq!(guard.group(7), None);
        assert!(!guard.must_merge(1, 2));
    }
}
