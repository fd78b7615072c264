//! The jam rule's cluster (see [`crate::response::rules`]): every body touching the seeds of a
//! jammed contact, directly or through each other, without separating, frozen into one rigid
//! motion.
//!
//! It owns the cluster's growth and its freeze, for every engine alike: the engine says which
//! bodies are near a member (its broad phase, or its cells), this finds who belongs, gives them
//! all the cluster's centre-of-mass velocity and leaves the members for the engine to re-test.
//! The members are summed in the order of their ids, not in the order they were found, so the
//! cluster's velocity does not depend on the order a broad phase reports neighbours in: every
//! method freezes a cluster to the same bits. It never schedules or re-tests a body itself.

use crate::bodies::{Bodies, Rest};
use crate::frame::{FrameStats, Physics};
use crate::narrow_phase::contacts;
use crate::response::rest;
use crate::response::rules::ContactRules;
use glam::DVec3;

/// A member within this many of its contact tolerances of a wall touches it: the cluster moves no
/// further into it, and on a floor under gravity lies still.
const WALL_TOLERANCES: f64 = 4.0;

/// Scratch of the jam rule: the cluster being frozen, its members' marks, query results.
#[derive(Debug, Default)]
pub(crate) struct Cluster {
    members: Vec<u32>,
    mark: Vec<u32>,
    epoch: u32,
    near: Vec<u32>,
}

impl Cluster {
    /// The bodies frozen by the last [`Cluster::freeze`], ascending: the engine re-tests them.
    pub(crate) fn members(&self) -> &[u32] {
        &self.members
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        (self.members.capacity() + self.mark.capacity() + self.near.capacity()) * 4
    }

    /// The jam rule, counted as one jammed contact: every body touching `seeds` at `t`, directly
    /// or through each other, without separating, moves on with the cluster's centre-of-mass
    /// velocity less any component into a wall a member touches (a cluster `pinned` against
    /// static geometry stops), and its spins stop. `near(bodies, m, out)` puts into `out` the
    /// bodies that may touch member `m` (any superset of them); `pinned(bodies, m)` says whether
    /// member `m` is pressed against static geometry. Returns the cluster's virial: its members'
    /// momentum changes dotted with their centres' offsets from the first moving seed's (what they
    /// exchanged; a stop against a wall or static body counts too).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn freeze(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        rules: &mut ContactRules,
        seeds: &[u32],
        t: f64,
        stats: &mut FrameStats,
        mut near: impl FnMut(&Bodies, usize, &mut Vec<u32>),
        mut pinned_by_level: impl FnMut(&Bodies, usize) -> bool,
    ) -> f64 {
        stats.jam_contacts += 1;
        let (mut cluster, mut found) = (std::mem::take(&mut self.members), std::mem::take(&mut self.near));
        cluster.clear();
        self.epoch = self.epoch.wrapping_add(1);
        self.mark.resize(bodies.slots(), 0);
        // A cluster pressed against static geometry stops: the level holds it. Under the rest
        // rule bodies lying still hold it up too, and are not of it.
        let resting = rest::applies(bodies, physics);
        let support = |bodies: &Bodies, o: usize| resting && bodies.rest_of(o) == Rest::Still;
        let (mut pinned, mut held) = (false, false);
        for &seed in seeds {
            if bodies.is_fixed(seed as usize) || support(bodies, seed as usize) {
                pinned |= bodies.is_fixed(seed as usize);
                held = true;
                continue;
            }
            self.mark[seed as usize] = self.epoch;
            cluster.push(seed);
        }
        let first = cluster.first().map_or(0, |&m| m as usize);
        let mut k = 0;
        while k < cluster.len() {
            let m = cluster[k] as usize;
            k += 1;
            found.clear();
            near(bodies, m, &mut found);
            for &o in &found {
                let o = o as usize;
                if self.mark[o] != self.epoch && contacts::pressed_together(bodies, m, o, t) {
                    if support(bodies, o) {
                        held = true;
                        continue;
                    }
                    self.mark[o] = self.epoch;
                    cluster.push(o as u32);
                }
            }
            pinned = pinned || pinned_by_level(bodies, m);
        }
        // Summed in id order: the same bits whichever order the members were found in.
        cluster.sort_unstable();
        let (mut mass, mut momentum) = (0.0, DVec3::ZERO);
        let (mut touches_min, mut touches_max) = ([false; 3], [false; 3]);
        for &m in &cluster {
            let m = m as usize;
            mass += bodies.mass(m);
            momentum += bodies.mass(m) * bodies.velocity_at(m, t);
            // Within a few of the body's own contact tolerances: a shape's is a thousand times a
            // sphere's, and one touching a floor a shape's tolerance away, not counted as on it,
            // kept its fall, touched the floor again at the same instant and jammed for ever.
            let [near_min, near_max] = contacts::walls_within(bodies, m, &physics.bounds, t, WALL_TOLERANCES);
            for axis in 0..3 {
                touches_min[axis] |= near_min[axis];
                touches_max[axis] |= near_max[axis];
            }
        }
        // Under the rest rule a cluster held up by a floor or by a body lying still lies still.
        // Under gravity a cluster pinned against static geometry or on a floor lies still in
        // every mode: it stops, and gravity would press it into what holds it again at once,
        // touch after touch closer together without end (an elastic world or detect mode has no
        // rest rule to end that; a ball resting on a wall there is refused before the step, which
        // shapes and static geometry are too costly to check for).
        let g = bodies.gravity;
        let floor = (0..3).any(|axis| (g[axis] < 0.0 && touches_min[axis]) || (g[axis] > 0.0 && touches_max[axis]));
        let still = (resting && held) || ((pinned || floor) && g != DVec3::ZERO);
        let mut velocity = if pinned || still || mass == 0.0 { DVec3::ZERO } else { momentum / mass };
        for axis in 0..3 {
            if (velocity[axis] < 0.0 && touches_min[axis]) || (velocity[axis] > 0.0 && touches_max[axis]) {
                velocity[axis] = 0.0;
            }
        }
        // One rigid motion for all: no spin, or members would turn into each other.
        let mut virial = 0.0;
        for &m in &cluster {
            let m = m as usize;
            let gained = bodies.mass(m) * (velocity - bodies.velocity_at(m, t));
            // A cluster spans less than half a periodic side: its members' nearest images.
            virial += bodies.offset_at(first, m, t).dot(gained);
            rules.freeze(m as u32, t);
            bodies.set_motion_at(m, t, velocity, DVec3::ZERO);
            if still {
                bodies.lie_still(m, t);
            }
        }
        self.members = cluster;
        self.near = found;
        virial
    }
}
