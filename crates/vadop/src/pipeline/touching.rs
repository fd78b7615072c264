//! The pairs of bodies in contact now, for worlds that report when contacts end (detect mode).
//!
//! It owns one record per touching pair, linked into a short list per body: when a body changes
//! velocity the pipeline finds its partners without a search, and no pair is hashed. A pair joins
//! when its contact starts and leaves when the contact ends or a body is removed. It never decides
//! when a contact starts or ends: the pipeline does, from the narrow phase's canonical times. It
//! keeps when each contact started, because the end search starts there: from a point every run
//! shares (a resumed one too), not from wherever the window in progress began.

use crate::slab::Slab;

/// End of a body's list.
const NONE: u32 = u32::MAX;

/// One touching pair, in the lists of both its bodies.
#[derive(Debug, Clone, Copy)]
struct Link {
    /// The two bodies, lower id first.
    bodies: [u32; 2],
    /// The next link in each body's list.
    next: [u32; 2],
    /// When the contact started.
    since: f64,
}

/// Touching pairs with a list per body.
#[derive(Debug, Default, Clone)]
pub struct Touching {
    /// First link of each body's list.
    head: Vec<u32>,
    links: Slab<Link>,
}

impl Touching {
    /// Records that bodies `a` and `b` touch from `since` on (once: a pair is inserted only when
    /// it starts touching, and it is not touching then).
    pub fn insert(&mut self, a: u32, b: u32, since: f64) {
        let bodies = [a.min(b), a.max(b)];
        let needed = bodies[1] as usize + 1;
        if self.head.len() < needed {
            self.head.resize(needed, NONE);
        }
        let link = Link { bodies, next: bodies.map(|i| self.head[i as usize]), since };
        let index = self.links.insert(link);
        for i in bodies {
            self.head[i as usize] = index;
        }
    }

    /// Forgets that `a` and `b` touch; false when they were not recorded as touching.
    pub fn remove(&mut self, a: u32, b: u32) -> bool {
        let bodies = [a.min(b), a.max(b)];
        let Some(index) = self.find(bodies) else {
            return false;
        };
        for i in bodies {
            self.unlink(i, index);
        }
        self.links.free(index);
        true
    }

    /// Forgets every pair of body `i` (it was removed).
    pub fn remove_body(&mut self, i: u32) {
        loop {
            let Some(j) = self.partners(i).next() else { return };
            self.remove(i, j);
        }
    }

    /// The bodies touching body `i`, most recent first.
    pub fn partners(&self, i: u32) -> impl Iterator<Item = u32> + '_ {
        self.contacts_of(i).map(|(j, _)| j)
    }

    /// The bodies touching body `i` and when each contact started, most recent first.
    pub fn contacts_of(&self, i: u32) -> impl Iterator<Item = (u32, f64)> + '_ {
        let mut current = self.head.get(i as usize).copied().unwrap_or(NONE);
        std::iter::from_fn(move || {
            if current == NONE {
                return None;
            }
            let link = &self.links[current];
            let side = usize::from(link.bodies[1] == i);
            current = link.next[side];
            Some((link.bodies[1 - side], link.since))
        })
    }

    /// Every touching pair, lower id first, in ascending order, with the start of its contact.
    pub fn contacts(&self) -> Vec<(u32, u32, f64)> {
        let mut contacts: Vec<(u32, u32, f64)> = (0..self.head.len() as u32)
            .flat_map(|i| self.contacts_of(i).filter(move |&(j, _)| j > i).map(move |(j, since)| (i, j, since)))
            .collect();
        contacts.sort_unstable_by_key(|&(a, b, _)| (a, b));
        contacts
    }

    /// Every touching pair, lower id first, in ascending order.
    pub fn pairs(&self) -> Vec<(u32, u32)> {
        self.contacts().into_iter().map(|(a, b, _)| (a, b)).collect()
    }

    /// True when no pair touches.
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.links.len() == 0
    }

    /// Bytes held (capacity).
    pub fn memory_bytes(&self) -> usize {
        self.head.capacity() * 4 + self.links.memory_bytes()
    }

    /// The link of the pair `bodies`, from the lower id's list.
    fn find(&self, bodies: [u32; 2]) -> Option<u32> {
        let mut current = self.head.get(bodies[0] as usize).copied().unwrap_or(NONE);
        while current != NONE {
            let link = &self.links[current];
            if link.bodies == bodies {
                return Some(current);
            }
            current = link.next[usize::from(link.bodies[1] == bodies[0])];
        }
        None
    }

    /// Takes link `index` out of body `i`'s list.
    fn unlink(&mut self, i: u32, index: u32) {
        let side_of = |link: &Link| usize::from(link.bodies[1] == i);
        let removed = self.links[index];
        let after = removed.next[side_of(&removed)];
        if self.head[i as usize] == index {
            self.head[i as usize] = after;
            return;
        }
        let mut current = self.head[i as usize];
        while current != NONE {
            let side = side_of(&self.links[current]);
            let next = self.links[current].next[side];
            if next == index {
                self.links[current].next[side] = after;
                return;
            }
            current = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_example() {
        let mut touching = Touching::default();
        touching.insert(3, 1, 0.5);
        touching.insert(1, 7, 0.25);
        assert_eq!(touching.partners(1).collect::<Vec<_>>(), [7, 3]);
        assert_eq!(touching.contacts_of(3).collect::<Vec<_>>(), [(1, 0.5)]);
        assert!(touching.remove(1, 3));
        assert_eq!(touching.contacts(), [(1, 7, 0.25)]);
    }

    #[test]
    fn lists_stay_consistent_under_inserts_and_removals() {
        let mut touching = Touching::default();
        let mut expected: Vec<(u32, u32)> = Vec::new();
        // A deterministic shuffle of inserts and removals over a few bodies.
        let mut state = 12345u64;
        for _ in 0..2000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let (a, b) = ((state >> 33) as u32 % 9, (state >> 45) as u32 % 9);
            if a == b {
                continue;
            }
            let pair = (a.min(b), a.max(b));
            if let Some(k) = expected.iter().position(|&p| p == pair) {
                expected.swap_remove(k);
                assert!(touching.remove(b, a));
            } else if state.is_multiple_of(7) {
                touching.remove_body(a);
                expected.retain(|&(x, y)| x != a && y != a);
            } else {
                expected.push(pair);
                touching.insert(a, b, 0.0);
            }
            expected.sort_unstable();
            assert_eq!(touching.pairs(), expected);
            for i in 0..9 {
                let mut partners: Vec<u32> = touching.partners(i).collect();
                partners.sort_unstable();
                let mut mine: Vec<u32> =
                    expected.iter().filter_map(|&(x, y)| (x == i).then_some(y).or((y == i).then_some(x))).collect();
                mine.sort_unstable();
                assert_eq!(partners, mine);
            }
        }
        assert!(!touching.remove(0, 100));
        assert_eq!(touching.is_empty(), expected.is_empty());
    }
}
