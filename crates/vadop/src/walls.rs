//! The box the bodies live in, its six walls and its periodic axes: what every stage says when
//! it names where a body is allowed to be, what it bounced off or which face it crossed. An axis
//! may be walled (bodies bounce off its two walls) or periodic (a body leaving through one face
//! comes back through the other, and bodies meet across the faces through their nearest image).
//! It owns the box's validation, the walls' names and normals and the nearest-image rule; it
//! never computes a contact time or moves a body.

use crate::error::{check_length, check_vector, Result, VadopError};
use glam::DVec3;

/// The axis-aligned box the bodies live in.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct BoxBounds {
    pub min: DVec3,
    pub max: DVec3,
    /// Per axis x, y, z: periodic (no walls; see [`BoxBounds::with_periodic`]) instead of walled.
    #[serde(default, skip_serializing_if = "all_walled")]
    pub periodic: [bool; 3],
}

fn all_walled(periodic: &[bool; 3]) -> bool {
    !periodic.contains(&true)
}

impl BoxBounds {
    /// The box widened by the rounding error a body may end a frame outside it (1e-9 of its
    /// longest side, plus a few ulps of its corners): a saved or moved body that far out was put
    /// there by stepping, one further out by a damaged state.
    pub(crate) fn with_rounding_slack(&self) -> BoxBounds {
        let slack = 1e-9 * (self.max - self.min).max_element()
            + 4.0 * f64::EPSILON * self.min.abs().max(self.max.abs()).max_element();
        BoxBounds { min: self.min - slack, max: self.max + slack, periodic: self.periodic }
    }

    /// A box, checked to have finite corners and sides of at least [`crate::error::MIN_LENGTH`].
    pub fn new(min: DVec3, max: DVec3) -> Result<BoxBounds> {
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(VadopError::BadBox { min: min.to_array(), max: max.to_array() });
        }
        check_vector("box corner", min)?;
        check_vector("box corner", max)?;
        check_length("box side", (max - min).min_element())?;
        Ok(BoxBounds { min, max, periodic: [false; 3] })
    }
    /// The cube `[0, side]^3`.
    pub fn cube(side: f64) -> Result<BoxBounds> {
        BoxBounds::new(DVec3::ZERO, DVec3::splat(side))
    }

    /// The same box with the axes `periodic` (x, y, z) periodic: a body crossing one of their
    /// faces comes back through the opposite one, with its crossings counted
    /// ([`crate::World::crossings`]), and bodies meet across them through their nearest images.
    /// A periodic side must be at least [`MIN_PERIODIC_DIAMETERS`] of the largest body's
    /// bounding diameter, so two bodies meet through one image at a time.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::BoxBounds;
    /// // Periodic in x and y, a floor and a ceiling in z.
    /// let slab = BoxBounds::cube(10.0).unwrap().with_periodic([true, true, false]);
    /// assert!(slab.is_periodic());
    /// // Centres 9 apart in x are 1 apart through the faces.
    /// assert_eq!(slab.nearest_image(DVec3::new(9.0, 0.0, 9.0)), DVec3::new(-1.0, 0.0, 9.0));
    /// ```
    pub fn with_periodic(self, periodic: [bool; 3]) -> BoxBounds {
        BoxBounds { periodic, ..self }
    }

    /// True when any axis is periodic.
    #[inline]
    pub fn is_periodic(&self) -> bool {
        self.periodic.contains(&true)
    }

    /// The box's side lengths.
    #[inline]
    pub fn side(&self) -> DVec3 {
        self.max - self.min
    }

    /// The periodic axes' part of the box, for what bodies need of it (see [`Periodic`]).
    #[inline]
    pub fn periodic_part(&self) -> Periodic {
        Periodic { axes: self.periodic, min: self.min, side: self.side() }
    }

    /// `offset` (one centre minus another) through the nearest image on every periodic axis.
    #[inline]
    pub fn nearest_image(&self, offset: DVec3) -> DVec3 {
        self.periodic_part().nearest(offset)
    }

    /// The box's walls as corners, at infinity on the periodic axes (which have none): what the
    /// wall contacts are predicted against.
    #[inline]
    pub(crate) fn walls(&self) -> (DVec3, DVec3) {
        self.corners_where(false)
    }

    /// The periodic faces as corners, at infinity on the walled axes: what a centre's crossings
    /// are predicted against.
    #[inline]
    pub(crate) fn faces(&self) -> (DVec3, DVec3) {
        self.corners_where(true)
    }

    /// The box's corners on the axes whose periodicity is `periodic`, at infinity on the others.
    #[inline]
    fn corners_where(&self, periodic: bool) -> (DVec3, DVec3) {
        let pick = |a: usize, at: f64, none: f64| if self.periodic[a] == periodic { at } else { none };
        let min = DVec3::from_array(std::array::from_fn(|a| pick(a, self.min[a], f64::NEG_INFINITY)));
        let max = DVec3::from_array(std::array::from_fn(|a| pick(a, self.max[a], f64::INFINITY)));
        (min, max)
    }

    /// True when a body of `radius` at `position` lies inside the box: between the walls of a
    /// walled axis, its centre within the faces of a periodic one (the body may reach across).
    pub fn contains(&self, position: DVec3, radius: f64) -> bool {
        (0..3).all(|a| {
            let reach = if self.periodic[a] { 0.0 } else { radius };
            position[a] - reach >= self.min[a] && position[a] + reach <= self.max[a]
        })
    }
}

/// A periodic side holds at least this many of the largest bounding diameter: two bodies then
/// meet through one image at a time, and a body's path in a window (see
/// [`crate::broad_phase::proxy`]) stays short of a third of the side.
pub const MIN_PERIODIC_DIAMETERS: f64 = 8.0;

/// What the bodies need of the box's periodic axes: which they are, and the box's corner and
/// sides, to take an offset between two centres through its nearest image.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Periodic {
    pub axes: [bool; 3],
    pub min: DVec3,
    pub side: DVec3,
}

impl Periodic {
    /// True when any axis is periodic.
    #[inline]
    pub fn any(&self) -> bool {
        self.axes.contains(&true)
    }

    /// `offset` through the nearest image on every periodic axis: each such component brought
    /// within half a side by whole sides.
    #[inline]
    pub fn nearest(&self, offset: DVec3) -> DVec3 {
        offset + self.shift(offset)
    }

    /// The images of something spanning `[low, high]` that reach across the faces: for every
    /// non-empty combination of the periodic axes on which the span reaches a face, the whole
    /// sides that take it to the opposite side (at most one face per axis: a span shorter than
    /// half a side never reaches both). At most seven.
    pub(crate) fn image_shifts(&self, low: DVec3, high: DVec3) -> impl Iterator<Item = DVec3> {
        let shifts: [f64; 3] = std::array::from_fn(|a| match self.axes[a] {
            true if low[a] <= self.min[a] => self.side[a],
            true if high[a] >= self.min[a] + self.side[a] => -self.side[a],
            _ => 0.0,
        });
        (1..8usize).filter(move |mask| (0..3).all(|a| mask & (1 << a) == 0 || shifts[a] != 0.0)).map(move |mask| {
            DVec3::from_array(std::array::from_fn(|a| if mask & (1 << a) != 0 { shifts[a] } else { 0.0 }))
        })
    }

    /// The whole sides that take `offset` to its nearest image (zero on walled axes).
    #[inline]
    pub fn shift(&self, offset: DVec3) -> DVec3 {
        DVec3::from_array(std::array::from_fn(|a| {
            if self.axes[a] {
                -self.side[a] * round_within_half_side(offset[a] / self.side[a])
            } else {
                0.0
            }
        }))
    }
}

/// `x.round()`, its common case answered without the library's call: an offset within half a
/// side (most pairs, neighbours in a box of at least [`MIN_PERIODIC_DIAMETERS`]) rounds to a
/// zero of its own sign, as `round` gives it (the sign reaches the shift's zero, and through it
/// an offset of zero's sign).
#[inline(always)]
fn round_within_half_side(x: f64) -> f64 {
    if x.abs() < 0.5 {
        0.0f64.copysign(x)
    } else {
        x.round()
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

#[cfg(test)]
mod tests {
    use super::round_within_half_side;

    #[test]
    fn round_within_half_side_is_round_to_the_bit() {
        let below_half = 0.5f64.next_down();
        for x in [0.0, -0.0, 1e-300, -1e-300, 0.25, -0.25, below_half, -below_half, 0.5, -0.5, 0.75, -1.5, 2.5, 1e300] {
            assert_eq!(round_within_half_side(x).to_bits(), x.round().to_bits(), "{x}");
        }
        assert!(round_within_half_side(f64::NAN).is_nan());
    }
}
