//! Static geometry: the bodies that never move (level geometry: triangle meshes, half-spaces, and
//! any shape fixed in place), bounded once in a hierarchy, and the query that gives a moving
//! body's swept box the static bodies it may reach.
//!
//! It owns a bounding-volume hierarchy (parry's) over the static bodies' boxes, rebuilt only when
//! a static body is added or removed, and the list of half-spaces, which no box bounds. Static
//! bodies need no velocity-aligned volume and no broad-phase entry: they are bounded once here,
//! and a mesh's triangles by the mesh's own hierarchy inside its narrow phase. It never computes
//! contact times: the pipeline asks the narrow phase about each static body a query returns.

use crate::bodies::Bodies;
use glam::DVec3;
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};

/// The static bodies of a world, bounded.
#[derive(Debug, Default)]
pub(crate) struct StaticGeometry {
    /// The body store's revision of its static bodies this was built from.
    revision: u64,
    /// Bounded static bodies: the hierarchy's leaf k is body `bounded[k]`.
    bvh: Option<Bvh>,
    bounded: Vec<u32>,
    /// Half-spaces: a candidate for every body.
    unbounded: Vec<u32>,
}

impl StaticGeometry {
    /// Rebuilds the hierarchy when the store's static bodies changed since the last build.
    pub(crate) fn update(&mut self, bodies: &Bodies) {
        if !self.is_stale(bodies) {
            return;
        }
        self.revision = bodies.rigid.statics_revision;
        self.bounded.clear();
        self.unbounded.clear();
        let mut boxes = Vec::new();
        for i in bodies.alive_ids().filter(|&i| bodies.is_fixed(i as usize)) {
            let Some(geometry) = bodies.geometry(i as usize) else { continue };
            let pose = bodies.rigid_motion(i as usize);
            let pose = geometry.pose_of_shape(pose.position, pose.orientation_at(pose.since));
            let aabb = geometry.parry_shape().compute_aabb(&pose);
            if aabb.mins.is_finite() && aabb.maxs.is_finite() {
                boxes.push(aabb);
                self.bounded.push(i);
            } else {
                self.unbounded.push(i);
            }
        }
        self.bvh = (!boxes.is_empty()).then(|| Bvh::from_leaves(BvhBuildStrategy::default(), &boxes));
    }

    /// True when `bodies` added or removed a static body since the last [`Self::update`].
    #[inline]
    pub(crate) fn is_stale(&self, bodies: &Bodies) -> bool {
        bodies.rigid.statics_revision != self.revision
    }

    /// True when the world has no static body.
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.bounded.is_empty() && self.unbounded.is_empty()
    }

    /// Calls `f` with every static body whose box meets `[low, high]`, and every half-space.
    pub(crate) fn for_each_near(&self, low: DVec3, high: DVec3, mut f: impl FnMut(u32)) {
        if let Some(bvh) = &self.bvh {
            let query = Aabb::new(low, high);
            for leaf in bvh.intersect_aabb(&query) {
                f(self.bounded[leaf as usize]);
            }
        }
        for &i in &self.unbounded {
            f(i);
        }
    }
}
