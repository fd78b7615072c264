//! Save and resume: the whole state of a [`World`] as a versioned JSON file, written atomically,
//! from which stepping continues bit-exactly as if the world had never stopped.
//!
//! It owns the file format and its validation. What is saved: the settings, the box, the time,
//! every body slot (removed ones too, so slots are reused in the same order) with its generation
//! (so the handles of removed bodies stay stale), the time of its last velocity change and of its
//! last contact (the TC model depends on it), the free slots, the bodies added since the last
//! step, and the pairs in contact (for the pseudo-dynamic method the pairs it saw overlapping,
//! for a world that reports contact ends its touching pairs and when each contact started, where
//! the search for its end starts), and in a periodic box each body's crossings. What is not: the broad phase, the proxies and the queue, which are rebuilt. That
//! cannot change a contact, because contact times are canonical and candidate generation only
//! decides which pairs are tested, never what a test finds. Numbers are written in the shortest
//! form that reads back to the same bits.
//!
//! A file is validated as a whole before anything is built from it: every value the world would
//! have refused, times out of order, bodies outside the box at either end of their current motion,
//! overlapping bodies in a simulate-mode world of a continuous method, inconsistent slots or
//! generations. A loaded world is one stepping could have produced. It never writes a file in place: a run killed mid-write leaves the
//! previous file intact.

use super::{BoxBounds, Mode, World, WorldConfig};
use crate::bodies::{Rest, RigidState, Sphere};
use crate::error::{Result, VadopError};
use crate::handle::BodyHandle;
use crate::motion::Motion;
use crate::shape::{Shape, ShapeGeometry};
use glam::{DQuat, DVec3};
use std::io::Write;
use std::path::Path;

/// First field of every world file, so other JSON files are recognised as such.
const FORMAT: &str = "vadop-world";
/// Bumped on every incompatible change of the layout. Version 1 files (no contact history, every
/// position at the saved time), version 2 files (no generations) and version 4 files (no contact
/// starts) still load.
const VERSION: u32 = 5;
/// The first version that saves generations.
const GENERATIONS: u32 = 3;
/// The first version that saves when the touching pairs' contacts started.
const CONTACT_STARTS: u32 = 5;

#[derive(serde::Serialize, serde::Deserialize)]
struct Snapshot {
    format: String,
    version: u32,
    config: WorldConfig,
    bounds: BoxBounds,
    time: f64,
    slots: Vec<Slot>,
    free_slots: Vec<u32>,
    unplaced: Vec<u32>,
    /// Pairs (i < j) in contact at the saved instant: the pseudo-dynamic method's overlaps at its
    /// last frame instant, or the touching pairs of a world that reports contact ends.
    #[serde(default)]
    overlapping: Vec<(u32, u32)>,
    /// For a world that reports contact ends, when each of `overlapping` started touching.
    #[serde(default)]
    touching_since: Vec<f64>,
    /// The store's shapes in id order (the users', and one per plain sphere radius once the world
    /// holds rigid bodies), and which are the users'.
    #[serde(default)]
    shapes: Vec<Shape>,
    #[serde(default)]
    user_shapes: Vec<u32>,
    /// True when the store keeps shapes and spins for every slot (then every slot has one).
    #[serde(default)]
    rigid: bool,
    /// Bodies that lay still, moved or removed since the last step: where they were and their
    /// radii, so the next step wakes what lay on them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    released: Vec<(DVec3, f64)>,
}

/// A rigid body's shape and spin: its shape's id, its orientation and angular velocity at its
/// last velocity change, and whether it is static (a static slot's mass, infinite, is written as
/// 0: JSON has no infinity).
#[derive(serde::Serialize, serde::Deserialize)]
struct SlotSpin {
    shape: u32,
    orientation: DQuat,
    angular_velocity: DVec3,
    fixed: bool,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Slot {
    position: DVec3,
    velocity: DVec3,
    /// Time at which `position` holds (the body's last velocity change).
    since: f64,
    radius: f64,
    mass: f64,
    alive: bool,
    /// The slot's generation: of a live slot its body's, of a removed one its next body's.
    #[serde(default)]
    generation: u32,
    /// Time of the body's last contact, if any.
    #[serde(default)]
    last_contact: Option<f64>,
    /// A world with rigid bodies: the slot's shape and spin.
    #[serde(default)]
    spin: Option<SlotSpin>,
    /// In a periodic box: the body's crossings of each periodic axis's faces.
    #[serde(default, skip_serializing_if = "is_zero")]
    crossings: [i64; 3],
    /// Under gravity: how the body is held up, when at rest.
    #[serde(default, skip_serializing_if = "is_falling")]
    rest: Rest,
}

fn is_falling(rest: &Rest) -> bool {
    *rest == Rest::Falling
}

fn is_zero(crossings: &[i64; 3]) -> bool {
    *crossings == [0; 3]
}

impl Slot {
    /// The slot's generation in a file of `version`. Files before generations named bodies by
    /// slot alone: their bodies are generation 0, and a removed slot's next body generation 1,
    /// so the old id of a removed body stays stale.
    fn generation(&self, version: u32) -> u32 {
        if version >= GENERATIONS {
            self.generation
        } else {
            u32::from(!self.alive)
        }
    }
}

impl World {
    /// Writes the whole world to `path` atomically (a temporary file beside it, flushed to disk,
    /// then renamed into place). Call between frames; [`World::load`] resumes bit-exactly.
    pub fn save(&self, path: &Path) -> Result<()> {
        let io =
            |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let b = &self.bodies;
        let slots = (0..b.slots())
            .map(|i| Slot {
                position: b.state[i].motion.position,
                velocity: b.velocity(i),
                since: b.state[i].motion.since,
                radius: b.radius(i),
                mass: if b.is_fixed(i) { 0.0 } else { b.mass(i) },
                alive: b.alive[i],
                generation: b.generation(i),
                last_contact: self.last_contact(i),
                crossings: b.crossings_of(i),
                rest: b.rest_of(i),
                spin: b.has_rigid().then(|| SlotSpin {
                    shape: b.rigid.shape[i],
                    orientation: b.rigid.spin_start[i].0,
                    angular_velocity: b.rigid.spin_start[i].1,
                    fixed: b.rigid.fixed[i],
                }),
            })
            .collect();
        let (overlapping, touching_since) =
            self.engine.as_ref().map_or_else(Default::default, |engine| engine.touching_since());
        let snapshot = Snapshot {
            format: FORMAT.to_string(),
            version: VERSION,
            config: self.config,
            bounds: self.bounds,
            time: self.time,
            slots,
            free_slots: self.free_slots.clone(),
            unplaced: self.unplaced.clone(),
            released: self.released.clone(),
            overlapping,
            touching_since,
            shapes: b.rigid.shapes.iter().map(|g| g.shape().clone()).collect(),
            user_shapes: self.user_shapes.clone(),
            rigid: b.has_rigid(),
        };
        let text = serde_json::to_string(&snapshot).map_err(|e| io(&e))?;
        let mut temporary = path.as_os_str().to_owned();
        temporary.push(".partial");
        let temporary = std::path::PathBuf::from(temporary);
        let mut file = std::fs::File::create(&temporary).map_err(|e| io(&e))?;
        file.write_all(text.as_bytes()).and_then(|()| file.sync_all()).map_err(|e| io(&e))?;
        std::fs::rename(&temporary, path).map_err(|e| io(&e))
    }

    /// Reads a world written by [`World::save`]. Fails on a file of another format or version,
    /// or on any state stepping could not have produced.
    pub fn load(path: &Path) -> Result<World> {
        let bad = |message: String| VadopError::Io { path: path.display().to_string(), message };
        // Bounded by the memory left: a device or a huge file is refused, not read until the
        // system runs out.
        let snapshot: Snapshot = crate::memory::read_json(path).map_err(bad)?;
        if snapshot.format != FORMAT || !(1..=VERSION).contains(&snapshot.version) {
            return Err(bad(format!(
                "not a {FORMAT} file of version 1 to {VERSION} (format {:?}, version {})",
                snapshot.format, snapshot.version
            )));
        }
        let mut world = World::new(snapshot.bounds, snapshot.config).map_err(|e| bad(e.to_string()))?;
        let time = snapshot.time;
        if !(time.is_finite() && time >= 0.0) {
            return Err(bad(format!("time must be finite and >= 0, got {time}")));
        }
        world.time = time;
        // Bodies end a frame up to a rounding error outside the box; a damaged file is further out.
        let exact = world.bounds;
        world.bounds = exact.with_rounding_slack();
        let shapes = snapshot
            .shapes
            .iter()
            .enumerate()
            .map(|(k, shape)| shape.geometry().map_err(|e| bad(format!("shape {k}: {e}"))))
            .collect::<Result<Vec<ShapeGeometry>>>()?;
        let users_valid = snapshot.user_shapes.windows(2).all(|w| w[0] < w[1])
            && snapshot.user_shapes.iter().all(|&k| (k as usize) < shapes.len());
        if !users_valid {
            return Err(bad("user shapes must be ascending ids of saved shapes".to_string()));
        }
        let rigid = snapshot.rigid;
        if snapshot.slots.iter().any(|slot| slot.spin.is_some() != rigid) {
            return Err(bad("every slot has a shape and spin exactly when the world keeps them".to_string()));
        }
        world.bodies.rigid.restore_shapes(shapes, &snapshot.user_shapes);
        world.user_shapes = snapshot.user_shapes.clone();
        if rigid {
            world.bodies.make_rigid();
        }
        for (i, slot) in snapshot.slots.iter().enumerate() {
            let at =
                |position: DVec3| Sphere { position, velocity: slot.velocity, radius: slot.radius, mass: slot.mass };
            if !(slot.since.is_finite() && slot.since <= time) {
                return Err(bad(format!("slot {i}: since must be finite and <= time {time}, got {}", slot.since)));
            }
            if let Some(last) = slot.last_contact {
                if !(last.is_finite() && last <= time) {
                    return Err(bad(format!("slot {i}: last contact must be finite and <= time {time}, got {last}")));
                }
            }
            // A removed body's slot only keeps its place and generation; a live one must be where
            // stepping put it.
            let motion = Motion { position: slot.position, since: slot.since, velocity: slot.velocity };
            if !slot.rest.fits(slot.velocity, world.config.gravity) {
                return Err(bad(format!(
                    "slot {i}: rest {:?} needs gravity, and no velocity along the walls it slides on (axes as bits 1 to 7) or none at all lying still",
                    slot.rest
                )));
            }
            if slot.alive {
                let fixed = slot.spin.as_ref().is_some_and(|spin| spin.fixed);
                world.check_supported(fixed).map_err(|e| bad(format!("slot {i}: {e}")))?;
            }
            let now = motion.at_under(time, slot.rest.acceleration(world.config.gravity));
            let checked = match &slot.spin {
                None => world.check_sphere(&at(slot.position)).and_then(|()| match slot.alive {
                    true => world.check_sphere(&at(now)),
                    false => Ok(()),
                }),
                Some(spin) => world.check_slot_spin(slot, spin, now),
            };
            checked.map_err(|e| bad(format!("slot {i}: {e}")))?;
            // A live body's generation is one a slot can hold; a removed one's was bumped at least
            // once, and at most to retirement.
            let generation = slot.generation(snapshot.version);
            let generations = match slot.alive {
                true => 0..=BodyHandle::MAX_GENERATION,
                false => 1..=BodyHandle::MAX_GENERATION + 1,
            };
            if !generations.contains(&generation) {
                return Err(bad(format!(
                    "slot {i}: generation must lie in {generations:?} for a {} slot, got {generation}",
                    if slot.alive { "live" } else { "removed" }
                )));
            }
            match &slot.spin {
                None => world.bodies.put(i, at(slot.position), slot.since),
                Some(spin) => {
                    let state = RigidState {
                        shape: spin.shape,
                        radius: slot.radius,
                        position: slot.position,
                        orientation: spin.orientation,
                        velocity: slot.velocity,
                        angular_velocity: spin.angular_velocity,
                        mass: if spin.fixed { f64::INFINITY } else { slot.mass },
                        fixed: spin.fixed,
                    };
                    world.bodies.put_rigid(i, state, slot.since);
                }
            }
            world.bodies.alive[i] = slot.alive;
            world.bodies.tags[i].generation = generation;
            if slot.crossings != [0; 3] {
                if !world.bounds.is_periodic() {
                    return Err(bad(format!("slot {i}: crossings are counted in a periodic box only")));
                }
                world.bodies.crossings.resize(world.bodies.slots(), [0; 3]);
                world.bodies.crossings[i] = slot.crossings;
            }
            world.bodies.set_rest(i, slot.rest);
        }
        world.bounds = exact;
        let slots = snapshot.slots.len();
        let dead = snapshot.slots.iter().filter(|s| !s.alive).count();
        let reusable = |i: usize| !world.bodies.alive[i] && world.bodies.is_reusable(i);
        let mut free = snapshot.free_slots.clone();
        free.sort_unstable();
        free.dedup();
        let mut waiting = snapshot.unplaced.clone();
        waiting.sort_unstable();
        waiting.dedup();
        let consistent = free.len() == snapshot.free_slots.len()
            && free.len() == (0..slots).filter(|&i| reusable(i)).count()
            && free.iter().all(|&slot| (slot as usize) < slots && reusable(slot as usize))
            && waiting.len() == snapshot.unplaced.len()
            && waiting.iter().all(|&slot| (slot as usize) < slots && snapshot.slots[slot as usize].alive);
        if !consistent {
            return Err(bad("free and unplaced slots do not match the slots".to_string()));
        }
        let pairs_valid = snapshot.overlapping.windows(2).all(|w| w[0] < w[1])
            && snapshot.overlapping.iter().all(|&(a, b)| {
                a < b && (b as usize) < slots && snapshot.slots[a as usize].alive && snapshot.slots[b as usize].alive
            });
        let keeps_pairs = snapshot.config.method == super::Method::Discrete || snapshot.config.contact_ends;
        if !pairs_valid || (!snapshot.overlapping.is_empty() && !keeps_pairs) {
            return Err(bad(
                "overlapping pairs must be ascending pairs of live bodies, saved by the discrete method or a world \
                 that reports contact ends"
                    .to_string(),
            ));
        }
        // A contact in progress started at or before the saved time. Older files do not say when:
        // its end is then searched from the saved time, as the saving run's next window did.
        let discrete = snapshot.config.method == super::Method::Discrete;
        let touching_since = match !discrete && snapshot.version < CONTACT_STARTS {
            true => vec![time; snapshot.overlapping.len()],
            false => snapshot.touching_since,
        };
        let starts = if discrete { 0 } else { snapshot.overlapping.len() };
        let starts_valid =
            touching_since.len() == starts && touching_since.iter().all(|&since| since.is_finite() && since <= time);
        if !starts_valid {
            return Err(bad(format!(
                "a world that reports contact ends saves one contact start, finite and <= time {time}, per touching \
                 pair (the discrete method none)"
            )));
        }
        world.live = slots - dead;
        world.free_slots = snapshot.free_slots;
        // The pseudo-dynamic method finds overlaps only after they happen: its worlds may hold some.
        if world.config.mode == Mode::Simulate && world.config.method != super::Method::Discrete {
            if let Some((a, b, depth)) =
                crate::world::overlap::first_overlap(&world.bodies, &world.stepped(&waiting), time)
            {
                let (a, b) = (world.bodies.handle(a as usize), world.bodies.handle(b as usize));
                return Err(bad(format!(
                    "bodies {a} and {b} overlap by {depth:.3e}: a simulate-mode world never holds overlapping bodies"
                )));
            }
        }
        // Enter the bodies that had been stepped into a fresh engine now, so the next step
        // checks only the bodies added since the last one, exactly as the saved world would.
        world.enter_stepped(snapshot.unplaced);
        if !snapshot.released.iter().all(|&(p, r)| p.is_finite() && r.is_finite() && r > 0.0) {
            return Err(bad("released bodies need finite positions and positive radii".to_string()));
        }
        world.released = snapshot.released;
        if let Some(rules) = world.rules_mut() {
            rules.resize(slots);
            for (i, slot) in snapshot.slots.iter().enumerate() {
                rules.set_last_contact(i, slot.last_contact.unwrap_or(f64::NEG_INFINITY));
            }
        }
        if let Some(engine) = &mut world.engine {
            engine.restore_touching(snapshot.overlapping, touching_since);
        }
        Ok(world)
    }
}

impl World {
    /// A saved rigid slot is one stepping could have produced: a saved shape (level geometry only
    /// when static), a rotation, finite motion, and a moving body inside the box at its last
    /// velocity change and now.
    fn check_slot_spin(&self, slot: &Slot, spin: &SlotSpin, now: DVec3) -> Result<()> {
        let Some(geometry) = self.bodies.rigid.shapes.get(spin.shape as usize) else {
            return Err(VadopError::NoSuchShape(spin.shape));
        };
        crate::error::check_vector("velocity", slot.velocity)?;
        crate::error::check_vector("angular velocity", spin.angular_velocity)?;
        let q = spin.orientation;
        if !(q.is_finite() && (q.length_squared() - 1.0).abs() < 1e-9) {
            return Err(VadopError::BadOrientation(q.to_array()));
        }
        if spin.fixed {
            return Ok(());
        }
        if geometry.is_static_only() {
            return Err(VadopError::StaticOnlyShape(spin.shape));
        }
        if !(slot.mass.is_finite() && slot.mass > 0.0) {
            return Err(VadopError::BadMass(slot.mass));
        }
        self.check_inside(geometry, slot.position, q, slot.position)?;
        // Its orientation now follows from the spin; its centre of mass, inside its shape, stays
        // inside the box.
        if slot.alive && !(now.cmpge(self.bounds.min).all() && now.cmple(self.bounds.max).all()) {
            return Err(VadopError::ShapeOutsideBox {
                position: now.to_array(),
                low: now.to_array(),
                high: now.to_array(),
            });
        }
        Ok(())
    }
}
