//! Body handles: how users name a body of a [`World`](crate::World).
//!
//! A handle is the body's slot in the store plus the slot's *generation*: removing a body frees
//! its slot for the next body added (lowest slot first) and bumps the slot's generation, so the
//! removed body's handle never names the newcomer. A stale handle is refused with
//! [`VadopError::StaleHandle`](crate::VadopError::StaleHandle), one the world never gave out with
//! [`VadopError::NoSuchBody`](crate::VadopError::NoSuchBody). The engine itself works with slot
//! indices only; handles exist at the API's edge.

use std::fmt;

/// Names one body of a [`World`](crate::World): its slot `index` and the slot's `generation`.
///
/// Handles are ordered by index, then generation; at any instant a world holds one body per
/// index, so its live handles sort like its slots. [`BodyHandle::to_bits`] packs a handle into
/// one integer, `generation << 32 | index`: while a slot has never been reused (generation 0)
/// that is the slot index itself. Generations stay at or below [`BodyHandle::MAX_GENERATION`], so
/// the bits fit a signed 64-bit integer too (the Python package's int64 arrays, JSON readers).
///
/// A removed body's handle is refused, even once its slot holds another body:
///
/// ```
/// use glam::DVec3;
/// use vadop::{BodyHandle, BoxBounds, Sphere, VadopError, World, WorldConfig};
/// let mut world = World::new(BoxBounds::cube(10.0)?, WorldConfig::default())?;
/// let ball = Sphere { position: DVec3::splat(5.0), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 };
/// let first = world.add_sphere(ball)?;
/// world.remove_sphere(first)?;
/// let second = world.add_sphere(ball)?;
/// // The second body reuses the slot, under a new generation...
/// assert_eq!((first.index(), first.generation()), (0, 0));
/// assert_eq!((second.index(), second.generation()), (0, 1));
/// // ...so the first body's handle names nothing, and changes nothing.
/// assert_eq!(world.sphere(first), Err(VadopError::StaleHandle { handle: first, current: Some(second) }));
/// assert!(world.set_velocity(first, DVec3::X).is_err());
/// assert_eq!(world.sphere(second)?.velocity, DVec3::ZERO);
/// // As one integer (the form the CLI and Python use): generation << 32 | index.
/// assert_eq!((first.to_bits(), second.to_bits()), (0, 1 << 32));
/// assert_eq!(BodyHandle::from_bits(second.to_bits()), second);
/// assert_eq!((first.to_string(), second.to_string()), ("0".to_string(), "0v1".to_string()));
/// # Ok::<(), VadopError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct BodyHandle {
    // Declared index first: the derived order is (index, generation).
    index: u32,
    generation: u32,
}

impl BodyHandle {
    /// The highest generation a slot reaches. Removing the body of this generation retires its
    /// slot instead of wrapping around to a generation an old handle still holds; the bound
    /// keeps [`BodyHandle::to_bits`] below 2^63.
    pub const MAX_GENERATION: u32 = i32::MAX as u32;

    pub(crate) const fn new(index: u32, generation: u32) -> BodyHandle {
        BodyHandle { index, generation }
    }

    /// The body's slot: its position in the world's slot order, reused after a removal.
    pub const fn index(self) -> u32 {
        self.index
    }

    /// How many bodies held the slot before this one.
    pub const fn generation(self) -> u32 {
        self.generation
    }

    /// The handle as one integer: `generation << 32 | index`.
    pub const fn to_bits(self) -> u64 {
        (self.generation as u64) << 32 | self.index as u64
    }

    /// The handle whose [`BodyHandle::to_bits`] is `bits`. Any integer is a handle; one a world
    /// never gave out is refused by that world with
    /// [`VadopError::NoSuchBody`](crate::VadopError::NoSuchBody).
    pub const fn from_bits(bits: u64) -> BodyHandle {
        BodyHandle { index: bits as u32, generation: (bits >> 32) as u32 }
    }
}

/// The index alone while the slot has never been reused (`7`), else index and generation
/// (`7v2`): a world that never removes a body names its bodies 0, 1, 2, ...
impl fmt::Display for BodyHandle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.generation {
            0 => write!(f, "{}", self.index),
            generation => write!(f, "{}v{generation}", self.index),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_round_trip_and_order_follows_index_then_generation() {
        for handle in
            [BodyHandle::new(0, 0), BodyHandle::new(7, 3), BodyHandle::new(u32::MAX, BodyHandle::MAX_GENERATION)]
        {
            assert_eq!(BodyHandle::from_bits(handle.to_bits()), handle);
            assert!(i64::try_from(handle.to_bits()).is_ok());
        }
        assert_eq!(BodyHandle::from_bits(u64::MAX), BodyHandle::new(u32::MAX, u32::MAX));
        assert!(BodyHandle::new(1, 9) < BodyHandle::new(2, 0));
        assert!(BodyHandle::new(2, 0) < BodyHandle::new(2, 1));
    }
}
