//! Save and resume: the whole state of a [`World`] as a versioned JSON file, written atomically,
//! from which stepping continues bit-exactly as if the world had never stopped.
//!
//! It owns the file format and its validation. What is saved: the settings, the box, the time,
//! every body slot (removed ones too, so ids are reused in the same order), the free ids and the
//! bodies added since the last step. What is not: the broad phase, the queue and the last frame's
//! statistics, which are rebuilt or reset. That cannot change a contact, because candidate
//! generation only decides which pairs are tested, never what a test finds: the VADOP world and
//! the brute-force oracle already agree bit for bit whatever their broad-phase history.
//! Numbers are written in the shortest form that reads back to the same bits.
//!
//! It never writes a file in place: a run killed mid-write leaves the previous file intact.

use super::{BoxBounds, World, WorldConfig};
use crate::bodies::Sphere;
use crate::error::{Result, VadopError};
use glam::DVec3;
use std::io::Write;
use std::path::Path;

/// First field of every world file, so other JSON files are recognised as such.
const FORMAT: &str = "vadop-world";
/// Bumped on every incompatible change of the layout.
const VERSION: u32 = 1;

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
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Slot {
    position: DVec3,
    velocity: DVec3,
    /// Time at which `position` holds.
    since: f64,
    radius: f64,
    mass: f64,
    stamp: u32,
    alive: bool,
}

impl World {
    /// Writes the whole world to `path` atomically (a temporary file beside it, flushed to disk,
    /// then renamed into place). Call between frames; [`World::load`] resumes bit-exactly.
    pub fn save(&self, path: &Path) -> Result<()> {
        let io = |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let b = &self.bodies;
        let slots = (0..b.slots())
            .map(|i| Slot {
                position: b.position[i],
                velocity: b.velocity[i],
                since: b.since[i],
                radius: b.radius[i],
                mass: b.mass[i],
                stamp: b.stamp[i],
                alive: b.alive[i],
            })
            .collect();
        let snapshot = Snapshot {
            format: FORMAT.to_string(),
            version: VERSION,
            config: self.config,
            bounds: self.bounds,
            time: self.time,
            slots,
            free_slots: self.free_slots.clone(),
            unplaced: self.unplaced.clone(),
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
    /// or on any value the world would not have accepted.
    pub fn load(path: &Path) -> Result<World> {
        let bad = |message: String| VadopError::Io { path: path.display().to_string(), message };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let snapshot: Snapshot = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if snapshot.format != FORMAT || snapshot.version != VERSION {
            return Err(bad(format!(
                "not a {FORMAT} file of version {VERSION} (format {:?}, version {})",
                snapshot.format, snapshot.version
            )));
        }
        let mut world = World::new(snapshot.bounds, snapshot.config)?;
        if !(snapshot.time.is_finite() && snapshot.time >= 0.0) {
            return Err(bad(format!("time must be finite and >= 0, got {}", snapshot.time)));
        }
        world.time = snapshot.time;
        // Bodies end a frame up to a rounding error outside the box; a corrupt file is further out.
        let side = (world.bounds.max - world.bounds.min).max_element();
        let slack = 1e-6 * side;
        let exact = world.bounds;
        world.bounds = BoxBounds { min: exact.min - slack, max: exact.max + slack };
        for (i, slot) in snapshot.slots.iter().enumerate() {
            let sphere = Sphere { position: slot.position, velocity: slot.velocity, radius: slot.radius, mass: slot.mass };
            world.check_sphere(&sphere).map_err(|e| bad(format!("slot {i}: {e}")))?;
            if !(slot.since.is_finite() && slot.since <= snapshot.time) {
                return Err(bad(format!("slot {i}: since must be finite and <= time, got {}", slot.since)));
            }
            world.bodies.put(i, sphere, slot.since);
            world.bodies.stamp[i] = slot.stamp;
            world.bodies.alive[i] = slot.alive;
        }
        world.bounds = exact;
        let slots = snapshot.slots.len();
        let dead = snapshot.slots.iter().filter(|s| !s.alive).count();
        let mut free = snapshot.free_slots.clone();
        free.sort_unstable();
        free.dedup();
        let consistent = free.len() == snapshot.free_slots.len()
            && free.len() == dead
            && free.iter().all(|&id| (id as usize) < slots && !snapshot.slots[id as usize].alive)
            && snapshot.unplaced.iter().all(|&id| (id as usize) < slots && snapshot.slots[id as usize].alive);
        if !consistent {
            return Err(bad("free and unplaced ids do not match the slots".to_string()));
        }
        world.live = slots - dead;
        world.free_slots = snapshot.free_slots;
        // Enter the bodies that had been stepped into a fresh broad phase now, so the next step
        // checks only the bodies added since the last one, exactly as the saved world would.
        let mut waiting = snapshot.unplaced.clone();
        waiting.sort_unstable();
        world.unplaced = world.bodies.alive_ids().filter(|id| waiting.binary_search(id).is_err()).collect();
        world.place_new_bodies();
        world.prime_discrete();
        world.unplaced = snapshot.unplaced;
        Ok(world)
    }

    /// The pseudo-dynamic baseline reports an overlap only when it is new: recompute which pairs
    /// overlapped at the last frame instant, as the saved world remembered.
    fn prime_discrete(&mut self) {
        if let super::BroadPhase::Discrete(pd) = &mut self.broad {
            pd.update(&self.bodies);
            pd.sort();
            pd.find_overlaps(&self.bodies);
        }
    }
}
