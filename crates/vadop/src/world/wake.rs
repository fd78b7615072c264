//! Waking what lay on bodies the caller moves or removes between frames: under the rest rule
//! (see [`crate::response::rest`]) a body lying still is held up by what it touches from above,
//! so when the caller gives a body lying still a new motion or removes it, the bodies lying still
//! on it, and on those in turn, fall again at the next step rather than float. Inside a step the
//! engine wakes them (it knows which bodies are near); between frames the world does, over a grid
//! of the bodies lying still ([`Cells`]), once per step whatever the number of bodies released.
//! It never decides how a body comes to rest.

use super::overlap::Cells;
use super::World;
use crate::bodies::Rest;
use crate::narrow_phase::spheres::CONTACT_TOLERANCE;

impl World {
    /// Body `i` is about to get a new motion from the caller, or to be removed: when it lies
    /// still, the next step wakes what lies on it.
    pub(super) fn release(&mut self, i: usize) {
        if self.bodies.rest_of(i) == Rest::Still {
            self.released.push((self.bodies.position_at(i, self.time), self.bodies.radius(i)));
        }
    }

    /// At a step's start, once its engine holds every body: the bodies lying still on top of
    /// the released ones (touching them, to the contact tolerance, above their centres), and on
    /// those in turn, fall from where they are.
    pub(super) fn wake_released(&mut self) {
        if self.released.is_empty() {
            return;
        }
        let (time, mut stack) = (self.time, std::mem::take(&mut self.released));
        let bodies = &self.bodies;
        let still: Vec<u32> = bodies.alive_ids().filter(|&i| bodies.rest_of(i as usize) == Rest::Still).collect();
        let radii = still.iter().map(|&i| bodies.radius(i as usize)).chain(stack.iter().map(|&(_, r)| r));
        let cells = Cells::new(bodies, &still, time, radii.fold(0.0, f64::max));
        let mut woken = Vec::new();
        while let Some((position, radius)) = stack.pop() {
            woken.clear();
            cells.for_each_near(position, |o| woken.push(o));
            for &o in &woken {
                let o = o as usize;
                let p = self.bodies.position_at(o, time);
                let offset = self.bodies.periodic.nearest(p - position);
                let reach = (radius + self.bodies.radius(o)) * (1.0 + 4.0 * CONTACT_TOLERANCE);
                let on_it = offset.dot(self.bodies.gravity) < 0.0 && offset.length() <= reach;
                if self.bodies.rest_of(o) == Rest::Still && on_it {
                    self.bodies.fall(o, time);
                    stack.push((p, self.bodies.radius(o)));
                    self.reenter(o);
                }
            }
        }
    }
}
