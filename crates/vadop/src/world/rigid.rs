//! Bodies of any shape: the world's shapes, and rigid bodies that move, spin and collide, or stay
//! fixed as level geometry.
//!
//! It owns the users' description of a rigid body ([`Body`]) and its conversion to the store's
//! (the centre of mass and the principal axes, see [`crate::shape`]), and validates both before
//! anything changes. It never decides contacts or responses.

use super::{Method, World};
use crate::bodies::{RigidState, SPHERE};
use crate::error::{check_magnitude, check_vector, Result, VadopError};
use crate::handle::BodyHandle;
use crate::numeric::unit_quaternion;
use crate::shape::{Shape, ShapeGeometry};
use glam::{DQuat, DVec3};
use parry3d_f64::math::Pose;

/// Names one of a world's shapes, as [`World::add_shape`] gave it: 0, 1, 2 ... in the order they
/// were added.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct ShapeId(pub(crate) u32);

impl ShapeId {
    /// The shape's place among the world's shapes, in the order they were added.
    pub fn index(self) -> u32 {
        self.0
    }
}

/// What a body looks like: a ball of a radius (as [`crate::Sphere`]s are), or one of the world's
/// shapes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum BodyShape {
    Sphere { radius: f64 },
    Shape(ShapeId),
}

/// A rigid body as users describe it: its shape placed in the world, its motion and its mass.
///
/// `position` and `orientation` place the shape's own frame (the frame its sizes are given in,
/// see [`crate::shape`]); the body moves about its centre of mass, which the world finds from the
/// shape. Bodies spin freely between contacts, exactly: an asymmetric body tumbles, keeping its
/// angular momentum and energy.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::{Body, BodyShape, BoxBounds, Mode, World, WorldConfig};
/// let config = WorldConfig { mode: Mode::Detect, ..WorldConfig::default() };
/// let mut world = World::new(BoxBounds::cube(10.0)?, config)?;
/// let brick = world.add_shape(Shape::Cuboid { half_extents: DVec3::new(1.0, 0.25, 0.25) })?;
/// let spinning = Body {
///     shape: BodyShape::Shape(brick),
///     position: DVec3::new(2.0, 5.0, 5.0),
///     orientation: DQuat::IDENTITY,
///     velocity: DVec3::new(6.0, 0.0, 0.0),
///     angular_velocity: DVec3::new(0.0, 0.0, 20.0),
///     mass: 1.0,
/// };
/// let a = world.add_body(spinning)?;
/// let b = world.add_body(Body { position: DVec3::new(8.0, 5.0, 5.0), velocity: DVec3::ZERO, angular_velocity: DVec3::ZERO, ..spinning })?;
/// let contacts = world.step(1.0)?;
/// assert!(contacts.iter().any(|c| c.body == a && c.touched == vadop::Touched::Body(b)));
/// // The brick still spins about z, at the same rate (a principal axis: a steady spin).
/// assert!((world.body(a)?.angular_velocity.z - 20.0).abs() < 1e-9);
/// # Ok::<(), vadop::VadopError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Body {
    pub shape: BodyShape,
    /// Where the shape's own origin is.
    pub position: DVec3,
    /// Rotates the shape's own frame to the world's: any finite non-zero quaternion, normalised
    /// here whatever its length (1e300 or subnormal too).
    pub orientation: DQuat,
    /// Velocity of the centre of mass.
    pub velocity: DVec3,
    /// Angular velocity in world axes, radians per unit of time.
    pub angular_velocity: DVec3,
    /// Mass, > 0; infinite for a static body read back.
    pub mass: f64,
}

impl World {
    /// Adds a shape that bodies can then take; returns its id. Validates it (sizes, hulls, meshes:
    /// see [`Shape::geometry`]) and derives its geometry once, however many bodies share it.
    pub fn add_shape(&mut self, shape: Shape) -> Result<ShapeId> {
        let geometry = shape.geometry()?;
        let shapes = &mut self.bodies.rigid.shapes;
        shapes.push(geometry);
        self.user_shapes.push((shapes.len() - 1) as u32);
        Ok(ShapeId((self.user_shapes.len() - 1) as u32))
    }

    /// The shapes added so far, in the order they were added.
    pub fn shapes(&self) -> impl Iterator<Item = (ShapeId, &ShapeGeometry)> + '_ {
        self.user_shapes.iter().enumerate().map(|(k, &s)| (ShapeId(k as u32), &self.bodies.rigid.shapes[s as usize]))
    }

    /// The geometry of shape `id`: its volume, inertia, bounding radius and parry shape.
    pub fn shape(&self, id: ShapeId) -> Result<&ShapeGeometry> {
        self.user_geometry(id)
    }

    /// Adds a moving rigid body; returns its handle. Fails, changing nothing, on a bad value, a
    /// shape that is level geometry, or a body reaching out of the box.
    pub fn add_body(&mut self, body: Body) -> Result<BodyHandle> {
        let state = self.rigid_state(&body, false)?;
        self.place(state)
    }

    /// Adds many rigid bodies at once, all or none; an error names the first bad one by its index
    /// in `bodies`.
    pub fn add_bodies(&mut self, bodies: &[Body]) -> Result<Vec<BodyHandle>> {
        let states: Vec<RigidState> = bodies
            .iter()
            .enumerate()
            .map(|(index, b)| self.rigid_state(b, false).map_err(|e| VadopError::InBody { index, source: Box::new(e) }))
            .collect::<Result<_>>()?;
        self.check_room(states.len())?;
        states.into_iter().map(|state| self.place(state)).collect()
    }

    /// Adds a static body: level geometry (a triangle mesh, a half-space) or any shape fixed in
    /// place. It never moves, has infinite mass, and may reach beyond the box. Moving bodies
    /// touch it as they touch the walls: in detect mode too, they bounce off it.
    pub fn add_static(&mut self, shape: ShapeId, position: DVec3, orientation: DQuat) -> Result<BodyHandle> {
        let body = Body {
            shape: BodyShape::Shape(shape),
            position,
            orientation,
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            mass: f64::INFINITY,
        };
        let state = self.rigid_state(&body, true)?;
        self.place(state)
    }

    /// The body `handle` now, of any shape (a static body's mass is infinite).
    pub fn body(&self, handle: BodyHandle) -> Result<Body> {
        let i = self.live_slot(handle)?;
        Ok(self.body_at(i))
    }

    /// Live bodies of every shape with their handles, in ascending order of handle.
    pub fn bodies(&self) -> impl Iterator<Item = (BodyHandle, Body)> + '_ {
        self.bodies.alive_ids().map(|i| (self.bodies.handle(i as usize), self.body_at(i as usize)))
    }

    /// Removes a body of any shape and returns it as it was now.
    pub fn remove_body(&mut self, handle: BodyHandle) -> Result<Body> {
        let body = self.body(handle)?;
        self.remove_slot(handle)?;
        Ok(body)
    }

    /// Sets a moving body's velocity and angular velocity (between frames).
    pub fn set_motion(&mut self, handle: BodyHandle, velocity: DVec3, angular_velocity: DVec3) -> Result<()> {
        let i = self.moving_slot(handle)?;
        check_vector("velocity", velocity)?;
        check_vector("angular velocity", angular_velocity)?;
        self.release(i);
        self.bodies.set_motion_at(i, self.time, velocity, angular_velocity);
        self.reenter(i);
        Ok(())
    }

    /// Sets the velocities and angular velocities of the moving bodies `handles` (between
    /// frames), all or none.
    pub fn set_motions(
        &mut self,
        handles: &[BodyHandle],
        velocities: &[DVec3],
        angular_velocities: &[DVec3],
    ) -> Result<()> {
        for other in [velocities.len(), angular_velocities.len()] {
            if other != handles.len() {
                return Err(VadopError::LengthMismatch { handles: handles.len(), velocities: other });
            }
        }
        for (index, ((&handle, &velocity), &angular_velocity)) in
            handles.iter().zip(velocities).zip(angular_velocities).enumerate()
        {
            let checked = self
                .moving_slot(handle)
                .and_then(|_| check_vector("velocity", velocity))
                .and_then(|()| check_vector("angular velocity", angular_velocity));
            checked.map_err(|e| VadopError::InBody { index, source: Box::new(e) })?;
        }
        for ((&handle, &velocity), &angular_velocity) in handles.iter().zip(velocities).zip(angular_velocities) {
            self.set_motion(handle, velocity, angular_velocity)?;
        }
        Ok(())
    }

    /// Total angular momentum about the origin: of the centres' motion and of the spins.
    pub fn angular_momentum(&self) -> DVec3 {
        let t = self.time;
        self.moving_ids()
            .map(|i| {
                let p = self.bodies.position_at(i, t).cross(self.bodies.mass(i) * self.bodies.velocity_at(i, t));
                p + self.bodies.spin_momentum(i)
            })
            .sum()
    }

    /// Slots of the live bodies that move (static ones excluded).
    pub(crate) fn moving_ids(&self) -> impl Iterator<Item = usize> + '_ {
        self.bodies.alive_ids().map(|i| i as usize).filter(|&i| !self.bodies.is_fixed(i))
    }

    /// A shape the user added, and its index in the store's table (which also holds the shapes
    /// the store made for plain spheres).
    fn user_geometry(&self, id: ShapeId) -> Result<&ShapeGeometry> {
        let slot = *self.user_shapes.get(id.0 as usize).ok_or(VadopError::NoSuchShape(id.0))?;
        Ok(&self.bodies.rigid.shapes[slot as usize])
    }

    /// Refuses a body this world cannot step exactly yet: a static body in a periodic box (level
    /// geometry is not periodic). Asked of every body added and of every body loaded.
    pub(super) fn check_supported(&self, fixed: bool) -> Result<()> {
        if self.bounds.is_periodic() && fixed {
            return Err(VadopError::PeriodicUnsupported("a static body"));
        }
        Ok(())
    }

    /// The store's form of `body`, validated: the centre of mass and principal axes from the
    /// shape's frame.
    fn rigid_state(&self, body: &Body, fixed: bool) -> Result<RigidState> {
        self.check_supported(fixed)?;
        check_vector("position", body.position)?;
        check_vector("velocity", body.velocity)?;
        check_vector("angular velocity", body.angular_velocity)?;
        let q = body.orientation;
        let orientation = unit_quaternion(q).ok_or(VadopError::BadOrientation(q.to_array()))?;
        if !fixed {
            if !(body.mass.is_finite() && body.mass > 0.0) {
                return Err(VadopError::BadMass(body.mass));
            }
            check_magnitude("mass", body.mass)?;
            check_magnitude("inverse mass", 1.0 / body.mass)?;
            if self.config.method.resolve() == Method::Discrete && !matches!(body.shape, BodyShape::Sphere { .. }) {
                return Err(VadopError::DiscreteSpheresOnly);
            }
        } else if self.config.method.resolve() == Method::Discrete {
            return Err(VadopError::DiscreteSpheresOnly);
        }
        let (geometry, shape) = match body.shape {
            BodyShape::Sphere { radius } => {
                self.check_sphere(&crate::Sphere {
                    position: body.position,
                    velocity: body.velocity,
                    radius,
                    mass: 1.0,
                })?;
                (None, None)
            }
            BodyShape::Shape(id) => {
                let geometry = self.user_geometry(id)?;
                if geometry.is_static_only() && !fixed {
                    return Err(VadopError::StaticOnlyShape(id.0));
                }
                (Some(geometry), Some(self.user_shapes[id.0 as usize]))
            }
        };
        let (position, principal, radius) = match geometry {
            None => (body.position, orientation, radius_of(body.shape)),
            Some(g) => {
                let centre = Pose::from_parts(body.position, orientation) * g.body_from_shape().inverse();
                (centre.translation, centre.rotation, g.bounding_radius().unwrap_or(0.0))
            }
        };
        if let (Some(g), false) = (geometry, fixed) {
            self.check_inside(g, position, principal, body.position)?;
        }
        Ok(RigidState {
            shape: shape.unwrap_or(SPHERE),
            radius,
            position,
            orientation: principal,
            velocity: if fixed { DVec3::ZERO } else { body.velocity },
            angular_velocity: if fixed { DVec3::ZERO } else { body.angular_velocity },
            mass: if fixed { f64::INFINITY } else { body.mass },
            fixed,
        })
    }

    /// Fails when a body of `geometry` with its centre of mass at `centre` and principal axes
    /// `principal` reaches out of the box (`position` names it in the error).
    pub(crate) fn check_inside(
        &self,
        geometry: &ShapeGeometry,
        centre: DVec3,
        principal: DQuat,
        position: DVec3,
    ) -> Result<()> {
        let aabb = geometry.parry_shape().compute_aabb(&geometry.pose_of_shape(centre, principal));
        // On a periodic axis the shape may reach across a face, its centre of mass inside and its
        // bounding sphere short enough for the side; on a walled one it stays between the walls.
        if self.bounds.is_periodic() {
            self.check_periodic_sides(geometry.bounding_radius().unwrap_or(f64::INFINITY))?;
        }
        let (walls_min, walls_max) = self.bounds.walls();
        let (faces_min, faces_max) = self.bounds.faces();
        let inside = aabb.mins.cmpge(walls_min).all()
            && aabb.maxs.cmple(walls_max).all()
            && centre.cmpge(faces_min).all()
            && centre.cmple(faces_max).all();
        if !inside {
            return Err(VadopError::ShapeOutsideBox {
                position: position.to_array(),
                low: aabb.mins.to_array(),
                high: aabb.maxs.to_array(),
            });
        }
        Ok(())
    }

    /// Writes a validated body into the lowest free slot.
    fn place(&mut self, state: RigidState) -> Result<BodyHandle> {
        self.place_with(|bodies, slot, time| bodies.put_rigid(slot, state, time))
    }

    /// Body `i` as users describe it.
    fn body_at(&self, i: usize) -> Body {
        let (b, t) = (&self.bodies, self.time);
        let (centre, principal) = (b.position_at(i, t), b.orientation_at(i, t));
        // A store shape the user added (the table's indices of user shapes ascend), or a plain
        // sphere's.
        let user = b.rigid.shape.get(i).and_then(|&s| Some((s, self.user_shapes.binary_search(&s).ok()?)));
        let (shape, position, orientation) = match user {
            None => (BodyShape::Sphere { radius: b.radius(i) }, centre, principal),
            Some((slot, id)) => {
                let pose = b.rigid.shapes[slot as usize].pose_of_shape(centre, principal);
                (BodyShape::Shape(ShapeId(id as u32)), pose.translation, pose.rotation)
            }
        };
        Body {
            shape,
            position,
            orientation,
            velocity: b.velocity_at(i, t),
            angular_velocity: b.angular_velocity_at(i, t),
            mass: b.mass(i),
        }
    }

    /// The slot of a live body that moves.
    pub(crate) fn moving_slot(&self, handle: BodyHandle) -> Result<usize> {
        let i = self.live_slot(handle)?;
        if self.bodies.is_fixed(i) {
            return Err(VadopError::StaticBody(handle));
        }
        Ok(i)
    }

    /// Slot `i` changed velocity between frames: the engine re-enters it (or places it at the
    /// next step when it was added since the last).
    pub(crate) fn reenter(&mut self, i: usize) {
        let slot = i as u32;
        if !self.unplaced.contains(&slot) {
            let physics = self.physics();
            let (bodies, time, stats) = (&self.bodies, self.time, &mut self.stats);
            if let Some(engine) = &mut self.engine {
                engine.reenter(slot, bodies, &physics, time, stats);
            }
        }
    }
}

/// The radius of a sphere body.
fn radius_of(shape: BodyShape) -> f64 {
    match shape {
        BodyShape::Sphere { radius } => radius,
        BodyShape::Shape(_) => 0.0,
    }
}
