//! Moving a body between worlds bit for bit: a moving sphere's whole state as a record, read from
//! one world and added to another with the same motion, the same reference instant and the same
//! contact history, so the two worlds compute the same canonical contact times for it.
//!
//! This is what splits one world over several processes (vadop-mpi): each holds the bodies of
//! its part of the box and copies of its neighbours' bodies near the border, and all of them
//! agree on every contact to the bit. It also starts an empty world's clock at a given time, so a
//! part of a running world can be rebuilt at the time it had reached. It never steps a world and
//! never decides which bodies go where.

use super::World;
use crate::bodies::{Rest, Sphere};
use crate::error::{Result, VadopError};
use crate::handle::BodyHandle;
use crate::motion::Motion;
use glam::DVec3;

/// A moving sphere's whole state: its straight (or, under gravity, parabolic) motion from the
/// instant of its last velocity change, its size and mass, the time of its last contact (which
/// the TC model reads), in a periodic box its crossings of the faces, and under gravity how it is
/// held up (see [`Rest`]).
///
/// ```
/// use glam::DVec3;
/// use vadop::{BoxBounds, Sphere, World, WorldConfig};
/// let mut here = World::new(BoxBounds::cube(10.0)?, WorldConfig::default())?;
/// let ball = here.add_sphere(Sphere { position: DVec3::new(1.0, 5.0, 5.0), velocity: DVec3::new(-30.0, 0.0, 0.0), radius: 0.5, mass: 1.0 })?;
/// here.step(0.1)?; // it bounced off the wall at x = 0 at 1/60 s
/// let record = here.record(ball)?;
/// assert_eq!(record.since, 1.0 / 60.0);
/// // Another world at the same time takes it over on the very same motion.
/// let mut there = World::new(BoxBounds::cube(10.0)?, WorldConfig::default())?;
/// there.start_at(here.time())?;
/// let moved = there.add_record(&record)?;
/// assert_eq!(there.record(moved)?, record);
/// # Ok::<(), vadop::VadopError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SphereRecord {
    /// Centre at `since`.
    pub position: DVec3,
    /// The instant of the body's last velocity change: canonical contact times are computed from
    /// it, so it must travel with the body.
    pub since: f64,
    pub velocity: DVec3,
    pub radius: f64,
    pub mass: f64,
    /// Time of the body's last contact, if any.
    pub last_contact: Option<f64>,
    /// Crossings of each periodic axis's faces (see [`World::crossings`]); zero in a walled box.
    pub crossings: [i64; 3],
    /// How it is held up under gravity: falling, unless it came to rest.
    #[serde(default)]
    pub rest: Rest,
}

impl World {
    /// The whole state of the moving sphere `handle` (see [`SphereRecord`]).
    pub fn record(&self, handle: BodyHandle) -> Result<SphereRecord> {
        let i = self.live_slot(handle)?;
        if !self.bodies.is_sphere(i) || self.bodies.is_fixed(i) {
            return Err(VadopError::NotASphere(handle));
        }
        let motion = self.bodies.state[i].motion;
        Ok(SphereRecord {
            position: motion.position,
            since: motion.since,
            velocity: motion.velocity,
            radius: self.bodies.radius(i),
            mass: self.bodies.mass(i),
            last_contact: self.last_contact(i),
            crossings: self.bodies.crossings_of(i),
            rest: self.bodies.rest_of(i),
        })
    }

    /// Adds a moving sphere on the motion `record` holds, which may have started before the
    /// world's time; returns its handle. Fails, adding nothing, on a state stepping could not
    /// have produced: bad numbers, a motion or last contact after the world's time, a sphere
    /// outside the box at its last velocity change or now, crossings in a walled box.
    pub fn add_record(&mut self, record: &SphereRecord) -> Result<BodyHandle> {
        self.check_record(record)?;
        let sphere =
            Sphere { position: record.position, velocity: record.velocity, radius: record.radius, mass: record.mass };
        let handle = self.place_with(|bodies, slot, _| {
            bodies.put(slot, sphere, record.since);
            if record.crossings != [0; 3] {
                bodies.crossings.resize(bodies.slots(), [0; 3]);
                bodies.crossings[slot] = record.crossings;
            }
            bodies.set_rest(slot, record.rest);
        })?;
        if let Some(t) = record.last_contact {
            self.set_last_contact(handle.index() as usize, t);
        }
        Ok(handle)
    }

    /// Sets the clock of a world that holds no body and has never stepped to `time`: a part of a
    /// running world rebuilt where it stood (see [`World::add_record`]).
    pub fn start_at(&mut self, time: f64) -> Result<()> {
        if !(time.is_finite() && time >= 0.0) {
            return Err(VadopError::BadStartTime(time));
        }
        if self.engine.is_some() || self.bodies.slots() > 0 {
            return Err(VadopError::AlreadyStarted);
        }
        self.time = time;
        Ok(())
    }

    fn check_record(&mut self, record: &SphereRecord) -> Result<()> {
        let time = self.time;
        if !(record.since.is_finite() && record.since <= time) {
            return Err(VadopError::BadRecordTime { what: "since", value: record.since, time });
        }
        if let Some(last) = record.last_contact {
            if !(last.is_finite() && last <= time) {
                return Err(VadopError::BadRecordTime { what: "last contact", value: last, time });
            }
        }
        if record.crossings != [0; 3] && !self.bounds.is_periodic() {
            return Err(VadopError::CrossingsInWalledBox);
        }
        if !record.rest.fits(record.velocity, self.config.gravity) {
            return Err(VadopError::BadRecordRest(format!("{:?}", record.rest)));
        }
        let at = |position| Sphere { position, velocity: record.velocity, radius: record.radius, mass: record.mass };
        let motion = Motion { position: record.position, since: record.since, velocity: record.velocity };
        // Bodies end a frame up to a rounding error outside the box, as a saved world's do.
        let exact = self.bounds;
        self.bounds = exact.with_rounding_slack();
        let checked = self.check_sphere(&at(record.position)).and_then(|()| {
            self.check_sphere(&at(motion.at_under(time, record.rest.acceleration(self.config.gravity))))
        });
        self.bounds = exact;
        checked
    }
}
