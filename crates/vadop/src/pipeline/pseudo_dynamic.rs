//! The pseudo-dynamic baseline, stepped on its own: overlap checks at frame instants only, like
//! freeSOLID.
//!
//! It owns one list of bodies sorted by the low end of their x extent (kept sorted by insertion
//! sort across frames) and the pairs found overlapping at the previous instant. Bodies move
//! through the frame, bouncing off the walls exactly; at the frame's end it sweeps the list,
//! confirms AABB overlap on y and z and then sphere overlap, and reports (or, in simulate mode,
//! resolves) what overlaps at that instant, as an engine does after its step. It has no contact
//! times, so an overlap is stamped with the instant it was seen — the frame's end — and reported
//! with the frame just stepped: the one exception to the rule that a contact belongs to the frame
//! holding its time. It never predicts pair contacts: whatever touches and separates between two
//! instants is missed, which is exactly what the accuracy comparison measures. In a periodic box a
//! body comes back through the opposite face at the instant its centre crosses one, and the
//! bodies near a face are swept a second time as images one side away, against the list.

use crate::bodies::Bodies;
use crate::broad_phase::coherent_sort::coherent_sort;
use crate::frame::{Contact, Mode, Touched};
use crate::frame::{Output, Physics};
use crate::narrow_phase::spheres::wall_contact_time;
use crate::numeric::direction;
use crate::response::impact::{bounce_off_wall, exchange_virial, push_spheres};
use crate::response::rest;
use crate::response::rules::{ContactRules, Rule};
use glam::DVec3;
use std::time::Instant;

/// Frame-instant AABB sweep and prune.
#[derive(Debug, Default)]
pub(crate) struct PseudoDynamic {
    /// Live body ids sorted by `low_x`.
    order: Vec<u32>,
    /// Centre and low end of the x extent of each slot at the current instant.
    centre: Vec<DVec3>,
    low_x: Vec<f64>,
    /// Pairs (i < j) overlapping at the previous instant, ascending.
    previous: Vec<(u32, u32)>,
    /// Pairs overlapping now, ascending.
    current: Vec<(u32, u32)>,
    /// In a periodic box, images of the bodies near a face, one side away: the body, its centre
    /// and the low end of its x extent, sorted by that low end.
    images: Vec<(u32, DVec3, f64)>,
    /// The jam rule, for a body exactly as wide as the box.
    pub(crate) rules: ContactRules,
}

impl PseudoDynamic {
    /// Adds a body to the sweep list.
    pub(crate) fn add_body(&mut self, body: u32) {
        self.order.push(body);
    }

    /// Forgets body `i`'s overlaps (it was removed): a body added later in its slot starts with
    /// none, so its first overlap is a new contact.
    pub(crate) fn remove_body(&mut self, i: u32) {
        self.current.retain(|&(a, b)| a != i && b != i);
    }

    /// Pairs (i < j) overlapping at the last frame instant, ascending.
    pub(crate) fn overlapping(&self) -> &[(u32, u32)] {
        &self.current
    }

    /// Restores the pairs overlapping at the last frame instant (from a saved world).
    pub(crate) fn set_overlapping(&mut self, pairs: Vec<(u32, u32)>) {
        self.current = pairs;
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.order.capacity() * 4
            + self.centre.capacity() * 24
            + self.low_x.capacity() * 8
            + (self.previous.capacity() + self.current.capacity()) * 8
            + self.images.capacity() * std::mem::size_of::<(u32, DVec3, f64)>()
            + self.rules.memory_bytes()
    }

    /// Finds the pairs overlapping at `t` (c_update, c_sort, c_test); read them from `current`.
    pub(crate) fn find_overlaps(&mut self, bodies: &Bodies, t: f64, out: &mut Output) {
        let start = Instant::now();
        self.order.retain(|&b| bodies.alive[b as usize]);
        self.centre.resize(bodies.slots(), DVec3::ZERO);
        self.low_x.resize(bodies.slots(), 0.0);
        for &b in &self.order {
            let b = b as usize;
            self.centre[b] = bodies.position_at(b, t);
            self.low_x[b] = self.centre[b].x - bodies.radius(b);
        }
        out.stats.update_seconds += start.elapsed().as_secs_f64();

        let start = Instant::now();
        let keys = &self.low_x;
        out.stats.endpoint_swaps += coherent_sort(&mut self.order, |&a, &b| keys[a as usize] < keys[b as usize]);
        out.stats.list_entries = self.order.len() as u64;
        out.stats.sort_seconds += start.elapsed().as_secs_f64();

        let start = Instant::now();
        std::mem::swap(&mut self.previous, &mut self.current);
        self.current.clear();
        for (k, &i) in self.order.iter().enumerate() {
            let (pi, ri) = (self.centre[i as usize], bodies.radius(i as usize));
            let high_x = pi.x + ri;
            for &j in &self.order[k + 1..] {
                if self.low_x[j as usize] > high_x {
                    break;
                }
                test_pair(&mut self.current, bodies, (i, pi), (j, self.centre[j as usize]), out);
            }
        }
        if bodies.periodic.any() {
            self.test_images(bodies, out);
        }
        self.current.sort_unstable();
        out.stats.test_seconds += start.elapsed().as_secs_f64();
    }

    /// In a periodic box: the images of the bodies within a largest diameter of a face, one side
    /// away (one per combination of the faces a body is near), swept against the list; a pair is
    /// kept from the lower id's centre against the higher id's image only, so each is found once.
    fn test_images(&mut self, bodies: &Bodies, out: &mut Output) {
        let periodic = bodies.periodic;
        let near = 2.0 * self.order.iter().map(|&b| bodies.radius(b as usize)).fold(0.0, f64::max);
        let mut images = std::mem::take(&mut self.images);
        images.clear();
        for &b in &self.order {
            let (p, r) = (self.centre[b as usize], bodies.radius(b as usize));
            for shift in periodic.image_shifts(p - near, p + near) {
                images.push((b, p + shift, p.x + shift.x - r));
            }
        }
        images.sort_unstable_by(|x, y| x.2.total_cmp(&y.2).then(x.0.cmp(&y.0)));
        // Every body against the images whose low x lies in its x extent, and every image against
        // the bodies whose low x lies in its own (ties to the first): each overlap in x once.
        for k in 0..self.order.len() {
            let i = self.order[k];
            let (pi, low) = (self.centre[i as usize], self.low_x[i as usize]);
            let high = pi.x + bodies.radius(i as usize);
            let first = images.partition_point(|image| image.2 < low);
            for &(j, pj, _) in images[first..].iter().take_while(|image| image.2 <= high) {
                if i < j {
                    test_pair(&mut self.current, bodies, (i, pi), (j, pj), out);
                }
            }
        }
        for &(j, pj, low) in &images {
            let high = pj.x + bodies.radius(j as usize);
            let first = self.order.partition_point(|&b| self.low_x[b as usize] <= low);
            for k in first..self.order.len() {
                let i = self.order[k];
                if self.low_x[i as usize] > high {
                    break;
                }
                if i < j {
                    test_pair(&mut self.current, bodies, (i, self.centre[i as usize]), (j, pj), out);
                }
            }
        }
        self.images = images;
    }

    /// Steps from `t0` to `t1`: straight motion with exact wall bounces, then the overlaps at `t1`.
    pub(crate) fn step(&mut self, bodies: &mut Bodies, physics: &Physics, _t0: f64, t1: f64, out: &mut Output) {
        self.rules.resize(bodies.slots());
        self.rules.next_step();
        let start = Instant::now();
        // Walls: each body on its own, every bounce inside the frame, merged in time order.
        for &body in &self.order {
            let i = body as usize;
            if !bodies.alive[i] {
                continue;
            }
            let (walls, faces) = (physics.bounds.walls(), physics.bounds.faces());
            loop {
                let (motion, gravity) = (bodies.motion(i), bodies.gravity_on(i));
                let wall = wall_contact_time(&motion, bodies.radius(i), walls.0, walls.1, gravity);
                let crossing = match physics.bounds.is_periodic() {
                    true => wall_contact_time(&motion, 0.0, faces.0, faces.1, gravity),
                    false => None,
                };
                // A crossing first (at a tie too): the body comes back through the other face.
                if let Some((t, face)) = crossing.filter(|&(t, _)| t < t1 && wall.is_none_or(|(w, _)| t <= w)) {
                    bodies.wrap(i, face, t);
                    continue;
                }
                let Some((t, wall)) = wall.filter(|&(t, _)| t < t1) else { break };
                // Frame instants have no contact times to run the TC model on: only the jam rule.
                let impulse = match self.rules.wall(body, t, physics.restitution, 0.0) {
                    // A body alone: its cluster is itself, stopped at the wall.
                    Rule::Jam => {
                        out.stats.jam_contacts += 1;
                        let v = bodies.velocity_at(i, t);
                        let stopped = v - v.dot(wall.outward_normal()).max(0.0) * wall.outward_normal();
                        bodies.set_velocity_at(i, t, stopped);
                        bodies.mass(i) * (v - stopped).length()
                    }
                    // Under gravity with restitution below 1 it comes to rest on a floor as in the
                    // continuous methods (see [`crate::response::rest`]), or it would bounce
                    // without end.
                    Rule::Impulse { restitution, .. } if rest::applies(bodies, physics) => {
                        let (v, before) = (bodies.velocity_at(i, t), bodies.rest_of(i));
                        if rest::on_wall(bodies, physics, i, wall, t, restitution, false) {
                            out.stats.rest_contacts += 1;
                            bodies.mass(i) * (v - bodies.velocity(i)).length()
                        } else {
                            let impulse = bounce_off_wall(bodies, i, wall, t, restitution);
                            rest::keep_held(bodies, physics, i, t, before);
                            impulse
                        }
                    }
                    Rule::Impulse { restitution, .. } => bounce_off_wall(bodies, i, wall, t, restitution),
                };
                let normal = wall.outward_normal();
                let point = bodies.position_at(i, t) + normal * bodies.radius(i);
                out.contacts.push(Contact {
                    time: t,
                    body: bodies.handle(i),
                    touched: Touched::Wall(wall),
                    point,
                    normal,
                    impulse,
                });
            }
        }
        out.contacts.sort_by(|x, y| x.time.total_cmp(&y.time).then(x.body.index().cmp(&y.body.index())));
        out.stats.response_seconds += start.elapsed().as_secs_f64();
        self.find_overlaps(bodies, t1, out);
        let start = Instant::now();
        for k in 0..self.current.len() {
            let (a, b) = self.current[k];
            let (i, j) = (a as usize, b as usize);
            let normal = direction(bodies.periodic.nearest(self.centre[j] - self.centre[i])).unwrap_or(DVec3::X);
            let mut impulse = 0.0;
            if physics.mode == Mode::Simulate {
                let before_j = bodies.velocity_at(j, t1);
                impulse = push_spheres(bodies, (i, j), t1, normal, physics.restitution);
                if impulse == 0.0 {
                    continue;
                }
                out.stats.pair_virial += exchange_virial(bodies, (i, j), t1, before_j);
            } else if self.previous.binary_search(&(a, b)).is_ok() {
                continue;
            }
            out.stats.pair_contacts += 1;
            out.contacts.push(self.contact(bodies, (i, j), normal, t1, impulse));
        }
        if physics.report_ends {
            // Pairs overlapping at the last instant and not at this one parted in between (a
            // removed body's pairs left `current` with it, so they are gone, not apart).
            for &(a, b) in &self.previous {
                let (i, j) = (a as usize, b as usize);
                debug_assert!(bodies.alive[i] && bodies.alive[j]);
                if self.current.binary_search(&(a, b)).is_ok() {
                    continue;
                }
                let normal = direction(bodies.periodic.nearest(self.centre[j] - self.centre[i])).unwrap_or(DVec3::X);
                out.stats.contact_ends += 1;
                out.ends.push(self.contact(bodies, (i, j), normal, t1, 0.0));
            }
        }
        out.stats.response_seconds += start.elapsed().as_secs_f64();
    }

    /// The contact (or contact end) of bodies `i` and `j` at `time`, at `i`'s surface along
    /// `normal` from its centre at this instant.
    fn contact(&self, bodies: &Bodies, (i, j): (usize, usize), normal: DVec3, time: f64, impulse: f64) -> Contact {
        Contact {
            time,
            body: bodies.handle(i),
            touched: Touched::Body(bodies.handle(j)),
            point: self.centre[i] + normal * bodies.radius(i),
            normal,
            impulse,
        }
    }
}

/// Tests bodies `i` and `j` with centres `pi` and `pj` (`j`'s, or its image's) for overlap, into
/// `current`.
#[inline]
fn test_pair(
    current: &mut Vec<(u32, u32)>,
    bodies: &Bodies,
    (i, pi): (u32, DVec3),
    (j, pj): (u32, DVec3),
    out: &mut Output,
) {
    let reach = bodies.radius(i as usize) + bodies.radius(j as usize);
    if (pi.y - pj.y).abs() > reach || (pi.z - pj.z).abs() > reach {
        return;
    }
    out.stats.candidate_pairs += 1;
    out.stats.narrow_tests += 1;
    // Scaled so the squares neither underflow nor overflow at any scale.
    let scale = crate::numeric::unit_scale(reach);
    if ((pi - pj) * scale).length_squared() < (reach * scale) * (reach * scale) {
        current.push(if i < j { (i, j) } else { (j, i) });
    }
}
