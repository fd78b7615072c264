//! The body store: the state of every body in flat arrays, indexed by body id.
//!
//! Inside the engine a body's id is its slot index, reused after a removal; users name bodies by
//! [`BodyHandle`], the slot and its generation. The store owns each body's motion and bounding
//! radius, its mass, the per-body velocity stamp that voids stale predictions and each slot's
//! generation; and, once the world holds a body that is not a plain sphere, the [`Rigid`] part:
//! the world's shapes, each body's shape, its exact spin ([`FreeRotation`]) and whether it is
//! static. A world of spheres never allocates that part. It never moves bodies on its own or
//! knows about axes or contacts. A position is
//! stored together with the time it refers to (`since`), so a body that changed velocity
//! mid-frame is evaluated exactly as p(t) = p + (t - since) * v by every method alike.
//! The motion and the radius share one cache line per body ([`BodyState`]): it is what the
//! narrow phase reads for a candidate pair, and the proxy table reads it from here rather than
//! keeping a copy. The mass, the stamp and the generation share 16 bytes per body ([`BodyTag`]):
//! the event loop reads the stamps of an event's bodies to see it is current, and then, for a
//! collision, their masses and generations.

use crate::frame::Mode;
use crate::handle::BodyHandle;
use crate::memory::prefetch_item;
use crate::motion::free_rotation::FreeRotation;
use crate::motion::hold::without_axes;
pub use crate::motion::hold::Rest;
use crate::motion::Motion;
use crate::motion::{RigidMotion, Spin};
use crate::shape::ShapeGeometry;
use crate::walls::{Periodic, Wall};
use glam::{DQuat, DVec3};

mod stamps;
pub(crate) use stamps::FORESEEN_STEP;

/// One sphere as users see it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sphere {
    /// Centre position.
    pub position: DVec3,
    /// Linear velocity (units per second).
    pub velocity: DVec3,
    /// Radius, > 0.
    pub radius: f64,
    /// Mass, > 0.
    pub mass: f64,
}

/// What the narrow phase needs of a body, in one cache line: its straight motion since its last
/// velocity change and the radius of the sphere about its centre that holds the whole body.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct BodyState {
    pub motion: Motion,
    pub radius: f64,
}

impl Default for BodyState {
    fn default() -> Self {
        BodyState { motion: Motion { position: DVec3::ZERO, since: 0.0, velocity: DVec3::ZERO }, radius: 0.0 }
    }
}

/// What the event loop reads of a body beside its motion, together: the stamp that tells an
/// event is current, and a collision's mass and handle. In one record rather than three arrays
/// the line an event's check misses on serves its collision too (8 bytes of `mass` and 4 of each
/// counter: four bodies a line).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C, align(16))]
pub struct BodyTag {
    pub mass: f64,
    /// Bumped on every velocity change (and on removal): predictions made earlier are void.
    pub stamp: u32,
    /// Of a live slot, its body's generation; of a removed one, the generation its next body
    /// gets (above [`BodyHandle::MAX_GENERATION`]: retired, never reused).
    pub(crate) generation: u32,
}

/// Flat store of all bodies; removed slots stay until reused (lowest first, by the world).
#[derive(Debug, Default, Clone)]
pub struct Bodies {
    /// Motion and radius of each body.
    pub state: Vec<BodyState>,
    /// Mass, stamp and generation of each body.
    pub tags: Vec<BodyTag>,
    pub alive: Vec<bool>,
    /// No live body is faster than this: raised by every velocity written and lowered only by
    /// `Bodies::tighten_speed_bound`, so a step need not read every body to rule out an absurd
    /// speed.
    pub speed_bound: f64,
    /// The world's uniform acceleration: every moving body's path is a parabola under it (static
    /// bodies stay put), so two moving bodies keep a straight relative motion.
    pub gravity: DVec3,
    /// The box's periodic axes: pairs meet through their nearest image across them.
    pub periodic: Periodic,
    /// Whether contacts turn bodies back ([`Mode::turns_back`]): a pair's search needs it to
    /// tell a contact in progress from one to turn back.
    pub mode: Mode,
    /// Per slot, in a periodic box: how many times the body's centre crossed each periodic
    /// axis's faces (+1 out through the max face, -1 through the min face), so its unwrapped
    /// position is its position plus these times the sides. Empty until a first crossing.
    pub crossings: Vec<[i64; 3]>,
    /// Per slot, under gravity: how the body is held up. Empty until a first body comes to rest.
    pub rest: Vec<Rest>,
    /// Shapes, spins and static bodies: empty in a world of plain spheres.
    pub rigid: Rigid,
    /// While a step that may be interrupted runs: each motion it overwrote, oldest first, so
    /// that [`Bodies::undo`] can take the store back to the step's start.
    undo: Option<Vec<Overwritten>>,
    /// One bit per slot present at the last [`Bodies::mark_stamps`]: set when the slot's stamp
    /// was bumped since. Empty until a first mark.
    bumped: Vec<u64>,
}

/// A body's motion (and spin, when the store keeps spins) as a step found it.
#[derive(Debug, Clone)]
struct Overwritten {
    slot: usize,
    state: BodyState,
    /// The crossing a wrap counted, on its axis, `+1` or `-1`.
    crossed: Option<(usize, i64)>,
    rest: Rest,
    spin: Option<(FreeRotation, (DQuat, DVec3))>,
}

/// What bodies that are not plain spheres add to the store, kept only once a world holds one:
/// then every slot has an entry, and a sphere added as a plain [`Sphere`] gets the shape of its
/// radius (one per distinct radius), its spin steady.
#[derive(Debug, Default, Clone)]
pub struct Rigid {
    /// The world's shapes, by [`crate::world::ShapeId`]: the users' and the plain spheres'.
    pub shapes: Vec<ShapeGeometry>,
    /// The shape of each plain sphere's radius (by its bits), among `shapes`.
    sphere_shapes: std::collections::BTreeMap<u64, u32>,
    /// Per slot: the body's shape.
    pub shape: Vec<u32>,
    /// Per slot: the body's exact rotation since its last velocity change.
    pub spin: Vec<FreeRotation>,
    /// Per slot: the orientation and angular velocity its spin started from (at its last
    /// velocity change), which rebuild the spin bit-exactly (a saved world).
    pub spin_start: Vec<(DQuat, DVec3)>,
    /// Per slot: a static body, which never moves, has infinite mass and is no broad phase's.
    pub fixed: Vec<bool>,
    /// Per slot: bumped whenever the body's motion (its path or its spin) is written, but not when
    /// only its predictions are voided (a proxy renewal bumps the stamp alone): a shape search
    /// parked on the old motion is void, one parked on the same motion is taken up again.
    pub(crate) motion_epoch: Vec<u32>,
    /// Bumped whenever a static body is added or removed, so the static geometry is rebuilt.
    pub statics_revision: u64,
    /// True once the per-slot arrays are kept (a world of spheres never sets it).
    active: bool,
}

/// The spin of a body that does not turn, made once.
fn steady_spin() -> &'static FreeRotation {
    static STEADY: std::sync::LazyLock<FreeRotation> =
        std::sync::LazyLock::new(|| FreeRotation::new(DVec3::ONE, DQuat::IDENTITY, DVec3::ZERO));
    &STEADY
}

fn steady() -> FreeRotation {
    *steady_spin()
}

/// Principal moments of a body of `geometry` (a solid ball of `radius` without one) and `mass`;
/// a static body (infinite mass) never turns, and any positive moments describe its spin.
fn inertia_of(geometry: Option<&ShapeGeometry>, mass: f64, radius: f64) -> DVec3 {
    match geometry {
        _ if !mass.is_finite() => DVec3::ONE,
        Some(g) => g.principal_inertia_unit() * (mass / g.volume()),
        None => DVec3::splat(0.4 * mass * radius * radius),
    }
}

impl Spin for FreeRotation {
    #[inline]
    fn orientation_at(&self, dt: f64) -> DQuat {
        FreeRotation::orientation_at(self, dt)
    }
    #[inline]
    fn max_angular_speed(&self) -> f64 {
        FreeRotation::max_angular_speed(self)
    }
    #[inline]
    fn steady_spin(&self) -> Option<DVec3> {
        FreeRotation::steady_spin(self)
    }
    #[inline]
    fn angular_velocity_at(&self, dt: f64) -> Option<DVec3> {
        Some(FreeRotation::angular_velocity_at(self, dt))
    }
    #[inline]
    fn max_angular_acceleration(&self) -> f64 {
        FreeRotation::max_angular_acceleration(self)
    }
    #[inline]
    fn orientation_and_angular_velocity_at(&self, dt: f64) -> (DQuat, Option<DVec3>) {
        let (orientation, omega) = FreeRotation::orientation_and_angular_velocity_at(self, dt);
        (orientation, Some(omega))
    }
}

/// A [`RigidState::shape`] meaning: a sphere of the state's radius.
pub(crate) const SPHERE: u32 = u32::MAX;

impl Rigid {
    /// Restores the shape table of a saved world: `shapes` in id order, the users' at `user`
    /// (the others are plain spheres' shapes).
    pub(crate) fn restore_shapes(&mut self, shapes: Vec<ShapeGeometry>, user: &[u32]) {
        for (id, geometry) in shapes.into_iter().enumerate() {
            if let (crate::shape::Shape::Sphere { radius }, false) = (geometry.shape(), user.contains(&(id as u32))) {
                self.sphere_shapes.insert(radius.to_bits(), id as u32);
            }
            self.shapes.push(geometry);
        }
    }

    /// The shape of a plain sphere of `radius`, added to the shapes the first time.
    fn sphere_shape(&mut self, radius: f64) -> u32 {
        let shapes = &mut self.shapes;
        *self.sphere_shapes.entry(radius.to_bits()).or_insert_with(|| {
            let geometry = crate::shape::Shape::Sphere { radius }.geometry().expect("a body's radius is a valid size");
            shapes.push(geometry);
            (shapes.len() - 1) as u32
        })
    }
}

/// A rigid body's motion and mass as the store keeps it; what [`Bodies::put_rigid`] writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RigidState {
    /// Index into [`Rigid::shapes`], or [`SPHERE`].
    pub shape: u32,
    /// Bounding radius about the centre of mass.
    pub radius: f64,
    /// Centre of mass.
    pub position: DVec3,
    /// Rotates body-frame (principal) vectors to world vectors.
    pub orientation: DQuat,
    pub velocity: DVec3,
    pub angular_velocity: DVec3,
    /// Infinite for a static body.
    pub mass: f64,
    pub fixed: bool,
}

/// The length of `velocity`, robust to squares that underflow: below about 1e-162 the largest
/// component stands in for it.
#[inline]
pub fn speed(velocity: DVec3) -> f64 {
    let length = velocity.length();
    if length > 0.0 {
        length
    } else {
        velocity.abs().max_element()
    }
}

impl Bodies {
    /// An empty store whose moving bodies fall under `gravity` in a box of `periodic` axes.
    pub(crate) fn new(gravity: DVec3, periodic: Periodic, mode: Mode) -> Bodies {
        Bodies { gravity, periodic, mode, ..Bodies::default() }
    }

    /// Centre of body `j` minus centre of body `i` at `t`, through the nearest image in a
    /// periodic box.
    #[inline]
    pub fn offset_at(&self, i: usize, j: usize, t: f64) -> DVec3 {
        self.nearest_offset(self.position_at(i, t), self.position_at(j, t)).0
    }

    /// `to - from` through the nearest image of `to` in a periodic box, and the whole sides that
    /// take `to` to that image (zero in a box without).
    #[inline]
    pub fn nearest_offset(&self, from: DVec3, to: DVec3) -> (DVec3, DVec3) {
        let offset = to - from;
        if !self.periodic.any() {
            return (offset, DVec3::ZERO);
        }
        let shift = self.periodic.shift(offset);
        (offset + shift, shift)
    }

    /// Body `i`'s centre at `t` unwrapped: its position plus its crossings times the sides.
    #[inline]
    pub fn unwrapped_at(&self, i: usize, t: f64) -> DVec3 {
        let crossed = self.crossings_of(i);
        self.position_at(i, t) + DVec3::from_array(std::array::from_fn(|a| crossed[a] as f64)) * self.periodic.side
    }

    /// What takes body `j`'s centre to its nearest image from body `i`'s at `t`: whole sides
    /// on the periodic axes (zero in a box without).
    #[inline]
    pub fn image_shift(&self, i: usize, j: usize, t: f64) -> DVec3 {
        if !self.periodic.any() {
            return DVec3::ZERO;
        }
        self.nearest_offset(self.position_at(i, t), self.position_at(j, t)).1
    }

    /// Body `i`'s crossings of the periodic faces (see [`Bodies::crossings`]).
    #[inline]
    pub fn crossings_of(&self, i: usize) -> [i64; 3] {
        self.crossings.get(i).copied().unwrap_or([0; 3])
    }

    /// Body `i`'s centre reached periodic face `face` at `t`: it comes back through the
    /// opposite face, on the same path, and the crossing is counted. Its motion starts afresh
    /// from `t` (voiding its predictions, as a velocity change does), so every method wraps it
    /// at the same canonical instant.
    pub(crate) fn wrap(&mut self, i: usize, face: Wall, t: f64) {
        let (axis, out) = (face.axis(), if face.is_max() { 1 } else { -1 });
        self.restart_at(i, t);
        let (low, high) = (self.periodic.min[axis], self.periodic.min[axis] + self.periodic.side[axis]);
        let x = &mut self.state[i].motion.position[axis];
        *x = (*x - out as f64 * self.periodic.side[axis]).clamp(low, high);
        // The undo entry the motion just wrote takes the crossing back too.
        if let Some(overwritten) = self.undo.as_mut().and_then(|log| log.last_mut()) {
            overwritten.crossed = Some((axis, out));
        }
        if self.crossings.len() < self.slots() {
            self.crossings.resize(self.slots(), [0; 3]);
        }
        self.crossings[i][axis] += out;
    }

    /// Number of slots, removed ones included.
    pub fn slots(&self) -> usize {
        self.state.len()
    }

    /// Centre of body `i` at absolute time `t`.
    #[inline]
    pub fn position_at(&self, i: usize, t: f64) -> DVec3 {
        self.state[i].motion.at_under(t, self.gravity_on(i))
    }

    /// Velocity of body `i` at absolute time `t`.
    #[inline]
    pub fn velocity_at(&self, i: usize, t: f64) -> DVec3 {
        self.state[i].motion.velocity_under(t, self.gravity_on(i))
    }

    /// True when the world has no gravity, so every path is a straight line: `gravity == ZERO`
    /// (a zero of either sign) told from the bits in a few instructions, where three float
    /// comparisons take a dozen; every candidate pair's test asks it.
    #[inline]
    pub fn straight_paths(&self) -> bool {
        let g = self.gravity;
        (g.x.to_bits() | g.y.to_bits() | g.z.to_bits()) << 1 == 0
    }

    /// The acceleration body `i` moves under: the world's gravity, none for a static body or
    /// one lying still, less the pull into the wall a sliding body slides on.
    #[inline]
    pub fn gravity_on(&self, i: usize) -> DVec3 {
        if self.straight_paths() || self.is_fixed(i) {
            return DVec3::ZERO;
        }
        self.rest_of(i).acceleration(self.gravity)
    }

    /// How body `i` is held up (see [`Rest`]).
    #[inline]
    pub fn rest_of(&self, i: usize) -> Rest {
        self.rest.get(i).copied().unwrap_or_default()
    }

    /// Body `i` comes to rest at `t` as `rest` says, touching the walls across the axes `on`
    /// (bits, as [`Rest::Sliding`]'s) that gravity pulls it into: its velocity into them is
    /// dropped and its centre set touching them (a rounding off at most, so that bodies resting
    /// side by side on a floor meet level); lying still, all of its motion and spin stop.
    /// Falling again, it keeps its velocity. Its predictions are void.
    pub(crate) fn come_to_rest(&mut self, i: usize, t: f64, rest: Rest, on: u8, walls: (DVec3, DVec3)) {
        let (mut velocity, mut spin) = (without_axes(self.velocity_at(i, t), on), self.angular_velocity_at(i, t));
        if rest == Rest::Still {
            (velocity, spin) = (DVec3::ZERO, DVec3::ZERO);
        }
        self.set_motion_at(i, t, velocity, spin);
        let radius = self.radius(i);
        for axis in (0..3).filter(|&axis| on & (1 << axis) != 0) {
            self.state[i].motion.position[axis] =
                if self.gravity[axis] < 0.0 { walls.0[axis] + radius } else { walls.1[axis] - radius };
        }
        self.set_rest(i, rest);
    }

    /// Body `i` lies still from `t` on where it is (on a body lying still, or a jammed cluster's
    /// member): its motion and spin stop.
    pub(crate) fn lie_still(&mut self, i: usize, t: f64) {
        self.set_motion_at(i, t, DVec3::ZERO, DVec3::ZERO);
        self.set_rest(i, Rest::Still);
    }

    /// Body `i` falls again from `t` on, from where it is, at the velocity it has (woken from
    /// lying still: none).
    pub(crate) fn fall(&mut self, i: usize, t: f64) {
        self.set_motion_at(i, t, self.velocity_at(i, t), self.angular_velocity_at(i, t));
    }

    /// Body `i`'s motion starts afresh at `t` on the same path, held up as it was (a wrap across a
    /// periodic face, a search started afresh): its predictions are void.
    pub(crate) fn restart_at(&mut self, i: usize, t: f64) {
        let rest = self.rest_of(i);
        self.set_motion_at(i, t, self.velocity_at(i, t), self.angular_velocity_at(i, t));
        self.set_rest(i, rest);
    }

    pub(crate) fn set_rest(&mut self, i: usize, rest: Rest) {
        if rest != Rest::Falling && self.rest.len() < self.slots() {
            self.rest.resize(self.slots(), Rest::Falling);
        }
        if let Some(held) = self.rest.get_mut(i) {
            *held = rest;
        }
    }

    /// Body `i`'s straight motion since its last velocity change.
    #[inline]
    pub fn motion(&self, i: usize) -> Motion {
        self.state[i].motion
    }

    /// Velocity of body `i` at its last velocity change (its `since`; at any time without
    /// gravity).
    #[inline]
    pub fn velocity(&self, i: usize) -> DVec3 {
        self.state[i].motion.velocity
    }

    /// Asks for the cache lines of body `i`'s state and tag ahead of their use (a hint: nothing
    /// changes). Not its liveness: an event's check reads the stamp alone (see
    /// [`Self::has_stamp`]).
    #[inline]
    pub fn prefetch(&self, i: usize) {
        prefetch_item(&self.state, i);
        prefetch_item(&self.tags, i);
    }

    /// Mass of body `i` (infinite for a static body).
    #[inline]
    pub fn mass(&self, i: usize) -> f64 {
        self.tags[i].mass
    }

    /// Of live slot `i`, its body's generation; of a removed one, its next body's.
    #[inline]
    pub(crate) fn generation(&self, i: usize) -> u32 {
        self.tags[i].generation
    }

    /// Inverse mass of body `i`, computed rather than stored: 8 bytes per body less, for a
    /// division only where a response needs it.
    #[inline]
    pub fn inverse_mass(&self, i: usize) -> f64 {
        1.0 / self.mass(i)
    }

    /// Radius of sphere `i`; of another shape, its bounding radius about its centre of mass.
    #[inline]
    pub fn radius(&self, i: usize) -> f64 {
        self.state[i].radius
    }

    /// Radius of the sphere about body `i`'s centre that holds the whole body: all the broad
    /// phase needs of its shape.
    #[inline]
    pub fn bounding_radius(&self, i: usize) -> f64 {
        self.state[i].radius
    }

    /// True once the world holds a body that is not a plain sphere: the [`Rigid`] part is kept.
    #[inline]
    pub fn has_rigid(&self) -> bool {
        self.rigid.active
    }

    /// Body `i`'s shape geometry; `None` in a world of plain spheres.
    #[inline]
    pub fn geometry(&self, i: usize) -> Option<&ShapeGeometry> {
        let shape = *self.rigid.shape.get(i)?;
        self.rigid.shapes.get(shape as usize)
    }

    /// True when body `i` is a sphere (of its state's radius), plain or added as a shape.
    #[inline]
    pub fn is_sphere(&self, i: usize) -> bool {
        !self.rigid.active || self.geometry(i).is_none_or(|g| matches!(g.shape(), crate::shape::Shape::Sphere { .. }))
    }

    /// True when bodies `i` and `j` are both spheres: a world of spheres answers with one load.
    #[inline]
    pub fn are_spheres(&self, i: usize, j: usize) -> bool {
        !self.rigid.active || (self.is_sphere(i) && self.is_sphere(j))
    }

    /// True for a static body.
    #[inline]
    pub fn is_fixed(&self, i: usize) -> bool {
        self.rigid.fixed.get(i).copied().unwrap_or(false)
    }

    /// Body `i`'s rotation since its last velocity change (steady in a world of spheres).
    #[inline]
    pub fn spin(&self, i: usize) -> &FreeRotation {
        self.rigid.spin.get(i).unwrap_or_else(|| steady_spin())
    }

    /// Orientation of body `i` (its principal axes to world) at absolute time `t`.
    #[inline]
    pub fn orientation_at(&self, i: usize, t: f64) -> DQuat {
        match self.rigid.spin.get(i) {
            Some(spin) => spin.orientation_at(t - self.state[i].motion.since),
            None => DQuat::IDENTITY,
        }
    }

    /// Angular velocity of body `i` (world frame) at absolute time `t`.
    #[inline]
    pub fn angular_velocity_at(&self, i: usize, t: f64) -> DVec3 {
        match self.rigid.spin.get(i) {
            Some(spin) => spin.angular_velocity_at(t - self.state[i].motion.since),
            None => DVec3::ZERO,
        }
    }

    /// Kinetic energy of body `i`'s spin (none in a world of spheres).
    #[inline]
    pub fn spin_energy(&self, i: usize) -> f64 {
        self.rigid.spin.get(i).map_or(0.0, FreeRotation::kinetic_energy)
    }

    /// Angular momentum of body `i`'s spin about its centre of mass, world frame.
    #[inline]
    pub fn spin_momentum(&self, i: usize) -> DVec3 {
        self.rigid.spin.get(i).map_or(DVec3::ZERO, FreeRotation::angular_momentum)
    }

    /// Body `i`'s motion for the shape narrow phase, under the acceleration it moves under. Its
    /// spin is borrowed: a pair search that ends on the bounding spheres never copies it.
    #[inline]
    pub fn rigid_motion(&self, i: usize) -> RigidMotion<&FreeRotation> {
        let m = self.state[i].motion;
        let acceleration = self.gravity_on(i);
        RigidMotion { position: m.position, since: m.since, velocity: m.velocity, acceleration, spin: self.spin(i) }
    }

    /// Principal moments of inertia of body `i`: its shape's for its mass (a solid ball's in a
    /// world of spheres).
    pub fn principal_inertia(&self, i: usize) -> DVec3 {
        inertia_of(self.geometry(i), self.mass(i), self.radius(i))
    }

    /// Velocity at `t` of body `i`'s material point at `point`: zero for a static body.
    pub fn point_velocity(&self, i: usize, t: f64, point: DVec3) -> DVec3 {
        if self.is_fixed(i) {
            return DVec3::ZERO;
        }
        self.velocity_at(i, t) + self.angular_velocity_at(i, t).cross(point - self.position_at(i, t))
    }

    /// Keeps the [`Rigid`] part from now on: every slot gets an entry (its sphere, steady).
    pub(crate) fn make_rigid(&mut self) {
        if !self.has_rigid() {
            let slots = self.slots();
            self.rigid.shape = (0..slots).map(|i| self.rigid.sphere_shape(self.state[i].radius)).collect();
            self.rigid.spin = vec![steady(); slots];
            self.rigid.spin_start = vec![(DQuat::IDENTITY, DVec3::ZERO); slots];
            self.rigid.fixed = vec![false; slots];
            self.rigid.motion_epoch = vec![0; slots];
            self.rigid.active = true;
        }
    }

    /// Writes a rigid body into slot `i` (appending when `i` is one past the end), like
    /// [`Bodies::put`]; the store keeps its [`Rigid`] part from now on.
    pub(crate) fn put_rigid(&mut self, i: usize, mut body: RigidState, time: f64) {
        self.make_rigid();
        if body.shape == SPHERE {
            body.shape = self.rigid.sphere_shape(body.radius);
        }
        let sphere = Sphere { position: body.position, velocity: body.velocity, radius: body.radius, mass: body.mass };
        self.put_state(i, sphere, time);
        (self.rigid.shape[i], self.rigid.fixed[i]) = (body.shape, body.fixed);
        self.start_spin(i, body.orientation, body.angular_velocity);
        if body.fixed {
            self.rigid.statics_revision += 1;
        }
    }

    /// Moves body `i` to time `t` with new linear and angular velocities, voiding its
    /// predictions: its spin starts again from its orientation at `t`. The first spin in a world
    /// of plain spheres (friction turns them) makes the store keep spins from then on.
    pub(crate) fn set_motion_at(&mut self, i: usize, t: f64, velocity: DVec3, angular_velocity: DVec3) {
        let orientation = self.orientation_at(i, t);
        self.move_to(i, t, velocity);
        if angular_velocity != DVec3::ZERO {
            self.make_rigid();
        }
        if self.has_rigid() {
            self.start_spin(i, orientation, angular_velocity);
        }
    }

    /// Body `i` spins from now (its `since`) from `orientation` with `angular_velocity`.
    pub(crate) fn start_spin(&mut self, i: usize, orientation: DQuat, angular_velocity: DVec3) {
        self.new_motion(i);
        self.rigid.spin[i] = FreeRotation::new(self.principal_inertia(i), orientation, angular_velocity);
        self.rigid.spin_start[i] = (orientation, angular_velocity);
    }

    /// Makes room for `additional` more slots, exactly: a world built from a scene of a million
    /// bodies holds a million slots, not the next power of two.
    pub(crate) fn reserve(&mut self, additional: usize) {
        self.state.reserve_exact(additional);
        self.tags.reserve_exact(additional);
        self.alive.reserve_exact(additional);
    }

    /// Writes `sphere` into slot `i`, appending when `i` is one past the end; a reused slot keeps
    /// the generation its last removal set.
    pub(crate) fn put(&mut self, i: usize, sphere: Sphere, time: f64) {
        self.put_state(i, sphere, time);
        if self.has_rigid() {
            let shape = self.rigid.sphere_shape(sphere.radius);
            (self.rigid.shape[i], self.rigid.spin[i], self.rigid.fixed[i]) = (shape, steady(), false);
            self.rigid.spin_start[i] = (DQuat::IDENTITY, DVec3::ZERO);
        }
    }

    /// Writes the state of slot `i` (appending when `i` is one past the end), the [`Rigid`]
    /// entries too (to be set by the caller).
    fn put_state(&mut self, i: usize, sphere: Sphere, time: f64) {
        self.speed_bound = self.speed_bound.max(speed(sphere.velocity));
        let state = BodyState {
            motion: Motion { position: sphere.position, since: time, velocity: sphere.velocity },
            radius: sphere.radius,
        };
        if i == self.slots() {
            self.state.push(state);
            self.tags.push(BodyTag { mass: sphere.mass, stamp: 0, generation: 0 });
            self.alive.push(true);
            if self.has_rigid() {
                self.rigid.shape.push(SPHERE);
                self.rigid.spin.push(steady());
                self.rigid.spin_start.push((DQuat::IDENTITY, DVec3::ZERO));
                self.rigid.fixed.push(false);
                self.rigid.motion_epoch.push(0);
            }
        } else {
            self.state[i] = state;
            self.tags[i].mass = sphere.mass;
            self.renew(i);
            self.new_motion(i);
            self.alive[i] = true;
            if let Some(crossed) = self.crossings.get_mut(i) {
                *crossed = [0; 3];
            }
            self.set_rest(i, Rest::Falling);
        }
    }

    /// Body `i`'s motion was just written: searches parked on the old one are void.
    #[inline]
    fn new_motion(&mut self, i: usize) {
        if let Some(epoch) = self.rigid.motion_epoch.get_mut(i) {
            *epoch = epoch.wrapping_add(1);
        }
    }

    /// The count of motions body `i` has had (see [`Rigid::motion_epoch`]); 0 in a world of
    /// plain spheres.
    #[inline]
    pub(crate) fn motion_epoch(&self, i: usize) -> u32 {
        self.rigid.motion_epoch.get(i).copied().unwrap_or(0)
    }

    /// Empties slot `i`: voids the body's predictions and moves the slot on to its next
    /// generation, so the body's handle names nothing from now on.
    pub(crate) fn remove(&mut self, i: usize) {
        if self.is_fixed(i) {
            self.rigid.statics_revision += 1;
        }
        self.alive[i] = false;
        self.renew(i);
        self.new_motion(i);
        self.tags[i].generation += 1;
    }

    /// The handle of the body in live slot `i`.
    #[inline]
    pub fn handle(&self, i: usize) -> BodyHandle {
        BodyHandle::new(i as u32, self.generation(i))
    }

    /// True when removed slot `i` may hold another body: its generation has not run out.
    pub(crate) fn is_reusable(&self, i: usize) -> bool {
        self.generation(i) <= BodyHandle::MAX_GENERATION
    }

    /// Moves body `i` to time `t` and gives it a new velocity, voiding its predictions; its spin
    /// goes on unchanged (from its orientation and angular velocity at `t`).
    #[inline]
    pub(crate) fn set_velocity_at(&mut self, i: usize, t: f64, velocity: DVec3) {
        if self.has_rigid() {
            self.set_motion_at(i, t, velocity, self.angular_velocity_at(i, t));
        } else {
            self.move_to(i, t, velocity);
        }
    }

    /// [`Self::set_velocity_at`] at `at.since`, where body `i`'s path moved on to that time is `at`
    /// ([`Motion::moved_on`]'s bits, read by the caller): a body without spin keeps the centre
    /// `at` holds, not worked out again.
    #[inline]
    pub(crate) fn set_velocity_on(&mut self, i: usize, at: Motion, velocity: DVec3) {
        if self.has_rigid() {
            self.set_velocity_at(i, at.since, velocity);
        } else {
            self.move_onto(i, Motion { velocity, ..at });
        }
    }

    /// Starts keeping what stepping overwrites (see [`Bodies::undo`]).
    pub(crate) fn keep_undo(&mut self) {
        self.undo = Some(Vec::new());
    }

    /// Stops keeping what stepping overwrites, and forgets it.
    pub(crate) fn drop_undo(&mut self) {
        self.undo = None;
    }

    /// Takes every body back to its motion when [`Bodies::keep_undo`] was called, with
    /// `speed_bound` the bound then. Stamps move on: predictions made since stay void. A spin the
    /// store started keeping since (friction turned a sphere) is steady again.
    pub(crate) fn undo(&mut self, speed_bound: f64) {
        for o in self.undo.take().unwrap_or_default().into_iter().rev() {
            self.state[o.slot] = o.state;
            self.new_motion(o.slot);
            if let Some((axis, out)) = o.crossed {
                self.crossings[o.slot][axis] -= out;
            }
            self.set_rest(o.slot, o.rest);
            if self.has_rigid() {
                let (spin, start) = o.spin.unwrap_or_else(|| (steady(), (DQuat::IDENTITY, DVec3::ZERO)));
                (self.rigid.spin[o.slot], self.rigid.spin_start[o.slot]) = (spin, start);
            }
        }
        self.speed_bound = speed_bound;
    }

    /// Moves body `i`'s centre to time `t` with a new velocity, voiding its predictions.
    #[inline]
    fn move_to(&mut self, i: usize, t: f64, velocity: DVec3) {
        let motion = self.state[i].motion.moved_on(t, velocity, self.gravity_on(i));
        self.move_onto(i, motion);
    }

    /// Gives body `i` the motion `motion`, from its centre at `motion.since` (see
    /// [`Self::move_to`]), voiding its predictions.
    #[inline]
    fn move_onto(&mut self, i: usize, motion: Motion) {
        if self.undo.is_some() {
            let spin = self.has_rigid().then(|| (self.rigid.spin[i], self.rigid.spin_start[i]));
            let overwritten = Overwritten { slot: i, state: self.state[i], spin, crossed: None, rest: self.rest_of(i) };
            if let Some(log) = &mut self.undo {
                log.push(overwritten);
            }
        }
        self.state[i].motion = motion;
        // A new motion falls: an impact moved the body off whatever held it up.
        self.set_rest(i, Rest::Falling);
        self.renew(i);
        self.new_motion(i);
        self.speed_bound = self.speed_bound.max(speed(motion.velocity));
    }

    /// Sets the speed bound to the speed of the fastest live body, and returns it.
    pub(crate) fn tighten_speed_bound(&mut self) -> f64 {
        self.speed_bound = self.alive_ids().map(|i| speed(self.velocity(i as usize))).fold(0.0, f64::max);
        self.speed_bound
    }

    /// The sphere in slot `i` as of time `t`.
    pub fn sphere_at(&self, i: usize, t: f64) -> Sphere {
        Sphere {
            position: self.position_at(i, t),
            velocity: self.velocity_at(i, t),
            radius: self.radius(i),
            mass: self.mass(i),
        }
    }

    /// Ids of live bodies, ascending.
    pub fn alive_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.alive.iter().enumerate().filter(|(_, &a)| a).map(|(i, _)| i as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_paths_is_gravity_equal_to_zero() {
        let cases = [
            DVec3::ZERO,
            DVec3::new(-0.0, 0.0, -0.0),
            DVec3::new(0.0, 0.0, -9.81),
            DVec3::new(f64::MIN_POSITIVE / 4.0, 0.0, 0.0),
            DVec3::new(0.0, f64::NAN, 0.0),
            DVec3::new(0.0, 0.0, -f64::INFINITY),
        ];
        for gravity in cases {
            let bodies = Bodies::new(gravity, Periodic::default(), Mode::Detect);
            assert_eq!(bodies.straight_paths(), gravity == DVec3::ZERO, "{gravity:?}");
        }
    }

    /// The mark records exactly the stamps bumped after it, by any change that bumps one: a new
    /// velocity, a renewal, a removal.
    #[test]
    fn a_mark_records_the_stamps_bumped_since() {
        let mut bodies = Bodies::new(DVec3::ZERO, Periodic::default(), Mode::Detect);
        let sphere = Sphere { position: DVec3::ZERO, velocity: DVec3::X, radius: 0.5, mass: 1.0 };
        for i in 0..130 {
            bodies.put(i, sphere, 0.0);
        }
        bodies.renew(3);
        bodies.mark_stamps();
        assert!((0..130).all(|i| !bodies.bumped_since_mark(i)));
        bodies.set_velocity_at(64, 0.5, DVec3::Y);
        bodies.renew(129);
        bodies.remove(7);
        let bumped: Vec<usize> = (0..130).filter(|&i| bodies.bumped_since_mark(i)).collect();
        assert_eq!(bumped, [7, 64, 129]);
        bodies.mark_stamps();
        assert!((0..130).all(|i| !bodies.bumped_since_mark(i)));
    }
}
