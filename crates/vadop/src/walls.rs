//! The box the bodies live in and its six walls: what every stage says when it names where a
//! body is allowed to be or what it bounced off. It owns the box's validation and the walls'
//! names and normals; it never computes a contact time or moves a body.

use crate::error::{check_length, check_vector, Result, VadopError};
use glam::DVec3;

/// The axis-aligned box the bodies live in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BoxBounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl BoxBounds {
    /// A box, checked to have finite corners and sides of at least [`crate::error::MIN_LENGTH`].
    pub fn new(min: DVec3, max: DVec3) -> Result<BoxBounds> {
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(VadopError::BadBox { min: min.to_array(), max: max.to_array() });
        }
        check_vector("box corner", min)?;
        check_vector("box corner", max)?;
        check_length("box side", (max - min).min_element())?;
        Ok(BoxBounds { min, max })
    }
    /// The cube `[0, side]^3`.
    pub fn cube(side: f64) -> Result<BoxBounds> {
        BoxBounds::new(DVec3::ZERO, DVec3::splat(side))
    }
    pub(crate) fn contains(&self, position: DVec3, radius: f64) -> bool {
        (position - radius).cmpge(self.min).all() && (position + radius).cmple(self.max).all()
    }
}

/// A side of the axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub enum Wall {
    MinX,
    MaxX,
    MinY,
    MaxY,
    MinZ,
    MaxZ,
}

impl Wall {
    /// Every wall, in id order.
    pub const ALL: [Wall; 6] = [Wall::MinX, Wall::MaxX, Wall::MinY, Wall::MaxY, Wall::MinZ, Wall::MaxZ];

    /// The coordinate axis (0, 1, 2) this wall is orthogonal to.
    pub fn axis(self) -> usize {
        self as usize / 2
    }
    /// True for the wall at the box's maximum on its axis.
    pub fn is_max(self) -> bool {
        self as usize % 2 == 1
    }
    /// The wall on `axis` at the maximum side when `is_max`.
    pub fn new(axis: usize, is_max: bool) -> Wall {
        Wall::ALL[axis * 2 + is_max as usize]
    }
    /// Unit normal pointing out of the box.
    pub fn outward_normal(self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis()] = if self.is_max() { 1.0 } else { -1.0 };
        n
    }
    /// The wall's name as written in files: `min-x`, `max-x`, ...
    pub fn name(self) -> &'static str {
        ["min-x", "max-x", "min-y", "max-y", "min-z", "max-z"][self as usize]
    }
}

impl std::fmt::Display for Wall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
