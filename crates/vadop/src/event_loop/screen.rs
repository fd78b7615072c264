//! The search's cheap screen before the exact test (see [`super::search`]): from the two centres
//! at the current instant, a pair moving apart, missing each other or unable to touch before the
//! best event found so far is skipped, with margins far wider than the rounding of the screen
//! (and the screen off in a world whose coordinates are too large for its smallest bodies to
//! trust them), so the screen never skips a pair the exact test would schedule.
//!
//! It owns the screen's margins and when they are trusted, the searching body as the screen sees
//! it ([`Own`]), and the screen itself: of one partner, and of four at a time in AVX lanes, the
//! same bits; and for a pair sure to touch, that its relative velocity is no rounding noise to the
//! exact test (see [`NOISE`]), which then skips its own check of it. It never computes a contact
//! time nor changes a body.

use crate::bodies::BodyState;
use glam::DVec3;
use std::mem::MaybeUninit;

/// A pair whose approach rate is below this fraction of |offset| |relative velocity| counts as
/// moving apart (the exact test's own threshold is 1e-12, on the negative side).
const RECEDING: f64 = 1e-6;
/// The screen's slack on a gap (relative to the radius sum squared, and to the offset squared)
/// and on a time bound (relative): all far above its rounding (see [`screen_trusted`]).
const GAP_SLACK: f64 = 1e-6;
const OFFSET_SLACK: f64 = 1e-12;
const TIME_SLACK: f64 = 1e-4;
/// A pair whose relative speed squared is below this fraction of the sum of the two speeds
/// squared may be rounding noise to the exact test (its own rule is 10^-12 of the sum of the
/// speeds): it never bounds the screen.
///
/// A pair sure to touch is above it, and is then *moving*: the exact test's noise rule
/// ([`NOISE_VELOCITY`](crate::narrow_phase::spheres::NOISE_VELOCITY)) cannot hold for it, so
/// the test skips it, the same bits. Why: write V = |v|^2 (v = vb - va) and S = |va|^2 + |vb|^2,
/// true values. The rule holds only where |v| <= 1.0001e-12 (|va| + |vb|) (its bound in true
/// values, stated there), so where V <= 1.0001e-24 (|va| + |vb|)^2 <= 2.0002e-24 S. The screen's
/// V and S (sums of squares of the same velocities) are each within 8 roundings plus 4 * 2^-1074
/// of the true ones; where S >= 2^-1000 that is far below the gap between 10^-16 S and
/// 2.0002e-24 S, so the screen's V is not above `NOISE` times its S; where S < 2^-1000, V is
/// below 2^-1078, every component of v below 2^-539, their squares round to zero, the screen's V
/// is zero and not above it either. (An overflow makes S infinite, which nothing is above, or
/// V infinite, which the rule cannot call noise; a NaN fails every comparison.)
const NOISE: f64 = 1e-16;
/// The screen is trusted when this many roundings of the largest coordinate are within
/// `1e-11` of the smallest radius.
pub(super) const ROUNDINGS: f64 = 16.0;
const TRUSTED: f64 = 1e-11;

/// True when centres computed at the current instant are accurate enough, in a box whose
/// coordinates reach `scale`, for the screen's margins to hold for radii of at least `radius`:
/// their rounding is then below 10^-11 of the smallest radius, the margins at least 10^-6 of it.
pub(super) fn screen_trusted(scale: f64, radius: f64) -> bool {
    ROUNDINGS * f64::EPSILON * scale <= TRUSTED * radius
}

/// Body `p` as its partners are screened against it, at `now`.
#[derive(Clone, Copy)]
pub(super) struct Own {
    pub p: usize,
    pub position: DVec3,
    pub velocity: DVec3,
    pub radius: f64,
    pub now: f64,
    /// Rounding of a time near `now`, relative to it: times compared as offsets from `now`
    /// allow for it.
    pub rounding: f64,
}

/// The screen of the body of `state` as `own`'s partner, its centre less `origin` (`own`'s,
/// shifted to its image) as its offset: `None` when it can be skipped (moving apart from `own`,
/// passing wide of it, or unable to touch it within `bound` of `own.now`), else a lower bound on
/// when it can touch, after `own.now` (minus infinity when there is none to trust, as for a pair
/// touching now), and whether it is moving (see [`NOISE`]). A pair sure to touch lowers `bound`
/// to an upper bound on when it does, and is moving. Every
/// bound allows for the rounding of the offsets (see [`screen_trusted`]): |offset|^2 falls no
/// faster than 2 |approach| per unit time at first, and the paths' closest approach is where the
/// discriminant says, to its slack.
#[inline(always)]
pub(super) fn screen(own: &Own, state: &BodyState, origin: DVec3, bound: &mut f64) -> Option<(f64, bool)> {
    let motion = &state.motion;
    // Written per component: the vector types' shuffles cost more than the arithmetic here.
    let (p, v, dt) = (motion.position, motion.velocity, own.now - motion.since);
    let (ox, oy, oz) = (p.x + dt * v.x - origin.x, p.y + dt * v.y - origin.y, p.z + dt * v.z - origin.z);
    let (vx, vy, vz) = (v.x - own.velocity.x, v.y - own.velocity.y, v.z - own.velocity.z);
    let approach = ox * vx + oy * vy + oz * vz;
    let (d2, v2) = (ox * ox + oy * oy + oz * oz, vx * vx + vy * vy + vz * vz);
    // |approach| clear of 10^-6 |offset| |velocity|: its sign is sure.
    let clear = approach * approach > RECEDING * RECEDING * d2 * v2;
    if approach > 0.0 {
        return if clear { None } else { Some((f64::NEG_INFINITY, false)) };
    }
    let reach = own.radius + state.radius;
    let gap = d2 - reach * reach;
    let slack = GAP_SLACK * reach * reach + OFFSET_SLACK * d2;
    if !(clear && gap > slack) {
        return Some((f64::NEG_INFINITY, false));
    }
    let closing = -approach;
    bounded(own, (gap - slack, 2.0 * closing), bound, || {
        let discriminant = approach * approach - v2 * gap;
        let spread = slack * v2;
        if discriminant < -spread {
            return None;
        }
        let earliest = (gap - slack) / (closing * (1.0 + TIME_SLACK) + (discriminant + spread).sqrt())
            * (1.0 - TIME_SLACK)
            - own.rounding;
        // Sure to touch (the exact test's noise rule aside: far faster than rounding noise), and
        // after now: the contact comes by `latest` at the latest.
        let sure = discriminant > spread
            && earliest > 0.0
            && v2 > NOISE * (own.velocity.length_squared() + motion.velocity.length_squared());
        let latest = || {
            (gap + slack) / (closing * (1.0 - TIME_SLACK) + (discriminant - spread).sqrt()) * (1.0 + TIME_SLACK)
                + own.rounding
        };
        Some((earliest, sure.then(latest)))
    })
}

/// The steps of [`screen`] that depend on `bound`, for a pair approaching with its gap clear of
/// the slack: `late` the gap less the slack, `rate` twice the closing rate; `rest` the earliest
/// it can touch (none when the paths pass wide) and the latest when it is sure to (then it is
/// moving).
#[inline(always)]
fn bounded(
    own: &Own,
    (late, rate): (f64, f64),
    bound: &mut f64,
    rest: impl FnOnce() -> Option<(f64, Option<f64>)>,
) -> Option<(f64, bool)> {
    if late > rate * (*bound + own.rounding) * (1.0 + TIME_SLACK) {
        return None;
    }
    let (earliest, latest) = rest()?;
    if earliest > *bound {
        return None;
    }
    if let Some(latest) = latest {
        *bound = bound.min(latest);
    }
    Some((earliest, latest.is_some()))
}

/// True when [`screen`] can run four partners at a time (see [`screen_four_avx`]).
#[inline]
pub(super) fn lanes() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

/// [`screen`] of four partners up to its steps that depend on the bound (see [`screen_four_avx`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Four {
    /// The lanes left, one a bit (lane `k` the `k`-th partner's): those not rejected whatever
    /// the bound (moving apart, passing wide, or unable to touch within the bound given, which
    /// only falls along a search).
    pub left: u32,
    /// Of those, the lanes bounded by it (approaching, the gap clear of the slack: [`bounded`]'s
    /// values follow); the others have no bound to trust, and are not moving.
    bounded: u32,
    /// Of those, the lanes sure to touch, by `latest`.
    sure: u32,
    /// Per lane: `late`, `rate`, `earliest` and `latest`, written only when a lane is bounded:
    /// most groups have none, and return without the four arrays' stores (or a zero fill).
    values: MaybeUninit<[[f64; 4]; 4]>,
}

impl Four {
    /// [`screen`]'s answer for lane `lane`, one of those left, with the bound as it stands.
    #[inline(always)]
    pub(super) fn lane(&self, lane: usize, own: &Own, bound: &mut f64) -> Option<(f64, bool)> {
        let bit = 1 << lane;
        if self.bounded & bit == 0 {
            return Some((f64::NEG_INFINITY, false));
        }
        // SAFETY: a lane is bounded only once the values are written.
        let [late, rate, earliest, latest] = unsafe { self.values.assume_init_ref() };
        let latest = (self.sure & bit != 0).then_some(latest[lane]);
        bounded(own, (late[lane], rate[lane]), bound, || Some((earliest[lane], latest)))
    }
}

/// Four partners of a search in a row, as the lanes read them: each one's body and the origin
/// its offset is taken from.
pub(super) trait Partners {
    /// Lane `lane`'s body.
    fn body(&self, lane: usize) -> usize;
    /// Lane `lane`'s body's record, of `states` (those the search reads).
    #[inline(always)]
    fn state<'s>(&self, states: &'s [BodyState], lane: usize) -> &'s BodyState {
        &states[self.body(lane)]
    }
    /// The origin of lane `lane`'s offset.
    fn origin(&self, lane: usize) -> DVec3;
    /// The origin of all four lanes when they share it (met through one cell or one image, as
    /// most groups away from the faces are): one value read once, where four are built and
    /// gathered into lanes.
    fn shared_origin(&self) -> Option<DVec3>;
}

/// [`screen_four_avx`] behind the check for AVX: one group alone, the lanes' unit test's (the
/// searches screen their groups through [`screen_fours`]).
#[cfg(test)]
pub(super) fn screen_four(own: &Own, states: &[BodyState], partners: &impl Partners, bound: f64) -> Four {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: asked only where `lanes` found AVX.
    return unsafe { screen_four_avx(own, states, partners, bound) };
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (own, states, partners, bound);
        unreachable!("lanes are x86-64's: `lanes` is false elsewhere")
    }
}

/// [`screen_four_avx`] of the groups of four partners in a row, `partners(group)` each one's
/// partners: the lanes each group leaves, taken in order with `bound` as it stands (as
/// [`Four::lane`] answers them), `keep(group, lane, (earliest, moving))` for each that passes.
/// Asked only where [`lanes`] holds.
///
/// One call for all the groups of a search, inside which the lanes' screen is inlined: called
/// once a group from code without AVX, which cannot inline it, it cost the call's saving and
/// restoring of registers, about twenty instructions a group. The groups come as a slice of
/// fours walked by its iterator, `keep` handed the group itself: taken by index, as before,
/// each group cost a check of its slice's bounds, and each lane kept another (BENCHMARKS.md,
/// twenty-fifth session).
#[inline]
pub(super) fn screen_fours<'a, G, P: Partners>(
    own: &Own,
    states: &[BodyState],
    groups: &'a [G],
    partners: impl Fn(&'a G) -> P,
    bound: &mut f64,
    keep: impl FnMut(&'a G, usize, (f64, bool)),
) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: asked only where `lanes` found AVX.
    return unsafe { screen_fours_avx(own, states, groups, partners, bound, keep) };
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (own, states, groups, partners, bound, keep);
        unreachable!("lanes are x86-64's: `lanes` is false elsewhere")
    }
}

/// [`screen_fours`] in AVX's registers (to be called only where the processor has AVX).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn screen_fours_avx<'a, G, P: Partners>(
    own: &Own,
    states: &[BodyState],
    groups: &'a [G],
    partners: impl Fn(&'a G) -> P,
    bound: &mut f64,
    mut keep: impl FnMut(&'a G, usize, (f64, bool)),
) {
    for group in groups {
        let four = screen_four_avx(own, states, &partners(group), *bound);
        let mut left = four.left;
        while left != 0 {
            let lane = left.trailing_zeros() as usize;
            left &= left - 1;
            if let Some(screened) = four.lane(lane, own, bound) {
                keep(group, lane, screened);
            }
        }
    }
}

/// [`screen`] of four partners of `own` up to its steps that depend on the bound, `bound` as it
/// stands before the first. Asked only where [`lanes`] holds.
///
/// The partners' records (from `states`) and origins are read inside the lanes' function, one
/// function for every kind of partners: copied into arrays to be handed over, they cost a group
/// about a third as many instructions again as the screen.
///
/// Each lane makes the scalar screen's operations in its order on the same floats, without FMA
/// (AVX alone; division and square root are correctly rounded in both), so its floats are the
/// scalar's bits; every comparison is ordered, as the scalar's, so a NaN falls the same way. A
/// lane rejected by the bound as it stands is rejected by any lower one, which the scalar screen
/// would meet later in the search.
///
/// In AVX's four-wide registers: to be called only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn screen_four_avx(own: &Own, states: &[BodyState], partners: &impl Partners, bound: f64) -> Four {
    use crate::narrow_phase::spheres::state_columns;
    use std::arch::x86_64::*;
    let states: [&BodyState; 4] = std::array::from_fn(|lane| partners.state(states, lane));
    let ([px, py, pz, since], [vx, vy, vz, radius]) = (state_columns(states, 0), state_columns(states, 1));
    let one = |value: f64| _mm256_set1_pd(value);
    let (add, sub, mul) = (|x, y| _mm256_add_pd(x, y), |x, y| _mm256_sub_pd(x, y), |x, y| _mm256_mul_pd(x, y));
    let (greater, less, and, or) = (
        |x, y| _mm256_cmp_pd::<_CMP_GT_OQ>(x, y),
        |x, y| _mm256_cmp_pd::<_CMP_LT_OQ>(x, y),
        |x, y| _mm256_and_pd(x, y),
        |x, y| _mm256_or_pd(x, y),
    );
    let mask = |x| _mm256_movemask_pd(x) as u32;
    // A negation flips the sign bit alone, as the scalar `-x` does.
    let negated = |x| _mm256_xor_pd(x, one(-0.0));
    // The origins' columns: the same floats either way.
    let [origin_x, origin_y, origin_z] = match partners.shared_origin() {
        Some(origin) => [one(origin.x), one(origin.y), one(origin.z)],
        None => {
            let origins: [DVec3; 4] = std::array::from_fn(|lane| partners.origin(lane));
            [0, 1, 2].map(|axis| _mm256_set_pd(origins[3][axis], origins[2][axis], origins[1][axis], origins[0][axis]))
        }
    };
    // `screen`, line by line.
    let dt = sub(one(own.now), since);
    let ox = sub(add(px, mul(dt, vx)), origin_x);
    let oy = sub(add(py, mul(dt, vy)), origin_y);
    let oz = sub(add(pz, mul(dt, vz)), origin_z);
    let (rx, ry, rz) = (sub(vx, one(own.velocity.x)), sub(vy, one(own.velocity.y)), sub(vz, one(own.velocity.z)));
    let approach = add(add(mul(ox, rx), mul(oy, ry)), mul(oz, rz));
    let d2 = add(add(mul(ox, ox), mul(oy, oy)), mul(oz, oz));
    let v2 = add(add(mul(rx, rx), mul(ry, ry)), mul(rz, rz));
    let clear = greater(mul(approach, approach), mul(mul(one(RECEDING * RECEDING), d2), v2));
    let apart = greater(approach, one(0.0));
    let reach = add(one(own.radius), radius);
    let gap = sub(d2, mul(reach, reach));
    let slack = add(mul(mul(one(GAP_SLACK), reach), reach), mul(one(OFFSET_SLACK), d2));
    // Not apart (a NaN approach is not clear), clear, and the gap past the slack.
    let screened = and(_mm256_andnot_pd(apart, clear), greater(gap, slack));
    let closing = negated(approach);
    let (late, rate) = (sub(gap, slack), mul(one(2.0), closing));
    let too_late = greater(late, mul(mul(rate, one(bound + own.rounding)), one(1.0 + TIME_SLACK)));
    let discriminant = sub(mul(approach, approach), mul(v2, gap));
    let spread = mul(slack, v2);
    let wide = less(discriminant, negated(spread));
    let rejected = or(and(apart, clear), and(screened, or(too_late, wide)));
    let mut four = Four {
        left: mask(rejected) ^ 0b1111,
        bounded: mask(_mm256_andnot_pd(rejected, screened)),
        sure: 0,
        values: MaybeUninit::uninit(),
    };
    if four.bounded == 0 {
        return four;
    }
    let earliest = sub(
        mul(
            _mm256_div_pd(late, add(mul(closing, one(1.0 + TIME_SLACK)), _mm256_sqrt_pd(add(discriminant, spread)))),
            one(1.0 - TIME_SLACK),
        ),
        one(own.rounding),
    );
    let latest = add(
        mul(
            _mm256_div_pd(
                add(gap, slack),
                add(mul(closing, one(1.0 - TIME_SLACK)), _mm256_sqrt_pd(sub(discriminant, spread))),
            ),
            one(1.0 + TIME_SLACK),
        ),
        one(own.rounding),
    );
    let speed_squared = add(add(mul(vx, vx), mul(vy, vy)), mul(vz, vz));
    let noise = mul(one(NOISE), add(one(own.velocity.length_squared()), speed_squared));
    four.sure = mask(and(and(greater(discriminant, spread), greater(earliest, one(0.0))), greater(v2, noise)));
    // SAFETY (each store): four floats into four; then every value is written.
    unsafe {
        let values = four.values.as_mut_ptr().cast::<[f64; 4]>();
        for (k, column) in [late, rate, earliest, latest].into_iter().enumerate() {
            _mm256_storeu_pd(values.add(k).cast::<f64>(), column);
        }
    }
    four
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Motion;
    use crate::narrow_phase::contacts::screened_spheres_start;
    use crate::window::Window;
    use rand::{Rng, SeedableRng};

    /// A pair the screen finds moving gets the exact test's answer without its noise rule, the
    /// same bits as with it (see [`NOISE`]): head-on pairs whose relative speed runs from 10^-17
    /// of their speeds (rounding noise to the exact test) to their size, at speeds from 10^-300
    /// to 10^300 (where the screen's squares underflow or overflow).
    #[test]
    fn a_moving_pair_s_exact_test_needs_no_noise_rule() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(25);
        let window = Window::new(0.0, f64::INFINITY);
        // Pairs found moving, and pairs not moving that the noise rule rejects.
        let (mut moving, mut noise) = (0, 0);
        for round in 0..200_000 {
            let speed = 10f64.powf(rng.random_range(-300.0..300.0));
            let velocity = DVec3::from_array([(); 3].map(|_| rng.random_range(-1.0..1.0))) * speed;
            let relative = -DVec3::X * speed * 10f64.powf(rng.random_range(-17.0..0.0));
            let own = Own { p: 0, position: DVec3::ZERO, velocity, radius: 0.5, now: 0.0, rounding: 0.0 };
            let at = |position, velocity| BodyState { motion: Motion { position, since: 0.0, velocity }, radius: 0.5 };
            let (mine, partner) =
                (at(own.position, velocity), at(DVec3::X * rng.random_range(1.001..3.0), velocity + relative));
            let mut bound = f64::INFINITY;
            let with_rule = screened_spheres_start(&mine, &partner, window, false);
            match screen(&own, &partner, own.position, &mut bound) {
                Some((_, true)) => {
                    moving += 1;
                    assert_eq!(screened_spheres_start(&mine, &partner, window, true), with_rule, "round {round}");
                }
                _ => {
                    noise += usize::from(
                        with_rule.is_none() && screened_spheres_start(&mine, &partner, window, true).is_some(),
                    )
                }
            }
        }
        assert!(moving > 10_000 && noise > 1_000, "moving {moving}, rejected as noise {noise}");
    }
}
