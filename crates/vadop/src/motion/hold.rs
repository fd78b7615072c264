//! How a moving body is held up under gravity ([`Rest`]): what its acceleration is while it falls,
//! slides along walls or lies still. The store keeps one per body; the rest rules
//! ([`crate::response::rest`]) decide it.

use glam::DVec3;

/// How a moving body is held up under gravity, in simulate mode with restitution below 1 (see
/// [`crate::response::rest`]): it falls (the default), slides along walls that hold it up
/// (gravity's pull into them is gone, its motion along them goes on), or lies still on walls or
/// on bodies lying still (no velocity, no acceleration) until an impact moves it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rest {
    #[default]
    Falling,
    /// On the walls across the axes whose bits are set (bit `k` for axis `k`): a floor, and in a
    /// corner under tilted gravity the side walls it is pressed into.
    Sliding(u8),
    Still,
}

impl Rest {
    /// The acceleration of a moving body held up so under `gravity`.
    #[inline]
    pub fn acceleration(self, gravity: DVec3) -> DVec3 {
        match self {
            Rest::Falling => gravity,
            Rest::Sliding(axes) => without_axes(gravity, axes),
            Rest::Still => DVec3::ZERO,
        }
    }

    /// The axes of the walls a sliding body slides on (bit `k` for axis `k`); none otherwise.
    #[inline]
    pub fn sliding_axes(self) -> u8 {
        match self {
            Rest::Sliding(axes) => axes,
            Rest::Falling | Rest::Still => 0,
        }
    }

    /// Whether a body with `velocity` may be held up so in a world under `gravity`: rest needs
    /// gravity, a sliding body moves only along the walls it slides on (axes as bits 1 to 7),
    /// one lying still not at all.
    pub(crate) fn fits(self, velocity: DVec3, gravity: DVec3) -> bool {
        match self {
            Rest::Falling => true,
            _ if gravity == DVec3::ZERO => false,
            Rest::Sliding(axes) => (1..8).contains(&axes) && without_axes(velocity, axes) == velocity,
            Rest::Still => velocity == DVec3::ZERO,
        }
    }
}

/// `v` with its components along the axes whose bits are set in `axes` dropped.
#[inline]
pub(crate) fn without_axes(mut v: DVec3, axes: u8) -> DVec3 {
    for axis in 0..3 {
        if axes & (1 << axis) != 0 {
            v[axis] = 0.0;
        }
    }
    v
}
