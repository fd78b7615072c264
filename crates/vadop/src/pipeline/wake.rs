//! Waking what lay on a body that moved: under the rest rule (see [`crate::response::rest`]) a
//! body lying still is held up by what it touches from above, so when one of those moves (a hard
//! impact, or the caller), the bodies lying still on it, and on those in turn, fall again rather
//! than float.
//!
//! It owns that walk over the bodies near a body, through the broad phase, as the jam rule's
//! walk does; it never decides how a body comes to rest.

use super::Pipeline;
use crate::bodies::{Bodies, Rest};
use crate::broad_phase::proxy::ProxyTable;
use crate::broad_phase::BroadPhase;
use crate::frame::{FrameStats, Physics};
use crate::narrow_phase::spheres::CONTACT_TOLERANCE;

/// Into `near`, the bodies whose proxies in `table` overlap body `m`'s: through its own proxy
/// and, across periodic faces, its ghosts.
pub(super) fn neighbours<B: BroadPhase>(
    broad: &mut B,
    table: &ProxyTable,
    bodies: &Bodies,
    m: usize,
    near: &mut Vec<u32>,
) {
    near.clear();
    let proxies = table.view(bodies);
    for slot in table.slots_of(m) {
        broad.query(slot as u32, proxies, None, |o, _| {
            near.extend(table.owner(o.body, o.stamp).map(|(body, _, _)| body));
        });
    }
}

impl<B: BroadPhase> Pipeline<B> {
    /// Body `woken`, which lay still, moves (or goes) at `t`: the bodies lying still on top of it
    /// (touching it, to the contact tolerance, above its centre), and on those in turn, fall
    /// again from where they are, re-tested from `t` when a window is under way.
    pub(super) fn wake_held(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        woken: usize,
        t: f64,
        stats: &mut FrameStats,
    ) {
        let mut stack = std::mem::take(&mut self.cluster_members);
        let mut near = std::mem::take(&mut self.near);
        stack.clear();
        stack.push(woken as u32);
        while let Some(m) = stack.pop() {
            let m = m as usize;
            neighbours(&mut self.broad, &self.proxies, bodies, m, &mut near);
            for &o in &near {
                let o = o as usize;
                let offset = bodies.offset_at(m, o, t);
                let reach = (bodies.radius(m) + bodies.radius(o)) * (1.0 + 4.0 * CONTACT_TOLERANCE);
                let on_it = offset.dot(bodies.gravity) < 0.0 && offset.length() <= reach;
                if bodies.rest_of(o) == Rest::Still && on_it {
                    bodies.fall(o, t);
                    self.enter(o as u32, bodies, physics, t, stats);
                    stack.push(o as u32);
                }
            }
        }
        self.cluster_members = stack;
        self.near = near;
    }
}
