//! Scale-free numerics shared by every stage: exact powers of two that bring any length or speed
//! near 1 before a square is taken, and normalisation that is exact for tiny and huge vectors
//! and quaternions alike. It owns no state and knows no body, shape or contact.

use glam::{DQuat, DVec3};

/// The exponent e with `2^e <= |x| < 2^(e+1)`, clamped to the normal range `[-1022, 1022]`.
#[inline]
pub(crate) fn exponent(x: f64) -> i32 {
    let biased = ((x.to_bits() >> 52) & 0x7ff) as i32;
    (biased - 1023).clamp(-1022, 1022)
}

/// `2^k` for k in the normal range.
#[inline]
pub(crate) const fn power_of_two(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// `x * 2^k` for any k in `[-2044, 2044]`, exact unless the result leaves the normal range.
#[inline]
pub(crate) fn scale_by_power_of_two(x: f64, k: i32) -> f64 {
    x * power_of_two(k / 2) * power_of_two(k - k / 2)
}

/// The exact power of two `2^-e` with `2^e <= |x| < 2^(e+1)` (clamped to the normal range), so
/// that `x * unit_scale(x)` lies in `[1, 2)` without rounding.
///
/// ```
/// use vadop::numeric::unit_scale;
/// assert_eq!(unit_scale(3.0), 0.5);
/// assert!(unit_scale(1e-300) * 1e-300 >= 1.0);
/// ```
#[inline]
pub fn unit_scale(x: f64) -> f64 {
    power_of_two(-exponent(x))
}

/// `v` scaled to unit length, exactly scale-free: tiny and huge vectors normalise like ordinary
/// ones. `None` for the zero vector (or a non-finite one).
#[inline]
pub fn direction(v: DVec3) -> Option<DVec3> {
    (v * unit_scale(v.abs().max_element())).try_normalize()
}

/// The rotation `q` stands for: `q` scaled to unit length, exactly scale-free as [`direction`]
/// (a quaternion times a power of two normalises to the same bits, at 1e300 or subnormal too).
/// `None` for the zero quaternion or a non-finite one.
///
/// ```
/// use glam::DQuat;
/// use vadop::numeric::unit_quaternion;
/// let huge = DQuat::from_xyzw(0.0, 0.0, 0.0, 1e155);
/// assert_eq!(unit_quaternion(huge), Some(DQuat::IDENTITY));
/// let tiny = DQuat::from_xyzw(3e-300, 0.0, 0.0, 4e-300);
/// assert!((unit_quaternion(tiny).unwrap().x - 0.6).abs() < 1e-15);
/// assert_eq!(unit_quaternion(DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)), None);
/// ```
#[inline]
pub fn unit_quaternion(q: DQuat) -> Option<DQuat> {
    let largest = glam::DVec4::from(q).abs().max_element();
    if !(q.is_finite() && largest > 0.0) {
        return None;
    }
    Some((q * unit_scale(largest)).normalize())
}
