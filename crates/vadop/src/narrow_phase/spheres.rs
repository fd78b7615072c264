//! The spheres' closed forms: the exact time of first contact of two moving spheres, or of a
//! sphere and a wall of the box.
//!
//! It owns the contact arithmetic and its tolerance, and nothing else: it never sees the world,
//! the broad phase or the queue, so every method and the brute-force oracle call the very same
//! functions and get bit-identical times. Motion is linear between velocity changes,
//! p(t) = p + (t - since) v, or a parabola under the world's gravity g,
//! p(t) = p + (t - since) v + (t - since)^2 g / 2: two bodies under the same g keep a linear
//! relative motion, so a pair's closed form is the same, from both centres and velocities at
//! the reference instant; only a wall sees the parabola (a quadratic per axis). A pair whose
//! accelerations differ (one falls onto another at rest) has a bent relative path, served by
//! [`super::falling`].
//!
//! Times are *canonical*: a pair's contact time is computed from the instant its relative motion
//! began (the later of the two bodies' last velocity changes), never from the window or frame
//! that asks. Whichever frame, window or method tests a pair, it gets the same time to the bit,
//! and the time belongs to exactly one half-open window `[start, end)`: a contact on a frame
//! boundary is reported once.
//!
//! Tolerance: two spheres whose centre distance d satisfies d^2 >= R^2 (1 - 2 * `CONTACT_TOLERANCE`)
//! count as touching, R being the sum of the radii (a *relative* tolerance, so it means the same at
//! any scale and any distance from the origin). Spheres already overlapping deeper than that are
//! not a new contact: they are passing through each other (detect mode) or were resolved earlier.
//!
//! Scale: lengths and velocities are scaled by exact powers of two before any square is taken,
//! so the arithmetic neither underflows for tiny scenes nor overflows for huge ones, and a scene
//! scaled by a power of two gives bit-identical contact times, scaled alike. Only a screen that
//! rejects clear misses first squares unscaled values, within guards that keep it conservative.

use super::falling::falling_sphere_time;
use crate::bodies::BodyState;
use crate::motion::Motion;
use crate::numeric::{exponent, power_of_two, scale_by_power_of_two, unit_scale};
use crate::walls::Wall;
use glam::DVec3;

/// Relative tolerance on the centre distance within which two spheres count as touching.
pub const CONTACT_TOLERANCE: f64 = 1e-9;

/// Smallest approach rate, relative to |offset| |relative velocity|, that counts as approaching.
/// Below it the motion is tangential to rounding accuracy: such a touch carries no impulse, and
/// treating it as a contact could re-detect a just-resolved pair forever.
pub const APPROACH_TOLERANCE: f64 = 1e-12;

/// A relative velocity within this fraction of the bodies' own speeds is rounding noise, not an
/// approach: without this, a pair brought to rest against each other would keep "colliding" on
/// rounding residues until they underflow.
///
/// The rule (`approach_time_by`) holds only where the true velocities have |vb - va| <=
/// 1.0001e-12 (|va| + |vb|), the bound every proof that a pair may skip it starts from (the
/// screens of `moving_pair_contact_time`'s callers, and [`straight_pair_contact_times_four`]'s
/// lanes): it is asked of the velocities scaled by a power of two, exactly, their largest
/// component in [1, 2) (a component scaled below 2^-1022 loses at most 2^-1074, far below
/// 10^-12 of a sum of lengths of at least 1), and its three lengths are each a few roundings,
/// well under 10^-4 relative, from the true ones.
pub const NOISE_VELOCITY: f64 = 1e-12;

/// Time `tau >= 0` after the reference instant at which two spheres first touch while
/// approaching, if they ever do on their straight paths.
///
/// `offset` is the centre of the second sphere minus the centre of the first, `relative_velocity`
/// the second's velocity minus the first's, both at the reference instant; `radius_sum` is R.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::spheres::sphere_sphere_time;
/// // Two unit spheres 10 apart closing at speed 4 touch after (10 - 2) / 4 = 2.
/// let tau = sphere_sphere_time(DVec3::new(10.0, 0.0, 0.0), DVec3::new(-4.0, 0.0, 0.0), 2.0);
/// assert_eq!(tau, Some(2.0));
/// // Receding: never.
/// assert_eq!(sphere_sphere_time(DVec3::new(10.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0), 2.0), None);
/// ```
// Always inlined: every candidate pair's test runs it, and most leave it at its first check.
#[inline(always)]
pub fn sphere_sphere_time(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> Option<f64> {
    if paths_clearly_miss(offset, relative_velocity, radius_sum) {
        return None;
    }
    exact_sphere_time(offset, relative_velocity, radius_sum)
}

/// [`sphere_sphere_time`] without its screen: the inputs scaled, then the closed form.
#[inline(always)]
fn exact_sphere_time(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> Option<f64> {
    let (length, speed) = (exponent(radius_sum), exponent(relative_velocity.abs().max_element()));
    let tau = scaled_time(
        offset * power_of_two(-length),
        relative_velocity * power_of_two(-speed),
        radius_sum * power_of_two(-length),
    )?;
    // tau = tau' * 2^length / 2^speed: a power of two, so this is exact.
    let tau = scale_by_power_of_two(tau, length - speed);
    tau.is_finite().then_some(tau)
}

/// True when the centres' straight paths (the lines, over all time) pass further apart than
/// `radius_sum` by a margin no rounding can cross: then [`scaled_time`] finds them apart at the
/// reference instant and missing (gap > 0, discriminant < 0), and the pair has no contact. Most
/// candidate pairs of fast bodies are such misses, and this tells them on the unscaled inputs,
/// without the exponents and scaling the exact test pays first (the approach test, its first,
/// rejects few: the reference instant usually lies before the closest approach).
///
/// Why it never rejects a pair the exact test accepts: both compute the discriminant
/// D = |v|^2 R^2 - |offset x v|^2 from the same floats (the exact test's scaling is by powers of
/// two, exact), each with a rounding error below 32 ulps of P + S (P = |offset|^2 |v|^2,
/// S = |v|^2 R^2). This rejects only when its D is below -2^-40 (P + S), so the true D lies below
/// -2^-41 (P + S) and the exact test's is negative too. Then |offset|^2 > R^2 (1 + 2^-41) +
/// 2^-41 |offset|^2 (as |offset|^2 |v|^2 >= |offset x v|^2), a gap no rounding of the exact
/// test's |offset|^2 - R^2 (4 ulps of |offset|^2 + R^2) can close. The guards keep those error
/// bounds valid: |v|^2 and R^2 above 2^-450 (so S is above 2^-900, R and |v| are normal
/// numbers, the exact test's scaled S is at least 1, and neither computation's underflow matters
/// beside the margin), P + S below
/// 2^900 (nothing here overflows) and |offset| below 2^200 R (the exact test's scaled squares
/// cannot overflow). A NaN fails a comparison and is left to the exact test.
#[inline(always)]
fn paths_clearly_miss(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> bool {
    let speed_sq = relative_velocity.length_squared();
    let (distance_sq, radius_sq) = (offset.length_squared(), radius_sum * radius_sum);
    let sweep = speed_sq * radius_sq;
    let bound = distance_sq * speed_sq + sweep;
    let miss = offset.cross(relative_velocity).length_squared() - sweep;
    miss > MISS_MARGIN * bound
        && speed_sq.min(radius_sq) > SMALLEST_SQUARE
        && bound < LARGEST_BOUND
        && distance_sq < FARTHEST_SQUARED * radius_sq
}

/// The clear-miss screen's margin and guards (see [`paths_clearly_miss`]), one set for its scalar
/// form and its lanes.
const MISS_MARGIN: f64 = power_of_two(-40);
const SMALLEST_SQUARE: f64 = power_of_two(-450);
const LARGEST_BOUND: f64 = power_of_two(900);
const FARTHEST_SQUARED: f64 = power_of_two(400);

/// The root of [`sphere_sphere_time`] for inputs already scaled near 1.
#[inline]
fn scaled_time(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> Option<f64> {
    let approach = offset.dot(relative_velocity);
    // Most candidate pairs recede or miss: both are told without a square root. The threshold
    // below is never positive, so a pair that fails `approach < 0` fails it too (NaN included).
    if !(approach < 0.0) {
        return None;
    }
    let speed_sq = relative_velocity.length_squared();
    let radius_sq = radius_sum * radius_sum;
    let distance_sq = offset.length_squared();
    let gap = distance_sq - radius_sq;
    // b^2 - a c written as a R^2 - |offset x v|^2: no cancellation between two large squares,
    // which keeps grazing and nearly parallel motion accurate.
    let discriminant = speed_sq * radius_sq - offset.cross(relative_velocity).length_squared();
    if gap > 0.0 && discriminant < 0.0 {
        return None;
    }
    // Only approaching pairs can start a contact; `!(x < y)` also rejects NaN.
    let threshold = -APPROACH_TOLERANCE * (distance_sq * speed_sq).sqrt();
    if !(approach < threshold) {
        return None;
    }
    if gap <= 0.0 {
        let touching = gap >= -2.0 * CONTACT_TOLERANCE * radius_sq;
        return touching.then_some(0.0);
    }
    // The smaller root (-b - sqrt(disc)) / a in the form that never divides by a tiny a.
    Some(gap / (-approach + discriminant.sqrt()))
}

/// Canonical absolute time at which two spheres on their current motions, under the uniform
/// accelerations `(ga, gb)` (zero for straight paths; the same gravity for two falling bodies),
/// first touch while approaching, if ever: computed from the later of the two `since` instants,
/// so it does not depend on when or by whom it is asked.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::spheres::pair_contact_time;
/// use vadop::motion::Motion;
/// let a = Motion { position: DVec3::new(2.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(1.5, 0.0, 0.0) };
/// let b = Motion { position: DVec3::new(8.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(-1.5, 0.0, 0.0) };
/// // The gap of 5 closes at 3: one contact at 5/3, whichever frame asks.
/// assert_eq!(pair_contact_time(&a, &b, 1.0, (DVec3::ZERO, DVec3::ZERO)), Some(5.0 / 3.0));
/// // Falling together, they meet at the same instant.
/// let g = DVec3::new(0.0, 0.0, -9.81);
/// assert_eq!(pair_contact_time(&a, &b, 1.0, (g, g)), Some(5.0 / 3.0));
/// // With a at rest, b falls below it and misses.
/// assert_eq!(pair_contact_time(&a, &b, 1.0, (DVec3::ZERO, g)), None);
/// ```
#[inline(always)]
pub fn pair_contact_time(a: &Motion, b: &Motion, radius_sum: f64, (ga, gb): (DVec3, DVec3)) -> Option<f64> {
    if ga == DVec3::ZERO && gb == DVec3::ZERO {
        return straight_pair_contact_time(a, b, radius_sum);
    }
    let reference = a.since.max(b.since);
    let (va, vb) = (a.velocity_under(reference, ga), b.velocity_under(reference, gb));
    let offset = b.at_under(reference, gb) - a.at_under(reference, ga);
    if ga != gb {
        let time = reference + falling_sphere_time(offset, vb - va, gb - ga, radius_sum)?;
        return time.is_finite().then_some(time);
    }
    approach_time(reference, (va, vb), offset, radius_sum)
}

/// [`pair_contact_time`] of two spheres on straight paths (no pull on either), the same bits:
/// a world without gravity asks this of every candidate pair, with no pull to read or compare.
///
/// ```
/// use glam::DVec3;
/// use vadop::motion::Motion;
/// use vadop::narrow_phase::spheres::{pair_contact_time, straight_pair_contact_time};
/// let a = Motion { position: DVec3::new(2.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(1.5, 0.0, 0.0) };
/// // b starts later: from 0.5 on, when a is at x = 2.75, the gap of 7 - 1 closes at 3.
/// let b = Motion { position: DVec3::new(9.75, 5.0, 5.0), since: 0.5, velocity: DVec3::new(-1.5, 0.0, 0.0) };
/// let straight = straight_pair_contact_time(&a, &b, 1.0);
/// assert_eq!(straight, pair_contact_time(&a, &b, 1.0, (DVec3::ZERO, DVec3::ZERO)));
/// assert_eq!(straight, Some(2.5));
/// ```
#[inline(always)]
pub fn straight_pair_contact_time(a: &Motion, b: &Motion, radius_sum: f64) -> Option<f64> {
    let (reference, offset) = straight_offset(a, b);
    approach_time(reference, (a.velocity, b.velocity), offset, radius_sum)
}

/// [`straight_pair_contact_time`] of a pair that [`straight_paths_clearly_miss`] has passed: the
/// same bits (past its screen the exact test is all that runs), without asking the screen again.
#[inline(always)]
pub fn straight_pair_contact_time_past_screen(a: &Motion, b: &Motion, radius_sum: f64) -> Option<f64> {
    let (reference, offset) = straight_offset(a, b);
    approach_time_by(exact_sphere_time, reference, (a.velocity, b.velocity), offset, radius_sum, false)
}

/// [`straight_pair_contact_time_past_screen`] of a pair whose relative velocity the caller knows
/// to be no rounding noise (its noise rule, see [`NOISE_VELOCITY`], cannot hold for it): the same
/// bits, without asking that rule (three square roots).
#[inline(always)]
pub(crate) fn moving_pair_contact_time(a: &Motion, b: &Motion, radius_sum: f64) -> Option<f64> {
    let (reference, offset) = straight_offset(a, b);
    approach_time_by(exact_sphere_time, reference, (a.velocity, b.velocity), offset, radius_sum, true)
}

/// True when [`straight_pair_contact_time`] of `a` and `b` is `None` by its first screen (the
/// centres' lines pass clearly apart), from the very floats it computes, in either order (the
/// offset and relative velocity of `b, a` are those of `a, b` negated, exactly, so every square
/// and cross product is the same). For a pair sweep to tell its many such candidates before
/// anything else of the pair is looked at.
///
/// ```
/// use glam::DVec3;
/// use vadop::motion::Motion;
/// use vadop::narrow_phase::spheres::{straight_pair_contact_time, straight_paths_clearly_miss};
/// let a = Motion { position: DVec3::new(2.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(1.5, 0.0, 0.0) };
/// // Parallel lines 3 apart: they never come within 1.
/// let b = Motion { position: DVec3::new(2.0, 8.0, 5.0), since: 0.5, velocity: DVec3::new(-1.5, 0.0, 0.0) };
/// assert!(straight_paths_clearly_miss(&a, &b, 1.0) && straight_paths_clearly_miss(&b, &a, 1.0));
/// assert_eq!(straight_pair_contact_time(&a, &b, 1.0), None);
/// // Head on: not a clear miss.
/// let c = Motion { position: DVec3::new(9.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(-1.5, 0.0, 0.0) };
/// assert!(!straight_paths_clearly_miss(&a, &c, 1.0));
/// ```
#[inline(always)]
pub fn straight_paths_clearly_miss(a: &Motion, b: &Motion, radius_sum: f64) -> bool {
    let (_, offset) = straight_offset(a, b);
    paths_clearly_miss(offset, b.velocity - a.velocity, radius_sum)
}

/// [`straight_paths_clearly_miss`] of four pairs at once, pair k (`a[k]` and `b[k]`, their radii
/// summed) in lane k of AVX's four-wide registers: bit k of the result is set when the screen
/// clears it, exactly when the scalar screen does. A lane runs the scalar screen's operations
/// in its order, without fused multiply-adds (which round once where it rounds twice), so its
/// floats are the scalar's bits. Two steps differ only where a NaN is met: the later `since`
/// (`vmaxpd`, not `f64::max`) and the guard on the smaller square (two comparisons, not `min`);
/// a NaN in either makes `miss` NaN in both forms, and both keep the pair. The scalar form's
/// arithmetic is about 85 instructions a pair on two-wide registers; this is about 90 for four,
/// the states' 8 loads and 16 shuffles included.
///
/// # Safety
/// The processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub unsafe fn straight_paths_clearly_miss_four(a: [&BodyState; 4], b: [&BodyState; 4]) -> u32 {
    use std::arch::x86_64::*;
    let StraightPairsFour { offset, relative_velocity, radius_sum, .. } = straight_pairs_four(a, b);
    let one = |value: f64| _mm256_set1_pd(value);
    let (add, sub, mul) = (|x, y| _mm256_add_pd(x, y), |x, y| _mm256_sub_pd(x, y), |x, y| _mm256_mul_pd(x, y));
    // `paths_clearly_miss`, line by line.
    let speed_sq = dot_four(relative_velocity, relative_velocity);
    let (distance_sq, radius_sq) = (dot_four(offset, offset), mul(radius_sum, radius_sum));
    let sweep = mul(speed_sq, radius_sq);
    let bound = add(mul(distance_sq, speed_sq), sweep);
    let cross = cross_four(offset, relative_velocity);
    let miss = sub(dot_four(cross, cross), sweep);
    let (greater, less, and) = (
        |x, y| _mm256_cmp_pd::<_CMP_GT_OQ>(x, y),
        |x, y| _mm256_cmp_pd::<_CMP_LT_OQ>(x, y),
        |x, y| _mm256_and_pd(x, y),
    );
    let clears = and(
        and(greater(miss, mul(one(MISS_MARGIN), bound)), less(bound, one(LARGEST_BOUND))),
        and(
            and(greater(speed_sq, one(SMALLEST_SQUARE)), greater(radius_sq, one(SMALLEST_SQUARE))),
            less(distance_sq, mul(one(FARTHEST_SQUARED), radius_sq)),
        ),
    );
    _mm256_movemask_pd(clears) as u32
}

/// Four states each as two rows of four floats (`half` 0: the position and `since`; 1: the
/// velocity and the radius), the rows of the four turned into columns: a coordinate of all four
/// in one register, the `k`-th state's in lane `k`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub(crate) fn state_columns(states: [&BodyState; 4], half: usize) -> [std::arch::x86_64::__m256d; 4] {
    use std::arch::x86_64::*;
    let () = STATE_ROWS;
    assert!(half < 2);
    let row = |state: &BodyState| {
        // SAFETY: a `BodyState` is 8 floats (`STATE_ROWS`); `half` is 0 or 1.
        unsafe { _mm256_loadu_pd(std::ptr::from_ref(state).cast::<f64>().add(4 * half)) }
    };
    let [r0, r1, r2, r3] = states.map(row);
    let (low01, high01) = (_mm256_unpacklo_pd(r0, r1), _mm256_unpackhi_pd(r0, r1));
    let (low23, high23) = (_mm256_unpacklo_pd(r2, r3), _mm256_unpackhi_pd(r2, r3));
    [
        _mm256_permute2f128_pd::<0x20>(low01, low23),
        _mm256_permute2f128_pd::<0x20>(high01, high23),
        _mm256_permute2f128_pd::<0x31>(low01, low23),
        _mm256_permute2f128_pd::<0x31>(high01, high23),
    ]
}

/// What [`state_columns`] loads a state as: two rows of four floats, the
/// position and `since`, then the velocity and the radius.
#[cfg(target_arch = "x86_64")]
const STATE_ROWS: () = {
    use std::mem::{offset_of, size_of};
    let motion = offset_of!(BodyState, motion);
    assert!(size_of::<BodyState>() >= 64 && motion == 0 && offset_of!(BodyState, radius) == 56);
    assert!(offset_of!(Motion, position) == 0 && offset_of!(Motion, since) == 24 && offset_of!(Motion, velocity) == 32);
};

/// Four pairs' straight motions in lanes, from their reference instants (the later `since`):
/// what [`straight_offset`] and the relative velocity are for one pair, with both velocities and
/// the radius sum, pair k in lane k.
#[cfg(target_arch = "x86_64")]
struct StraightPairsFour {
    reference: std::arch::x86_64::__m256d,
    offset: [std::arch::x86_64::__m256d; 3],
    relative_velocity: [std::arch::x86_64::__m256d; 3],
    velocities: [[std::arch::x86_64::__m256d; 3]; 2],
    radius_sum: std::arch::x86_64::__m256d,
}

/// [`StraightPairsFour`] of `a[k]` and `b[k]`, each lane the scalar's floats: the later `since`
/// by `vmaxpd` (which differs from `f64::max` only where a `since` is NaN, and then the offset is
/// NaN in both forms, or in the sign of a zero, which no square or comparison sees), each centre
/// then by `Motion::at`, b's less a's.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn straight_pairs_four(a: [&BodyState; 4], b: [&BodyState; 4]) -> StraightPairsFour {
    use std::arch::x86_64::*;
    let ([ax, ay, az, since_a], [wx, wy, wz, radius_a]) = (state_columns(a, 0), state_columns(a, 1));
    let ([bx, by, bz, since_b], [vx, vy, vz, radius_b]) = (state_columns(b, 0), state_columns(b, 1));
    let (position_a, velocity_a) = ([ax, ay, az], [wx, wy, wz]);
    let (position_b, velocity_b) = ([bx, by, bz], [vx, vy, vz]);
    let reference = _mm256_max_pd(since_a, since_b);
    let (elapsed_a, elapsed_b) = (_mm256_sub_pd(reference, since_a), _mm256_sub_pd(reference, since_b));
    let offset = std::array::from_fn(|k| {
        let at_a = _mm256_add_pd(position_a[k], _mm256_mul_pd(elapsed_a, velocity_a[k]));
        let at_b = _mm256_add_pd(position_b[k], _mm256_mul_pd(elapsed_b, velocity_b[k]));
        _mm256_sub_pd(at_b, at_a)
    });
    let relative_velocity = std::array::from_fn(|k| _mm256_sub_pd(velocity_b[k], velocity_a[k]));
    let radius_sum = _mm256_add_pd(radius_a, radius_b);
    StraightPairsFour { reference, offset, relative_velocity, velocities: [velocity_a, velocity_b], radius_sum }
}

/// glam's dot product in lanes, in its order: (x x' + y y') + z z'.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn dot_four(u: [std::arch::x86_64::__m256d; 3], v: [std::arch::x86_64::__m256d; 3]) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u[0], v[0]), _mm256_mul_pd(u[1], v[1])), _mm256_mul_pd(u[2], v[2]))
}

/// glam's cross product in lanes: (y z' - y' z, z x' - z' x, x y' - x' y).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn cross_four(
    [x, y, z]: [std::arch::x86_64::__m256d; 3],
    [u, v, w]: [std::arch::x86_64::__m256d; 3],
) -> [std::arch::x86_64::__m256d; 3] {
    use std::arch::x86_64::*;
    let (sub, mul) = (|p, q| _mm256_sub_pd(p, q), |p, q| _mm256_mul_pd(p, q));
    [sub(mul(y, w), mul(v, z)), sub(mul(z, u), mul(w, x)), sub(mul(x, v), mul(u, y))]
}

/// `2^e` in each lane, e the lane's [`exponent`] (its exponent bits alone, clamped to the normal
/// range as [`exponent`] clamps: zero and subnormals give 2^-1022, infinity and NaN 2^1022).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn exponent_powers(x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let bits = _mm256_and_pd(x, _mm256_set1_pd(f64::INFINITY));
    _mm256_min_pd(_mm256_max_pd(bits, _mm256_set1_pd(power_of_two(-1022))), _mm256_set1_pd(power_of_two(1022)))
}

/// The largest of `exponent_powers` over three columns: for numbers (NaN aside) the power of the
/// largest magnitude's exponent, as the exponent grows with the magnitude.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn largest_exponent_power([x, y, z]: [std::arch::x86_64::__m256d; 3]) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    _mm256_max_pd(_mm256_max_pd(exponent_powers(x), exponent_powers(y)), exponent_powers(z))
}

/// [`straight_pair_contact_time_past_screen`] of four pairs at once, pair k (`a[k]` and `b[k]`,
/// their radii summed) in lane k: each answer the scalar's, to the bit. Every lane runs the
/// scalar's operations in its order, without fused multiply-adds, and its decisions by the same
/// comparisons (a NaN fails them as it fails the scalar's), so its floats are the scalar's
/// bits, with three differences of form, each exact where it is used:
/// - the exponents' powers come from the exponent bits alone (`exponent_powers`), and their
///   reciprocals (powers of two in the normal range) are exact; the largest component's power is
///   the largest power, NaN aside, and a NaN in a velocity makes the approach NaN, a miss;
/// - the contact's time is scaled by `2^length / 2^speed` at once, which is the scalar's two
///   steps exactly when that ratio and the result are normal numbers (or the result zero): the
///   scalar's middle value lies between the two. A lane with a contact outside that is answered
///   by the scalar test itself (none in ordinary scenes);
/// - the later `since` by `vmaxpd` (`straight_pairs_four`).
///
/// The pairs are those the sweep keeps past [`straight_paths_clearly_miss`]: most of them pass
/// through each other in detect mode, so this runs the whole test in every lane rather than
/// leaving it early as the scalar form does.
///
/// Only a contact inside its pair's window can be an event, and a third of the kept pairs' fall
/// outside it at 5 diameters/frame: bit k of the mask returned is set when pair k has a contact
/// and its time lies in lane k's window (`starts` and `ends`, `start <= time < end` as
/// [`crate::window::Window::contains`] asks, by the same ordered comparisons), and then lane k of
/// the times is that time; the other lanes' times are anything. The caller reports only the
/// set lanes, from one mask and one row of four floats rather than four options.
///
/// # Safety
/// The processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub unsafe fn straight_pair_contact_times_four(
    a: [&BodyState; 4],
    b: [&BodyState; 4],
    [starts, ends]: [std::arch::x86_64::__m256d; 2],
) -> (u32, [f64; 4]) {
    use std::arch::x86_64::*;
    let StraightPairsFour { reference, offset, relative_velocity, velocities, radius_sum } = straight_pairs_four(a, b);
    let one = |value: f64| _mm256_set1_pd(value);
    let (add, sub, mul) = (|x, y| _mm256_add_pd(x, y), |x, y| _mm256_sub_pd(x, y), |x, y| _mm256_mul_pd(x, y));
    let (and, and_not) = (|x, y| _mm256_and_pd(x, y), |x, y| _mm256_andnot_pd(x, y));
    let (less, less_or_equal) = (|x, y| _mm256_cmp_pd::<_CMP_LT_OQ>(x, y), |x, y| _mm256_cmp_pd::<_CMP_LE_OQ>(x, y));
    let magnitude = |x| _mm256_and_pd(x, one(f64::from_bits(!(1 << 63))));
    // `exact_sphere_time`'s scaling.
    let (length_power, speed_power) = (exponent_powers(radius_sum), largest_exponent_power(relative_velocity));
    let (inverse_length, inverse_speed) = (_mm256_div_pd(one(1.0), length_power), _mm256_div_pd(one(1.0), speed_power));
    let o = offset.map(|x| mul(x, inverse_length));
    let v = relative_velocity.map(|x| mul(x, inverse_speed));
    let r = mul(radius_sum, inverse_length);
    // `scaled_time`, line by line.
    let approach = dot_four(o, v);
    let speed_sq = dot_four(v, v);
    let radius_sq = mul(r, r);
    let distance_sq = dot_four(o, o);
    let gap = sub(distance_sq, radius_sq);
    let cross = cross_four(o, v);
    let discriminant = sub(mul(speed_sq, radius_sq), dot_four(cross, cross));
    let zero = _mm256_setzero_pd();
    let missing = and(less(zero, gap), less(discriminant, zero));
    let threshold = mul(one(-APPROACH_TOLERANCE), _mm256_sqrt_pd(mul(distance_sq, speed_sq)));
    let overlapping = less_or_equal(gap, zero);
    let touching = less_or_equal(mul(one(-2.0 * CONTACT_TOLERANCE), radius_sq), gap);
    let found = and_not(missing, and(less(approach, zero), less(approach, threshold)));
    let found = and_not(and_not(touching, overlapping), found);
    // -approach + sqrt(discriminant), as sqrt(discriminant) - approach: the same sum.
    let root = _mm256_div_pd(gap, sub(_mm256_sqrt_pd(discriminant), approach));
    let scaled = _mm256_blendv_pd(root, zero, overlapping);
    // `scale_by_power_of_two` by 2^(length - speed) in one step, where that is exact.
    let ratio = mul(length_power, inverse_speed);
    let tau = mul(scaled, ratio);
    let normal = |x| and(less_or_equal(one(f64::MIN_POSITIVE), x), less(x, one(f64::INFINITY)));
    let exact = and(normal(ratio), _mm256_or_pd(normal(magnitude(tau)), _mm256_cmp_pd::<_CMP_EQ_OQ>(tau, zero)));
    // `approach_time_by`'s check of the velocities, scaled by the larger's largest component,
    // asked only where a found lane's relative velocity is not clearly above the bound the rule
    // can hold under (see [`NOISE_VELOCITY`]): with the relative velocity's largest component at
    // least `speed_power`, a normal number, and every component of both velocities below
    // `2^36 speed_power`, |vb - va| is about `speed_power` or more and 1.0001e-12 (|va| + |vb|)
    // below 1.0001e-12 2 sqrt(3) 2^36 `speed_power`, under a quarter of it: no noise (a NaN in a
    // velocity makes the check's lengths NaN, no noise either).
    let [velocity_a, velocity_b] = velocities;
    let largest = |u: [__m256d; 3]| _mm256_max_pd(_mm256_max_pd(magnitude(u[0]), magnitude(u[1])), magnitude(u[2]));
    let clearly_moving = and(
        less(_mm256_max_pd(largest(velocity_a), largest(velocity_b)), mul(speed_power, one(power_of_two(36)))),
        less(one(f64::MIN_POSITIVE), speed_power),
    );
    let noise = if _mm256_movemask_pd(and_not(clearly_moving, found)) == 0 {
        zero
    } else {
        let scale = _mm256_div_pd(
            one(1.0),
            _mm256_max_pd(largest_exponent_power(velocity_a), largest_exponent_power(velocity_b)),
        );
        let (va, vb) = (velocity_a.map(|x| mul(x, scale)), velocity_b.map(|x| mul(x, scale)));
        let difference = std::array::from_fn(|k| sub(vb[k], va[k]));
        let length = |u| _mm256_sqrt_pd(dot_four(u, u));
        less_or_equal(length(difference), mul(one(NOISE_VELOCITY), add(length(va), length(vb))))
    };
    let time = add(reference, tau);
    let finite = less(magnitude(time), one(f64::INFINITY));
    let inside = and(_mm256_cmp_pd::<_CMP_LE_OQ>(starts, time), less(time, ends));
    let events = _mm256_movemask_pd(and(and(and_not(noise, found), finite), inside)) as u32;
    let by_scalar = _mm256_movemask_pd(and_not(exact, found)) as u32;
    let mut times = [0.0; 4];
    // SAFETY: four floats.
    unsafe { _mm256_storeu_pd(times.as_mut_ptr(), time) };
    if by_scalar == 0 {
        return (events, times);
    }
    let (mut starts_of, mut ends_of) = ([0.0; 4], [0.0; 4]);
    // SAFETY: four floats each.
    unsafe { (_mm256_storeu_pd(starts_of.as_mut_ptr(), starts), _mm256_storeu_pd(ends_of.as_mut_ptr(), ends)) };
    answer_by_scalar((events, times), by_scalar, (a, b), (starts_of, ends_of))
}

/// The lanes of [`straight_pair_contact_times_four`] set in `lanes`, answered by the scalar
/// test itself in their windows. Out of line: no lane of an ordinary scene comes here.
#[cfg(target_arch = "x86_64")]
#[cold]
#[inline(never)]
fn answer_by_scalar(
    (mut events, mut times): (u32, [f64; 4]),
    lanes: u32,
    (a, b): ([&BodyState; 4], [&BodyState; 4]),
    (starts, ends): ([f64; 4], [f64; 4]),
) -> (u32, [f64; 4]) {
    for k in (0..4).filter(|k| lanes >> k & 1 == 1) {
        let time = straight_pair_contact_time_past_screen(&a[k].motion, &b[k].motion, a[k].radius + b[k].radius);
        let inside = time.filter(|&t| crate::window::Window { start: starts[k], end: ends[k] }.contains(t));
        events = events & !(1 << k) | u32::from(inside.is_some()) << k;
        times[k] = inside.unwrap_or(0.0);
    }
    (events, times)
}

/// The reference instant of two straight motions (the later `since`) and `b`'s centre less
/// `a`'s then: what [`straight_pair_contact_time`] and its screen start from.
#[inline(always)]
fn straight_offset(a: &Motion, b: &Motion) -> (f64, DVec3) {
    let reference = a.since.max(b.since);
    // `at` is `at_under` without a pull, to the bit.
    (reference, b.at(reference) - a.at(reference))
}

/// The contact time of two spheres `offset` apart at `reference` with velocities `(va, vb)` and
/// no relative acceleration: [`sphere_sphere_time`] from `reference`, unless the relative
/// velocity is rounding noise.
#[inline(always)]
fn approach_time(reference: f64, velocities: (DVec3, DVec3), offset: DVec3, radius_sum: f64) -> Option<f64> {
    approach_time_by(sphere_sphere_time, reference, velocities, offset, radius_sum, false)
}

/// [`approach_time`] with `time` for [`sphere_sphere_time`] (or its exact test alone, for a pair
/// already screened); the noise rule not asked of a pair known to be `moving`.
#[inline(always)]
fn approach_time_by(
    time: impl FnOnce(DVec3, DVec3, f64) -> Option<f64>,
    reference: f64,
    (va, vb): (DVec3, DVec3),
    offset: DVec3,
    radius_sum: f64,
    moving: bool,
) -> Option<f64> {
    let tau = time(offset, vb - va, radius_sum)?;
    // Checked only for predicted contacts, which are far fewer than candidate pairs.
    if !moving {
        let scale = unit_scale(va.abs().max_element().max(vb.abs().max_element()));
        let (va, vb) = (va * scale, vb * scale);
        if (vb - va).length() <= NOISE_VELOCITY * (va.length() + vb.length()) {
            return None;
        }
    }
    let time = reference + tau;
    time.is_finite().then_some(time)
}

/// Time `tau` after the reference instant at which two touching or overlapping spheres separate:
/// the later root of |offset + tau v| = R, where their centres move apart through the distance R
/// again: 0 when they are apart and moving apart; for a pair apart but approaching, when it leaves
/// after passing through (the time of closest approach for a pair that misses). `None` when
/// there is no relative motion.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::spheres::sphere_separation_time;
/// // Centres 1 apart, R = 2, closing at 1: they pass through and separate when 2 apart on the far side.
/// assert_eq!(sphere_separation_time(DVec3::new(1.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 2.0), Some(3.0));
/// ```
#[inline]
pub fn sphere_separation_time(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> Option<f64> {
    let (length, speed) = (exponent(radius_sum), exponent(relative_velocity.abs().max_element()));
    let (offset, velocity, radius) =
        (offset * power_of_two(-length), relative_velocity * power_of_two(-speed), radius_sum * power_of_two(-length));
    let speed_sq = velocity.length_squared();
    if !(speed_sq > 0.0) {
        return None;
    }
    let gap = offset.length_squared() - radius * radius;
    let recession = offset.dot(velocity);
    // As in `scaled_time`, b^2 - a c as a R^2 - |offset x v|^2; rounding may take a grazing pair
    // below zero, and such a pair separates at its closest approach.
    let root = (speed_sq * radius * radius - offset.cross(velocity).length_squared()).max(0.0).sqrt();
    // The larger root (-b + sqrt(disc)) / a, in the form without cancellation for either sign of b.
    let tau = if recession > 0.0 { -gap / (recession + root) } else { (root - recession) / speed_sq };
    let tau = scale_by_power_of_two(tau.max(0.0), length - speed);
    tau.is_finite().then_some(tau)
}

/// Canonical absolute time at which two touching spheres on their current motions, both under
/// `gravity`, separate (see [`sphere_separation_time`]), computed from the later of the two
/// `since` instants like [`pair_contact_time`]; `None` when they move together and never separate.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::spheres::{pair_contact_time, pair_separation_time};
/// use vadop::motion::Motion;
/// let a = Motion { position: DVec3::new(2.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(1.5, 0.0, 0.0) };
/// let b = Motion { position: DVec3::new(8.0, 5.0, 5.0), since: 0.0, velocity: DVec3::new(-1.5, 0.0, 0.0) };
/// // They touch at 5/3 (centres 1 apart), pass through each other and part at 7/3.
/// assert_eq!(pair_contact_time(&a, &b, 1.0, (DVec3::ZERO, DVec3::ZERO)), Some(5.0 / 3.0));
/// assert_eq!(pair_separation_time(&a, &b, 1.0, DVec3::ZERO), Some(7.0 / 3.0));
/// ```
#[inline]
pub fn pair_separation_time(a: &Motion, b: &Motion, radius_sum: f64, gravity: DVec3) -> Option<f64> {
    let reference = a.since.max(b.since);
    let offset = b.at_under(reference, gravity) - a.at_under(reference, gravity);
    let relative_velocity = b.velocity_under(reference, gravity) - a.velocity_under(reference, gravity);
    let tau = sphere_separation_time(offset, relative_velocity, radius_sum)?;
    let time = reference + tau;
    time.is_finite().then_some(time)
}

/// Canonical absolute time at which a sphere of `radius` on `motion` under `gravity` inside the
/// box `[min, max]` first touches a wall while moving towards it, with the wall. Ties go to the
/// lowest axis.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::spheres::wall_contact_time;
/// use vadop::Wall;
/// use vadop::motion::Motion;
/// let motion = Motion { position: DVec3::new(5.0, 5.0, 5.0), since: 1.0, velocity: DVec3::new(2.0, 0.0, 0.0) };
/// let (min, max) = (DVec3::ZERO, DVec3::splat(10.0));
/// assert_eq!(wall_contact_time(&motion, 1.0, min, max, DVec3::ZERO), Some((3.0, Wall::MaxX)));
/// // Dropped from rest 4 above the floor under g = 2: it lands after sqrt(2 * 4 / 2) = 2.
/// let dropped = Motion { position: DVec3::new(5.0, 5.0, 5.0), since: 1.0, velocity: DVec3::ZERO };
/// assert_eq!(wall_contact_time(&dropped, 1.0, min, max, DVec3::new(0.0, 0.0, -2.0)), Some((3.0, Wall::MinZ)));
/// ```
#[inline]
pub fn wall_contact_time(motion: &Motion, radius: f64, min: DVec3, max: DVec3, gravity: DVec3) -> Option<(f64, Wall)> {
    if gravity == DVec3::ZERO {
        return straight_wall_time(motion, radius, min, max);
    }
    any_wall_time(motion, radius, min, max, gravity)
}

/// [`wall_contact_time`] axis by axis: a parabola along the axes with a pull, a straight line
/// along the others.
#[inline]
fn any_wall_time(motion: &Motion, radius: f64, min: DVec3, max: DVec3, gravity: DVec3) -> Option<(f64, Wall)> {
    let mut best: Option<(f64, Wall)> = None;
    for axis in 0..3 {
        if gravity[axis] != 0.0 {
            let (x, v, g) = (motion.position[axis], motion.velocity[axis], gravity[axis]);
            for (is_max, distance) in [(false, x - (min[axis] + radius)), (true, max[axis] - radius - x)] {
                // Seen from the wall's side: the distance to it, the speed and the pull towards it.
                let sign = if is_max { 1.0 } else { -1.0 };
                let Some(tau) = parabola_arrival(distance, sign * v, sign * g) else { continue };
                if best.is_none_or(|(t, _)| tau < t) {
                    best = Some((tau, Wall::new(axis, is_max)));
                }
            }
            continue;
        }
        let speed = motion.velocity[axis];
        let (distance, is_max) = if speed > 0.0 {
            (max[axis] - radius - motion.position[axis], true)
        } else if speed < 0.0 {
            (motion.position[axis] - (min[axis] + radius), false)
        } else {
            continue;
        };
        // A body already at (or a rounding error past) the wall and moving out touches it now.
        let tau = distance.max(0.0) / speed.abs();
        if tau.is_finite() && best.is_none_or(|(t, _)| tau < t) {
            best = Some((tau, Wall::new(axis, is_max)));
        }
    }
    best.map(|(tau, wall)| (motion.since + tau, wall)).filter(|(time, _)| time.is_finite())
}

/// [`wall_contact_time`] of a straight path: the same arithmetic, axis by axis, then the earliest
/// axis (the lowest on a tie) picked by comparisons turned into indices rather than branches: the
/// signs of the velocity and the axis that wins are random in a gas, and branches on them
/// mispredicted about three times a call.
#[inline]
fn straight_wall_time(motion: &Motion, radius: f64, min: DVec3, max: DVec3) -> Option<(f64, Wall)> {
    // A body already at (or a rounding error past) the wall and moving out touches it now. The
    // time is +0 or more, or NaN (at rest along the axis: 0 / 0; a NaN input), never -0: `max`
    // takes a NaN or -0 distance to +0, and the divisor is non-negative.
    let tau = |axis: usize| {
        let (x, speed) = (motion.position[axis], motion.velocity[axis]);
        let (to_max, to_min) = (max[axis] - radius - x, x - (min[axis] + radius));
        if speed > 0.0 { to_max } else { to_min }.max(0.0) / speed.abs()
    };
    let (x, y, z) = (tau(0), tau(1), tau(2));
    // The earliest by plain comparisons from infinity (one `minsd` each, no NaN fix-ups): a NaN
    // axis is never earlier, as an infinite one (x / 0, a wall at infinity on a periodic axis):
    // neither is a contact. Times never -0, so a tie leaves the same bits whichever wins.
    let earlier = |tau: f64, best: f64| if tau < best { tau } else { best };
    let best = earlier(z, earlier(y, earlier(x, f64::INFINITY)));
    // A NaN axis is past a finite best, as an infinite one; with no finite best there is no wall.
    let (past_x, past_y) = (x != best, y != best);
    let axis = usize::from(past_x) + usize::from(past_x & past_y);
    let wall = Wall::new(axis, motion.velocity[axis] > 0.0);
    Some((motion.since + best, wall)).filter(|(time, _)| best.is_finite() && time.is_finite())
}

/// First `tau >= 0` at which a point `distance` from a wall, moving towards it at `speed` and
/// pulled towards it by `pull` (negative values: away), reaches it while still moving towards
/// it: the root of `pull tau^2 / 2 + speed tau = distance` where the speed there,
/// `sqrt(speed^2 + 2 pull distance)`, is positive. A point at (or a rounding error past) the wall
/// and moving or pulled out touches it now; one at rest on it touches it too (a resting state,
/// [`crate::bodies::Rest`], takes the pull away instead).
#[inline]
fn parabola_arrival(distance: f64, speed: f64, pull: f64) -> Option<f64> {
    let distance = distance.max(0.0);
    if distance == 0.0 && (speed > 0.0 || (speed == 0.0 && pull > 0.0)) {
        return Some(0.0);
    }
    let arrival_sq = speed * speed + 2.0 * pull * distance;
    if !(arrival_sq >= 0.0) {
        return None;
    }
    let arrival = arrival_sq.sqrt();
    // The two forms of the root, each free of cancellation for its sign of the speed.
    let tau = if speed >= 0.0 {
        2.0 * distance / (speed + arrival)
    } else if pull > 0.0 {
        (arrival - speed) / pull
    } else {
        return None;
    };
    (tau >= 0.0 && tau.is_finite()).then_some(tau)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::direction;

    #[test]
    fn the_screen_rejects_only_what_the_exact_test_rejects() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut screened, mut missed) = (0, 0);
        for n in 0..400_000 {
            // Scales from tiny to huge, and paths near grazing (miss distance within a few ulps
            // of R) as often as clear misses.
            let exponents = if n % 4 < 2 { -1100..1100 } else { -60..60 };
            let scale = 2f64.powi(rng.random_range(exponents.clone()));
            let speed = 2f64.powi(rng.random_range(exponents));
            let radius_sum = scale * rng.random_range(0.5..2.0);
            let along =
                DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let Some(unit) = direction(along) else { continue };
            let side = direction(unit.any_orthonormal_vector() + unit * rng.random_range(-0.1..0.1)).expect("unit");
            let miss = if n % 2 == 0 { 1.0 + rng.random_range(-1e-11..1e-11) } else { rng.random_range(0.0..3.0) };
            let offset = side * (miss * radius_sum) - unit * (scale * rng.random_range(-4.0..40.0));
            let velocity = unit * speed;
            let exact = exact_sphere_time(offset, velocity, radius_sum);
            if paths_clearly_miss(offset, velocity, radius_sum) {
                assert_eq!(exact, None, "offset {offset:?} velocity {velocity:?} R {radius_sum}");
                screened += 1;
            }
            missed += usize::from(exact.is_none());
        }
        // The screen catches most misses at ordinary scales (a quarter of the cases are clear
        // misses there), not a handful.
        assert!(screened * 6 > missed, "screened {screened} of {missed} misses");
    }

    /// A state against `near` where the pair's answers are hard: a path grazing `near`'s, the
    /// same velocity, touching or overlapping, anywhere at tiny or huge scales, or a special
    /// value (signed zeros, NaN, infinities, subnormals) in one coordinate.
    #[cfg(target_arch = "x86_64")]
    fn hard_state(rng: &mut rand_chacha::ChaCha8Rng, near: &BodyState) -> BodyState {
        use rand::Rng;
        let special = [0.0, -0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MIN_POSITIVE, 1e-320, f64::MAX];

        let power = |rng: &mut rand_chacha::ChaCha8Rng| {
            let exponents = if rng.random_bool(0.5) { -1100..1100 } else { -4..4 };
            2f64.powi(rng.random_range(exponents))
        };
        let (scale, speed) = (power(rng), power(rng));
        let mut unit =
            || DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let (along, across) = (unit(), unit());
        let radius = scale * rng.random_range(0.25..2.0);
        let mut s = *near;
        match rng.random_range(0..8) {
            // A path grazing `near`'s at its radius sum, or passing at a random distance.
            0 | 1 => {
                let unit = direction(along).unwrap_or(DVec3::X);
                let side = direction(unit.any_orthonormal_vector()).expect("unit");
                let sum = near.radius + radius;
                let miss = if rng.random_bool(0.5) {
                    1.0 + rng.random_range(-1e-11..1e-11)
                } else {
                    rng.random_range(0.0..3.0)
                };
                s.motion.position = near.motion.at(s.motion.since) + side * (miss * sum) - unit * (scale * 8.0);
                s.motion.velocity = near.motion.velocity + unit * speed;
            }
            // The same velocity (no relative motion), at some distance or touching.
            2 => {
                let d =
                    direction(along).unwrap_or(DVec3::X) * (near.radius + radius) * [1.0, 3.0][rng.random_range(0..2)];
                s.motion.position = near.motion.at(s.motion.since) + d;
            }
            // Touching or overlapping, moving.
            3 => {
                let d = direction(along).unwrap_or(DVec3::X) * (near.radius + radius) * rng.random_range(0.5..1.0);
                s.motion.position = near.motion.at(s.motion.since) + d;
                s.motion.velocity = across * speed;
            }
            // Anywhere, any motion, another start.
            4 | 5 => {
                s.motion = Motion {
                    position: along * scale * 100.0,
                    since: rng.random_range(-2.0..2.0),
                    velocity: across * speed,
                };
            }
            // A special value in one coordinate.
            _ => {
                let value = special[rng.random_range(0..special.len())];
                match rng.random_range(0..5) {
                    0 => s.motion.position[rng.random_range(0..3)] = value,
                    1 => s.motion.velocity[rng.random_range(0..3)] = value,
                    2 => s.motion.since = value,
                    3 => s.radius = value,
                    _ => s.motion.velocity = near.motion.velocity,
                }
                return s;
            }
        }
        s.radius = radius;
        s
    }

    /// The four-lane screen against the scalar one, lane by lane, where the verdict is hard:
    /// grazing paths (miss distance within a few ulps of R), equal velocities, touching and
    /// overlapping spheres, tiny and huge scales (past the guards), signed zeros, NaN and
    /// infinities, and either `since` the later.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_screen_in_lanes_clears_what_the_scalar_screen_clears() {
        use rand::SeedableRng;
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
        let origin = BodyState::default();
        let (mut cleared, mut kept) = (0, 0);
        for _ in 0..200_000 {
            let a: [BodyState; 4] = std::array::from_fn(|_| hard_state(&mut rng, &origin));
            let b: [BodyState; 4] = std::array::from_fn(|k| hard_state(&mut rng, &a[k]));
            // SAFETY: AVX was detected above.
            let lanes = unsafe { straight_paths_clearly_miss_four(a.each_ref(), b.each_ref()) };
            for (k, (a, b)) in a.iter().zip(&b).enumerate() {
                let scalar = straight_paths_clearly_miss(&a.motion, &b.motion, a.radius + b.radius);
                assert_eq!(lanes >> k & 1 == 1, scalar, "a {a:?} b {b:?}");
                (cleared, kept) = if scalar { (cleared + 1, kept) } else { (cleared, kept + 1) };
            }
        }
        // Both verdicts met often, not one alone.
        assert!(cleared > 50_000 && kept > 50_000, "cleared {cleared} kept {kept}");
    }

    /// The four-lane exact test against the scalar one, lane by lane and to the bit, on the
    /// screen's hard pairs (grazing, equal velocities, touching and overlapping, tiny and huge
    /// scales, special values), in windows that hold the scalar's time, end at it, start just
    /// after it, hold everything or are NaN; and the scalar one the same whichever body comes
    /// first.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_exact_test_in_lanes_answers_as_the_scalar_test() {
        use crate::window::Window;
        use rand::{Rng, SeedableRng};
        use std::arch::x86_64::_mm256_loadu_pd;
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
        let origin = BodyState::default();
        let bits = |time: Option<f64>| time.map(f64::to_bits);
        let (mut contacts, mut kept, mut outside) = (0, 0, 0);
        for _ in 0..200_000 {
            let a: [BodyState; 4] = std::array::from_fn(|_| hard_state(&mut rng, &origin));
            let b: [BodyState; 4] = std::array::from_fn(|k| hard_state(&mut rng, &a[k]));
            let scalar: [Option<f64>; 4] = std::array::from_fn(|k| {
                straight_pair_contact_time_past_screen(&a[k].motion, &b[k].motion, a[k].radius + b[k].radius)
            });
            let windows: [Window; 4] = std::array::from_fn(|k| {
                let t = scalar[k].unwrap_or(1.0);
                let (start, end) = match rng.random_range(0..6) {
                    0 => (f64::NEG_INFINITY, f64::INFINITY),
                    1 => (t, t.next_up()),
                    2 => (t.next_down(), t),
                    3 => (t.next_up(), t + t.abs() + 1.0),
                    4 => (t - t.abs() - 1.0, t + t.abs() + 1.0),
                    _ => (f64::NAN, t.next_up()),
                };
                Window { start, end }
            });
            let (starts, ends) = (windows.map(|w| w.start), windows.map(|w| w.end));
            // SAFETY: AVX was detected above; four floats each.
            let (events, times) = unsafe {
                let columns = [_mm256_loadu_pd(starts.as_ptr()), _mm256_loadu_pd(ends.as_ptr())];
                straight_pair_contact_times_four(a.each_ref(), b.each_ref(), columns)
            };
            for (k, (a, b)) in a.iter().zip(&b).enumerate() {
                let swapped = straight_pair_contact_time_past_screen(&b.motion, &a.motion, b.radius + a.radius);
                let event = scalar[k].filter(|&t| windows[k].contains(t));
                let lane = (events >> k & 1 == 1).then_some(times[k]);
                assert_eq!(bits(lane), bits(event), "a {a:?} b {b:?} window {:?}", windows[k]);
                assert_eq!(bits(swapped), bits(scalar[k]), "a {a:?} b {b:?}");
                contacts += usize::from(scalar[k].is_some());
                outside += usize::from(scalar[k].is_some() && event.is_none());
                kept += usize::from(!straight_paths_clearly_miss(&a.motion, &b.motion, a.radius + b.radius));
            }
        }
        // Contacts met often, inside and outside their windows, among pairs the screen keeps.
        assert!(contacts > 30_000 && outside > 10_000 && kept > 100_000, "contacts {contacts} kept {kept}");
        // Pairs closing at about the noise's threshold, 2^-30 to 2^-50 of their own speeds, at
        // scales from tiny to huge: the lanes' noise check, asked or skipped, as the scalar's.
        let (mut noise, mut moving) = (0, 0);
        for _ in 0..20_000 {
            let pair = |rng: &mut rand_chacha::ChaCha8Rng| {
                let (scale, speed) =
                    (2f64.powi(rng.random_range(-1000..1000)), 2f64.powi(rng.random_range(-1000..1000)));
                let along =
                    DVec3::new(rng.random_range(0.5..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                let closing = speed * 2f64.powi(-rng.random_range(30..50)) * rng.random_range(1.0..2.0);
                let mut a = BodyState { radius: scale, ..BodyState::default() };
                a.motion.velocity = along * speed;
                let mut b = a;
                b.motion.position = DVec3::X * (scale * 3.0);
                b.motion.velocity = a.motion.velocity - DVec3::X * closing;
                (a, b)
            };
            let pairs: [(BodyState, BodyState); 4] = std::array::from_fn(|_| pair(&mut rng));
            let (a, b) = (pairs.map(|p| p.0), pairs.map(|p| p.1));
            let (starts, ends) = ([f64::NEG_INFINITY; 4], [f64::INFINITY; 4]);
            // SAFETY: AVX was detected above; four floats each.
            let (events, times) = unsafe {
                let everything = [_mm256_loadu_pd(starts.as_ptr()), _mm256_loadu_pd(ends.as_ptr())];
                straight_pair_contact_times_four(a.each_ref(), b.each_ref(), everything)
            };
            for k in 0..4 {
                let scalar =
                    straight_pair_contact_time_past_screen(&a[k].motion, &b[k].motion, a[k].radius + b[k].radius);
                let lane = (events >> k & 1 == 1).then_some(times[k]);
                assert_eq!(bits(lane), bits(scalar), "a {:?} b {:?}", a[k], b[k]);
                moving += usize::from(scalar.is_some());
                noise += usize::from(scalar.is_none());
            }
        }
        assert!(noise > 10_000 && moving > 10_000, "noise {noise} moving {moving}");
    }

    #[test]
    fn head_on_and_miss() {
        let t = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 1.0);
        assert_eq!(t, Some(2.0));
        let miss = sphere_sphere_time(DVec3::new(3.0, 1.5, 0.0), DVec3::new(-1.0, 0.0, 0.0), 1.0);
        assert_eq!(miss, None);
        let receding = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), 1.0);
        assert_eq!(receding, None);
    }

    #[test]
    fn touching_at_start_counts_only_when_approaching() {
        let touching = DVec3::new(2.0, 0.0, 0.0);
        assert_eq!(sphere_sphere_time(touching, DVec3::new(-1.0, 0.0, 0.0), 2.0), Some(0.0));
        assert_eq!(sphere_sphere_time(touching, DVec3::new(1.0, 0.0, 0.0), 2.0), None);
        // Deep overlap is not a new contact (bodies passing through in detect mode).
        let deep = DVec3::new(1.0, 0.0, 0.0);
        assert_eq!(sphere_sphere_time(deep, DVec3::new(-1.0, 0.0, 0.0), 2.0), None);
    }

    #[test]
    fn grazing_contact_is_found_at_the_closest_approach() {
        // Passes at distance exactly R: touches once, at the closest approach t = 5.
        let t = sphere_sphere_time(DVec3::new(5.0, 2.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 2.0);
        assert_eq!(t, Some(5.0));
        let just_misses = sphere_sphere_time(DVec3::new(5.0, 2.0 + 1e-9, 0.0), DVec3::new(-1.0, 0.0, 0.0), 2.0);
        assert_eq!(just_misses, None);
    }

    #[test]
    fn far_from_origin_and_very_fast() {
        // 500 diameters per frame, a million units from the origin.
        let base = DVec3::splat(1.0e6);
        let b = base + DVec3::new(400.0, 0.3, 0.0);
        let t = sphere_sphere_time(b - base, DVec3::new(-500.0, 0.0, 0.0), 1.0).expect("contact");
        let expected = (400.0 - (1.0f64 - 0.09).sqrt()) / 500.0;
        assert!((t - expected).abs() <= 1e-12, "{t} vs {expected}");
    }

    #[test]
    fn nearly_parallel_motion_is_stable() {
        // Relative speed 1e-12: the contact lies 1e12 time units away, and nothing divides by ~0.
        let t = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(-1e-12, 0.0, 0.0), 2.0).unwrap();
        assert!((t - 1e12).abs() < 1e-3, "{t}");
        let t = sphere_sphere_time(DVec3::new(2.0 + 1e-13, 0.0, 0.0), DVec3::new(-1e-12, 0.0, 0.0), 2.0).unwrap();
        assert!((t - 0.1).abs() < 1e-3, "{t}");
    }

    #[test]
    fn scaling_by_powers_of_two_is_exact_at_both_ends_of_the_range() {
        let offset = DVec3::new(7.25, 1.5, -0.375);
        let velocity = DVec3::new(-3.0, -0.5, 0.25);
        let unit = sphere_sphere_time(offset, velocity, 1.75).unwrap();
        for exponent in [-1000, -500, -160, 160, 500] {
            let s = 2f64.powi(exponent);
            // Same velocity, lengths scaled: the time scales exactly.
            let scaled = sphere_sphere_time(offset * s, velocity, 1.75 * s).unwrap();
            assert_eq!(scaled, unit * s, "2^{exponent}");
            // Same lengths, velocity scaled: the time scales inversely.
            if exponent.abs() <= 500 {
                let slow = sphere_sphere_time(offset, velocity * s, 1.75).unwrap();
                assert_eq!(slow, unit / s, "2^{exponent}");
            }
        }
        assert!((direction(DVec3::new(1e-320, 0.0, 0.0)).unwrap().x - 1.0).abs() < 1e-15);
        assert!(direction(DVec3::new(0.0, 1e300, 1e300)).unwrap().y > 0.7);
        assert_eq!(direction(DVec3::ZERO), None);
    }

    #[test]
    fn pair_time_does_not_depend_on_who_asks() {
        // Body b changed velocity at 0.7; the pair's time is computed from 0.7 whatever frame asks.
        let a = Motion { position: DVec3::new(0.0, 0.0, 0.0), since: 0.0, velocity: DVec3::new(1.0, 0.0, 0.0) };
        let b = Motion { position: DVec3::new(5.0, 0.0, 0.0), since: 0.7, velocity: DVec3::new(-1.0, 0.0, 0.0) };
        let t = pair_contact_time(&a, &b, 1.0, (DVec3::ZERO, DVec3::ZERO)).unwrap();
        // At 0.7, a is at 0.7: the gap 5 - 0.7 - 1 closes at 2.
        assert_eq!(t, 0.7 + (5.0 - 0.7 - 1.0) / 2.0);
        // Moving together exactly (relative velocity noise only): no contact.
        let c = Motion { velocity: DVec3::new(1.0 + 1e-15, 0.0, 0.0), ..b };
        let d = Motion { position: DVec3::new(3.0, 0.0, 0.0), ..a };
        let moved = Motion { position: DVec3::new(4.0, 0.0, 0.0), ..c };
        assert_eq!(pair_contact_time(&d, &moved, 1.0, (DVec3::ZERO, DVec3::ZERO)), None);
    }

    #[test]
    fn walls() {
        let (min, max) = (DVec3::ZERO, DVec3::splat(10.0));
        let at = |p: DVec3, v: DVec3| Motion { position: p, since: 0.0, velocity: v };
        let r =
            wall_contact_time(&at(DVec3::new(1.0, 5.0, 5.0), DVec3::new(-1.0, 0.0, 0.0)), 1.0, min, max, DVec3::ZERO);
        assert_eq!(r, Some((0.0, Wall::MinX)));
        let r =
            wall_contact_time(&at(DVec3::new(5.0, 5.0, 8.0), DVec3::new(0.0, 0.0, 2.0)), 1.0, min, max, DVec3::ZERO);
        assert_eq!(r, Some((0.5, Wall::MaxZ)));
        assert_eq!(wall_contact_time(&at(DVec3::splat(5.0), DVec3::ZERO), 1.0, min, max, DVec3::ZERO), None);
        assert_eq!(Wall::MaxY.outward_normal(), DVec3::Y);
        assert_eq!(Wall::new(2, false), Wall::MinZ);
        assert_eq!(Wall::MinZ.to_string(), "min-z");
    }

    /// The contact time in its first, plainer form: the early rejections must give the same bits
    /// on every input (as must the straight wall time's selects against the general loop).
    fn plain_scaled_time(offset: DVec3, relative_velocity: DVec3, radius_sum: f64) -> Option<f64> {
        let approach = offset.dot(relative_velocity);
        let speed_sq = relative_velocity.length_squared();
        let threshold = -APPROACH_TOLERANCE * (offset.length_squared() * speed_sq).sqrt();
        if !(approach < threshold) {
            return None;
        }
        let radius_sq = radius_sum * radius_sum;
        let gap = offset.length_squared() - radius_sq;
        if gap <= 0.0 {
            return (gap >= -2.0 * CONTACT_TOLERANCE * radius_sq).then_some(0.0);
        }
        let discriminant = speed_sq * radius_sq - offset.cross(relative_velocity).length_squared();
        if discriminant < 0.0 {
            return None;
        }
        Some(gap / (-approach + discriminant.sqrt()))
    }

    /// Random, grazing, touching, overlapping, receding, at-rest and non-finite inputs.
    #[test]
    fn early_rejections_and_selects_change_no_result() {
        let mut state = 0x9e3779b97f4a7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let special = [0.0, -0.0, 1.0, -1.0, 2.0, 1e-300, -1e300, f64::INFINITY, f64::NAN, 0.5];
        for k in 0..200_000 {
            let mut pick = || {
                if k % 7 == 0 {
                    special[(next() * special.len() as f64) as usize % special.len()]
                } else {
                    (next() - 0.5) * [4.0, 1e-3, 1e3][k % 3]
                }
            };
            let (offset, velocity) = (DVec3::new(pick(), pick(), pick()), DVec3::new(pick(), pick(), pick()));
            let radius = 1.0 + (k % 5) as f64 * 0.25;
            // A pair grazing at exactly the radius sum, or touching, now and then.
            let offset = match k % 11 {
                0 => DVec3::new(offset.x, radius, 0.0),
                1 => offset.normalize_or_zero() * radius,
                _ => offset,
            };
            let (a, b) = (scaled_time(offset, velocity, radius), plain_scaled_time(offset, velocity, radius));
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{offset} {velocity} {radius}");
            let motion = Motion { position: offset.abs() * 3.0, since: pick(), velocity };
            let (min, max) = (DVec3::ZERO, DVec3::new(10.0, f64::INFINITY, 7.0));
            let found = wall_contact_time(&motion, 0.5, min, max, DVec3::ZERO);
            let plain = any_wall_time(&motion, 0.5, min, max, DVec3::ZERO);
            assert_eq!(found.map(|(t, w)| (t.to_bits(), w)), plain.map(|(t, w)| (t.to_bits(), w)), "{motion:?}");
        }
    }
}
