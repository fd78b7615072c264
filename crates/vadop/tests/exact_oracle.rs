//! An oracle that shares nothing with the engine: exact rational arithmetic on small detect-mode
//! scenes, over the whole run at once instead of frame by frame.
//!
//! Every body's path (straight lines between exact wall bounces) and every pair's contacts are
//! computed with `num-rational`, each contact's time compared with the frame boundaries by exact
//! sign tests. Each method, the brute-force one included, must report every contact exactly
//! once, in the frame `[t_k, t_k+1)` that holds its time; a contact within rounding of a
//! boundary may fall on either side, but never on both. Boundary cases are built on purpose: the
//! frame-boundary duplicate that the engine and the old oracle shared is the regression here.

mod common;

use common::random_direction;
use glam::DVec3;
use num_rational::BigRational;
use num_traits::{Signed, Zero};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vadop::scene::Scene;
use vadop::{BoxBounds, Method, Mode, Sphere, Touched, WorldConfig};

type Q = BigRational;

fn q(x: f64) -> Q {
    BigRational::from_float(x).expect("finite")
}

fn dot(a: &[Q; 3], b: &[Q; 3]) -> Q {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

/// A stretch of a body's exact path: from `start` on it is at `position + (t - start) velocity`.
#[derive(Clone)]
struct Segment {
    start: Q,
    position: [Q; 3],
    velocity: [Q; 3],
}

/// Exact path of one body from 0 to `end`, bouncing elastically off the walls (the lowest axis
/// first when several are reached at once), and its wall contacts.
fn exact_path(s: &Sphere, bounds: &BoxBounds, end: &Q) -> (Vec<Segment>, Vec<Q>) {
    let r = q(s.radius);
    let low = bounds.min.to_array().map(|x| q(x) + &r);
    let high = bounds.max.to_array().map(|x| q(x) - &r);
    let mut segment =
        Segment { start: Q::zero(), position: s.position.to_array().map(q), velocity: s.velocity.to_array().map(q) };
    let mut segments = Vec::new();
    let mut walls = Vec::new();
    loop {
        let mut best: Option<(Q, usize)> = None;
        for k in 0..3 {
            let v = &segment.velocity[k];
            let distance = if v.is_positive() {
                &high[k] - &segment.position[k]
            } else if v.is_negative() {
                &segment.position[k] - &low[k]
            } else {
                continue;
            };
            let distance = if distance.is_negative() { Q::zero() } else { distance };
            let tau = distance / v.abs();
            if best.as_ref().is_none_or(|(t, _)| &tau < t) {
                best = Some((tau, k));
            }
        }
        segments.push(segment.clone());
        let Some((tau, k)) = best else { break };
        let t = &segment.start + &tau;
        if &t >= end {
            break;
        }
        walls.push(t.clone());
        let position = [0, 1, 2].map(|m| &segment.position[m] + &tau * &segment.velocity[m]);
        let mut velocity = segment.velocity.clone();
        velocity[k] = -velocity[k].clone();
        segment = Segment { start: t, position, velocity };
    }
    (segments, walls)
}

/// One exact contact: its pair and the frames it may be reported in (one, or two adjacent ones
/// when it lies within rounding of a boundary), or `optional` when it is within the tolerance
/// of not being a contact at all (grazing, touching at a segment's start).
#[derive(Debug)]
struct Expected {
    pair: (u32, u32),
    frames: Vec<usize>,
    optional: bool,
}

/// Where a contact whose time `t*` satisfies `below(T) == (t* < T)` (exactly) may be reported:
/// the frames `[t_k, t_k+1)` that hold it up to `slack` either side of a boundary, and whether it
/// may go unreported because it lies within `slack` of the end of the run.
fn frames_holding(boundaries: &[Q], slack: &Q, below: impl Fn(&Q) -> bool) -> (Vec<usize>, bool) {
    let last = boundaries.len() - 1;
    let frames =
        (0..last).filter(|&k| !below(&(&boundaries[k] - slack)) && below(&(&boundaries[k + 1] + slack))).collect();
    (frames, !below(&(&boundaries[last] - slack)))
}

/// The partner of a wall contact in [`Expected::pair`].
const WALL: u32 = u32::MAX;

/// Every pair and wall contact of the run, exactly.
fn exact_contacts(scene: &Scene, boundaries: &[Q]) -> Vec<Expected> {
    let end = boundaries.last().unwrap().clone();
    let slack = q(1e-9);
    let mut expected = Vec::new();
    let mut paths = Vec::new();
    for (i, sphere) in scene.spheres.iter().enumerate() {
        let (path, walls) = exact_path(sphere, &scene.bounds, &end);
        for t in walls {
            let (frames, at_end) = frames_holding(boundaries, &slack, |limit| &t < limit);
            expected.push(Expected { pair: (i as u32, WALL), frames, optional: at_end });
        }
        paths.push(path);
    }
    for i in 0..paths.len() {
        for j in i + 1..paths.len() {
            let radius = q(scene.spheres[i].radius + scene.spheres[j].radius);
            let r2 = &radius * &radius;
            // Walk both paths' segments in step: each overlap in time is one straight relative motion.
            let (mut a, mut b) = (0, 0);
            while a < paths[i].len() && b < paths[j].len() {
                let (sa, sb) = (&paths[i][a], &paths[j][b]);
                let from = if sa.start > sb.start { sa.start.clone() } else { sb.start.clone() };
                let next_a = paths[i].get(a + 1).map_or(end.clone(), |s| s.start.clone());
                let next_b = paths[j].get(b + 1).map_or(end.clone(), |s| s.start.clone());
                let until = if next_a < next_b { next_a.clone() } else { next_b.clone() };
                let at = |s: &Segment| [0, 1, 2].map(|k| &s.position[k] + (&from - &s.start) * &s.velocity[k]);
                let (pa, pb) = (at(sa), at(sb));
                let offset = [0, 1, 2].map(|k| &pb[k] - &pa[k]);
                let velocity = [0, 1, 2].map(|k| &sb.velocity[k] - &sa.velocity[k]);
                let (qa, qb, qc) = (dot(&velocity, &velocity), dot(&offset, &velocity), dot(&offset, &offset) - &r2);
                // d^2(from + tau) - R^2 = qc + 2 qb tau + qa tau^2.
                let near = |x: &Q, scale: &Q| x.abs() <= &q(1e-7) * scale;
                if qb.is_negative() && !qa.is_zero() {
                    let disc = &qb * &qb - &qa * &qc;
                    if !qc.is_positive() {
                        // Touching or overlapping at the start of the relative motion: a contact
                        // only within the tolerance, so the engine may or may not report it.
                        if near(&qc, &r2) {
                            let (frames, _) = frames_holding(boundaries, &slack, |t| &from < t);
                            expected.push(Expected { pair: (i as u32, j as u32), frames, optional: true });
                        }
                    } else if !disc.is_negative() {
                        // First root from + (-qb - sqrt(disc)) / qa < T  <=>  -qb - qa (T - from) < sqrt(disc).
                        let below = |t: &Q| {
                            let lhs = -&qb - &qa * (t - &from);
                            lhs.is_negative() || &lhs * &lhs < disc
                        };
                        let inside = !below(&from) && below(&until);
                        let at_edge = below(&(&until + &slack)) && !below(&(&until - &slack));
                        if inside || at_edge {
                            let grazing = near(&disc, &(&qa * &r2));
                            let (frames, at_end) = frames_holding(boundaries, &slack, below);
                            expected.push(Expected {
                                pair: (i as u32, j as u32),
                                frames,
                                optional: grazing || at_edge || at_end,
                            });
                        }
                    }
                }
                if next_a <= next_b {
                    a += 1;
                }
                if next_b <= next_a {
                    b += 1;
                }
            }
        }
    }
    expected
}

/// Steps `method` over the frames and checks its contacts against the exact ones; returns how
/// many it reported.
fn check(scene: &Scene, dt: f64, frames: usize, method: Method) -> usize {
    let mut boundaries = vec![0.0];
    for k in 0..frames {
        boundaries.push(boundaries[k] + dt);
    }
    let exact_boundaries: Vec<Q> = boundaries.iter().map(|&t| q(t)).collect();
    let mut expected = exact_contacts(scene, &exact_boundaries);
    let config = WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() };
    let mut world = scene.world(config).unwrap();
    let mut found = Vec::new();
    for frame in 0..frames {
        for c in world.step(dt).unwrap() {
            assert!(
                boundaries[frame] <= c.time && c.time < boundaries[frame + 1],
                "{method:?}: contact at {} outside frame {frame}",
                c.time
            );
            // No body is ever removed: a body's slot is its place in the scene.
            let other = match c.touched {
                Touched::Body(other) => other.index(),
                Touched::Wall(_) => WALL,
            };
            found.push(((c.body.index(), other), frame, c.time));
        }
    }
    let reported = found.len();
    for (pair, frame, time) in found {
        let matching = expected.iter().position(|e| e.pair == pair && e.frames.contains(&frame));
        match matching {
            Some(k) => {
                expected.swap_remove(k);
            }
            None => panic!("{method:?}: pair {pair:?} reported in frame {frame} at {time} has no exact contact there (a duplicate or an invented contact); dt {dt}, scene {scene:?}"),
        }
    }
    if let Some(missed) = expected.iter().find(|e| !e.optional) {
        panic!("{method:?}: exact contact {missed:?} was never reported; dt {dt}, scene {scene:?}");
    }
    reported
}

/// Two spheres built to touch at frame boundary `k` (up to the rounding of their start), plus
/// random company.
fn boundary_scene(rng: &mut ChaCha8Rng, dt: f64, frames: usize) -> Scene {
    let side = 20.0;
    let bounds = BoxBounds::cube(side).unwrap();
    let mut boundaries = vec![0.0f64];
    for k in 0..frames {
        boundaries.push(boundaries[k] + dt);
    }
    let mut spheres = Vec::new();
    for _ in 0..rng.random_range(1..4) {
        let k = rng.random_range(1..frames);
        let t = boundaries[k];
        let (ra, rb) = (rng.random_range(0.3..1.5), rng.random_range(0.3..1.5));
        let centre = DVec3::splat(side / 2.0) + random_direction(rng) * 3.0;
        let normal = random_direction(rng);
        let (va, vb) =
            (random_direction(rng) * rng.random_range(0.5..4.0), random_direction(rng) * rng.random_range(0.5..4.0));
        // Approaching along the normal at t, touching there; walk back to time 0.
        let (va, vb) = if (vb - va).dot(normal) < 0.0 { (va, vb) } else { (vb, va) };
        let a = centre - va * t;
        let b = centre + normal * (ra + rb) - vb * t;
        let fits = |p: DVec3, r: f64| (p - r).cmpgt(DVec3::ZERO).all() && (p + r).cmplt(DVec3::splat(side)).all();
        if fits(a, ra) && fits(b, rb) {
            spheres.push(Sphere { position: a, velocity: va, radius: ra, mass: 1.0 });
            spheres.push(Sphere { position: b, velocity: vb, radius: rb, mass: 1.0 });
        }
    }
    for _ in 0..rng.random_range(0..5) {
        let r = rng.random_range(0.3..1.5);
        let p = DVec3::new(rng.random_range(r..side - r), rng.random_range(r..side - r), rng.random_range(r..side - r));
        spheres.push(Sphere {
            position: p,
            velocity: random_direction(rng) * rng.random_range(0.0..30.0),
            radius: r,
            mass: 1.0,
        });
    }
    if spheres.is_empty() {
        spheres.push(Sphere { position: DVec3::splat(10.0), velocity: DVec3::X, radius: 1.0, mass: 1.0 });
    }
    Scene::new(bounds, spheres)
}

const METHODS: [Method; 4] = [Method::Brute, Method::Grid, Method::Vadop, Method::SweptAabb];

#[test]
fn the_reported_frame_boundary_duplicate() {
    // Issue: frames 10 and 11 both held the contact at 5/3.
    let sphere = |x: f64, vx: f64| Sphere {
        position: DVec3::new(x, 5.0, 5.0),
        velocity: DVec3::new(vx, 0.0, 0.0),
        radius: 0.5,
        mass: 1.0,
    };
    let scene = Scene::new(BoxBounds::cube(10.0).unwrap(), vec![sphere(2.0, 1.5), sphere(8.0, -1.5)]);
    for method in METHODS {
        // One pair contact; the walls are out of reach.
        assert_eq!(check(&scene, 1.0 / 6.0, 12, method), 1, "{method:?}");
    }
}

#[test]
fn contacts_built_on_frame_boundaries_are_reported_once() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut reported = 0;
    for case in 0..150 {
        let dt = [1.0 / 30.0, 1.0 / 6.0, 0.1, rng.random_range(0.001..0.3)][case % 4];
        let frames = 12;
        let scene = boundary_scene(&mut rng, dt, frames);
        for method in METHODS {
            reported += check(&scene, dt, frames, method);
        }
    }
    assert!(reported > 500, "too few contacts exercised: {reported}");
}

#[test]
fn random_small_scenes_match_exact_arithmetic() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut reported = 0;
    for _ in 0..60 {
        let side = rng.random_range(4.0..12.0);
        let bounds = BoxBounds::cube(side).unwrap();
        let spheres = (0..rng.random_range(2..9))
            .map(|_| {
                let r = rng.random_range(0.2..1.0);
                let p = DVec3::new(
                    rng.random_range(r..side - r),
                    rng.random_range(r..side - r),
                    rng.random_range(r..side - r),
                );
                // From nearly at rest to several box lengths per frame.
                Sphere {
                    position: p,
                    velocity: random_direction(&mut rng) * 10f64.powf(rng.random_range(-1.0..2.5)),
                    radius: r,
                    mass: 1.0,
                }
            })
            .collect();
        let scene = Scene::new(bounds, spheres);
        let dt = rng.random_range(0.01..0.2);
        for method in METHODS {
            reported += check(&scene, dt, 10, method);
        }
    }
    assert!(reported > 300, "too few contacts exercised: {reported}");
}
