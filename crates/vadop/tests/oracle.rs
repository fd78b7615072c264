//! Every continuous method against the brute-force oracle: on random scenes (sparse and dense,
//! slow and very fast, grazing and head-on) the VADOP world and its swept-AABB, swept-k-DOP and
//! grid baselines must report the same contacts as testing every pair, in the same order, frame
//! after frame, in detect mode (identical paths) and in simulate mode (full response).

use glam::DVec3;
use proptest::prelude::*;
use vadop::scene::{GeneratedScene, PaperScene, Scene, Velocities, FRAMES_PER_SECOND};
use vadop::{BoxBounds, Contact, Method, Mode, Sphere, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn config(method: Method, mode: Mode, pool_axes: Option<usize>) -> WorldConfig {
    WorldConfig { method, mode, pool_axes, ..WorldConfig::default() }
}

/// Steps `method` and the oracle side by side and checks every frame's contacts are identical;
/// returns the contact count.
fn assert_same_contacts(scene: &Scene, method: Method, mode: Mode, pool_axes: Option<usize>, frames: usize) -> usize {
    assert_same_contacts_with(scene, method, mode, pool_axes, frames, DT)
}

/// [`assert_same_contacts`] with frames of length `dt`.
fn assert_same_contacts_with(
    scene: &Scene,
    method: Method,
    mode: Mode,
    pool_axes: Option<usize>,
    frames: usize,
    dt: f64,
) -> usize {
    let mut vadop = scene.world(config(method, mode, pool_axes)).unwrap();
    let mut oracle = scene.world(config(Method::Brute, mode, pool_axes)).unwrap();
    let mut total = 0;
    for frame in 0..frames {
        let found: Vec<Contact> = vadop.step(dt).unwrap().to_vec();
        let expected = oracle.step(dt).unwrap();
        assert_eq!(found.len(), expected.len(), "frame {frame}: contact count differs");
        assert_eq!(found, expected, "frame {frame}: contact sequences differ");
        let (virial, expected_virial) = (vadop.stats().pair_virial, oracle.stats().pair_virial);
        assert_eq!(virial.to_bits(), expected_virial.to_bits(), "frame {frame}: virial {virial} vs {expected_virial}");
        if mode == Mode::Detect {
            assert_eq!(virial, 0.0, "frame {frame}: detect mode exchanges no momentum between bodies");
        }
        total += found.len();
        // Every pair of bodies shares an axis, so pruning only ever uses true separating axes.
        if let (true, Some(sap)) = (frame == 0 || frame == frames - 1, vadop.sweep_prune()) {
            let n = vadop.len() as u32;
            for i in 0..n {
                for j in i + 1..n {
                    assert!(sap.shares_axis(i, j), "bodies {i} and {j} share no axis");
                }
            }
        }
    }
    total
}

/// The paper's scene; a packing too dense for a few spheres to be placed apart is thinned until
/// they fit (small boxes hold fewer lattice sites).
fn paper(bodies: usize, packing_fraction: f64, max_speed: f64, seed: u64) -> Scene {
    let mut fraction = packing_fraction;
    loop {
        match (PaperScene { bodies, packing_fraction: fraction, max_speed, radius: 0.5, seed }).build() {
            Ok(scene) => return scene,
            Err(_) if fraction > 1e-3 => fraction *= 0.8,
            Err(e) => panic!("{e}"),
        }
    }
}

/// The continuous methods under test, the default and the paper's most often.
fn continuous_method() -> impl Strategy<Value = Method> {
    prop_oneof![2 => Just(Method::Auto), 2 => Just(Method::Vadop), 1 => Just(Method::SweptAabb), 1 => Just(Method::SweptKdop), 1 => Just(Method::Grid)]
}

/// Velocities beyond the paper's uniform speeds: an equilibrium gas, a stream (most bodies fast
/// in nearly one direction) and heavy-tailed speeds (a few bodies far faster than the rest).
fn other_velocities() -> impl Strategy<Value = Velocities> {
    prop_oneof![
        (0.01f64..3.0).prop_map(|rms_speed| Velocities::Maxwell { rms_speed }),
        (0.1f64..20.0, 0.0f64..0.5).prop_map(|(speed, spread)| Velocities::Stream { speed, spread }),
        (0.01f64..1.0, 1.1f64..3.0)
            .prop_map(|(median_speed, tail_index)| Velocities::HeavyTail { median_speed, tail_index }),
    ]
}

/// A generated scene with `velocities`, thinned like [`paper`] when too dense to place.
fn generated(bodies: usize, packing_fraction: f64, velocities: Velocities, seed: u64) -> Scene {
    let mut fraction = packing_fraction;
    loop {
        match (GeneratedScene { bodies, packing_fraction: fraction, velocities, radius: 0.5, seed }).build() {
            Ok(scene) => return scene,
            Err(_) if fraction > 1e-3 => fraction *= 0.8,
            Err(e) => panic!("{e}"),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn detect_mode_matches_brute_force(
        bodies in 2usize..300,
        packing_fraction in 0.01f64..0.4,
        max_speed in prop_oneof![0.01f64..0.1, 0.1f64..2.0, 2.0f64..20.0],
        pool_axes in prop_oneof![Just(None), Just(Some(3)), Just(Some(6)), Just(Some(13)), Just(Some(46)), Just(Some(200))],
        method in continuous_method(),
        seed in any::<u64>(),
    ) {
        let scene = paper(bodies, packing_fraction, max_speed, seed);
        assert_same_contacts(&scene, method, Mode::Detect, pool_axes, 12);
    }

    #[test]
    fn gas_stream_and_heavy_tailed_scenes_match_brute_force(
        bodies in 2usize..300,
        packing_fraction in 0.01f64..0.4,
        velocities in other_velocities(),
        method in continuous_method(),
        simulate in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let scene = generated(bodies, packing_fraction, velocities, seed);
        assert_same_contacts(&scene, method, if simulate { Mode::Simulate } else { Mode::Detect }, None, 12);
    }

    #[test]
    fn simulate_mode_matches_brute_force(
        bodies in 2usize..300,
        packing_fraction in 0.01f64..0.4,
        max_speed in prop_oneof![0.01f64..0.1, 0.1f64..2.0, 2.0f64..20.0],
        pool_axes in prop_oneof![Just(None), Just(Some(3)), Just(Some(7)), Just(Some(21)), Just(Some(81))],
        method in continuous_method(),
        seed in any::<u64>(),
    ) {
        let scene = paper(bodies, packing_fraction, max_speed, seed);
        assert_same_contacts(&scene, method, Mode::Simulate, pool_axes, 12);
    }
}

#[test]
fn dense_fast_pack_over_many_frames() {
    let scene = paper(300, 0.4, 5.0, 7);
    for method in [Method::Vadop, Method::SweptAabb, Method::SweptKdop, Method::Grid] {
        let contacts = assert_same_contacts(&scene, method, Mode::Simulate, None, 20);
        assert!(contacts > 1000, "{method:?}: a dense fast pack must collide a lot, got {contacts}");
    }
}

/// Grazing: pairs whose paths pass at exactly the sum of the radii, and just inside and outside.
#[test]
fn grazing_and_head_on_pairs() {
    let bounds = BoxBounds::cube(200.0).unwrap();
    let mut spheres = Vec::new();
    for k in 0..40 {
        let y = 10.0 + 4.5 * k as f64;
        let miss = [0.0, 1e-7, -1e-7, 1e-12][k % 4];
        let sphere = |x: f64, y: f64, vx: f64| Sphere {
            position: DVec3::new(x, y, 100.0),
            velocity: DVec3::new(vx, 0.0, 0.0),
            radius: 1.0,
            mass: 1.0,
        };
        // Head-on at 100 diameters per frame, and a grazing pass 2 + miss apart.
        spheres.push(sphere(20.0, y, 6000.0));
        spheres.push(sphere(180.0, y, -6000.0));
        spheres.push(sphere(60.0, y + 2.0 + miss, 300.0));
        spheres.push(sphere(100.0, y, 0.0));
    }
    let scene = Scene::new(bounds, spheres);
    for mode in [Mode::Detect, Mode::Simulate] {
        for method in [Method::Vadop, Method::SweptAabb, Method::SweptKdop, Method::Grid] {
            let contacts = assert_same_contacts(&scene, method, mode, Some(13), 6);
            assert!(contacts >= 40, "{method:?} {mode:?}: {contacts} contacts");
        }
    }
}

/// Fast spheres bouncing off the walls in detect mode: the grid runs each body's first bounce
/// of a window ahead (its proxy, binned partners and their contacts made at the window's start,
/// on every worker) and the event loop takes them when the bounce pops. Frames of many lengths
/// (windows cut mid-frame and frames across windows), one and two workers: the oracle's contacts.
#[test]
fn wall_bounces_run_ahead_give_the_oracles_contacts() {
    let scene = paper(800, 0.15, 5.0, 28);
    for method in [Method::Auto, Method::Grid] {
        for threads in [1, 2] {
            let config =
                |method| WorldConfig { method, mode: Mode::Detect, threads: Some(threads), ..WorldConfig::default() };
            let (mut found, mut oracle) =
                (scene.world(config(method)).unwrap(), scene.world(config(Method::Brute)).unwrap());
            let mut walls = 0;
            for (frame, factor) in
                [1.0, 0.3, 2.5, 1.0, 0.05, 4.0, 1.0, 1.7, 0.6, 1.0].into_iter().cycle().take(30).enumerate()
            {
                let contacts = found.step(factor * DT).unwrap().to_vec();
                assert_eq!(contacts, oracle.step(factor * DT).unwrap(), "{method:?}, {threads} threads, frame {frame}");
                walls += contacts.iter().filter(|c| matches!(c.touched, vadop::Touched::Wall(_))).count();
            }
            assert!(walls > 200, "{method:?}: {walls} wall contacts");
        }
    }
}

/// Regression (found by the property test): the grid rebinned a body between its velocity change
/// in a collision and the update of its box, so its cells described its old path.
#[test]
fn grid_never_bins_a_body_with_its_old_path() {
    let scene = paper(247, 0.23445822542962036, 3.488826731804634, 4796008885780173107);
    assert_same_contacts(&scene, Method::Grid, Mode::Simulate, None, 12);
}

/// Frame lengths, as factors of the usual frame: from a twentieth to five frames.
fn frame_factors() -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(prop_oneof![0.05f64..0.3, 0.3f64..2.0, 2.0f64..5.0], 8..16)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Simulate mode's event loop of spheres (the default method's, see `vadop::event_loop`)
    /// against brute force on equilibrium gases: sparse to dense, walled, periodic and mixed
    /// boxes, elastic and inelastic (the TC model and the jam rule), with and without friction,
    /// frames of changing lengths: the same contacts, virial and final states, to the bit.
    #[test]
    fn the_event_loop_of_gases_matches_brute_force(
        bodies in 2usize..300,
        packing_fraction in prop_oneof![0.01f64..0.1, 0.1f64..0.3, 0.3f64..0.45],
        rms_speed in prop_oneof![0.05f64..0.5, 0.5f64..5.0],
        axes in (any::<bool>(), any::<bool>(), any::<bool>()),
        restitution in prop_oneof![3 => Just(1.0), 1 => 0.0f64..1.0],
        friction in prop_oneof![3 => Just(0.0), 1 => 0.0f64..0.5],
        factors in frame_factors(),
        seed in any::<u64>(),
    ) {
        let mut scene = generated(bodies, packing_fraction, Velocities::Maxwell { rms_speed }, seed);
        let periodic = [axes.0, axes.1, axes.2];
        if scene.bounds.side().min_element() >= 8.0 {
            scene.bounds = scene.bounds.with_periodic(periodic);
        }
        let config = |method| WorldConfig { method, restitution, friction, ..WorldConfig::default() };
        let mut found = scene.world(config(Method::Auto)).unwrap();
        let mut oracle = scene.world(config(Method::Brute)).unwrap();
        for (frame, factor) in factors.iter().enumerate() {
            let contacts = found.step(DT * factor).unwrap().to_vec();
            let expected = oracle.step(DT * factor).unwrap();
            prop_assert_eq!(&contacts, expected, "frame {}", frame);
            prop_assert_eq!(found.stats().pair_virial.to_bits(), oracle.stats().pair_virial.to_bits());
        }
        let state = |w: &vadop::World| w.spheres().map(|(h, s)| format!("{h} {s:?}")).collect::<Vec<_>>();
        prop_assert_eq!(state(&found), state(&oracle));
    }
}

/// A dense periodic gas over many frames, through the event loop and the oracle: tens of
/// thousands of contacts, every one the same.
#[test]
fn a_dense_periodic_gas_over_many_frames() {
    let mut scene = generated(500, 0.45, Velocities::Maxwell { rms_speed: 1.0 }, 3);
    scene.bounds = scene.bounds.with_periodic([true, true, true]);
    let contacts = assert_same_contacts(&scene, Method::Auto, Mode::Simulate, None, 25);
    assert!(contacts > 10_000, "{contacts} contacts");
}
/// A slow bulk on a lattice one diameter apart (boxes touching face to face, as cell faces may
/// lie) and a fast tail crossing many cells along the lattice's rows and diagonals, some grazing
/// the bulk at exactly the sum of the radii or a hair inside or outside: the grid's pair sweep
/// skips a neighbour cell only for boxes that do not reach across into it, and the wall
/// predictions skip bodies whose proxy found no wall in the window. Every frame length, from a
/// tenth of a window to many windows.
#[test]
fn slow_lattice_and_fast_grazing_tail() {
    let bounds = BoxBounds::cube(40.0).unwrap();
    let mut spheres = Vec::new();
    let per_frame = FRAMES_PER_SECOND; // one unit (a diameter) per frame
    for k in 0..343usize {
        let site = DVec3::new((k % 7) as f64, (k / 7 % 7) as f64, (k / 49) as f64);
        // Slow: at most 0.01 diameters per frame, a different direction each.
        let drift = DVec3::new(((k * 37) % 11) as f64 - 5.0, ((k * 53) % 13) as f64 - 6.0, ((k * 71) % 7) as f64 - 3.0);
        spheres.push(Sphere {
            position: DVec3::splat(16.5) + site,
            velocity: drift * 0.001 * per_frame,
            radius: 0.5,
            mass: 1.0,
        });
    }
    for k in 0..24usize {
        let miss = [0.0, 1e-9, -1e-9, 1e-12][k % 4];
        let speed = [20.0, 45.0, 90.0][k % 3] * per_frame;
        let row = 16.5 + (k % 7) as f64;
        let (position, velocity) = if k % 2 == 0 {
            // Along x, past the lattice's top face at exactly one diameter (plus `miss`).
            (DVec3::new(1.0 + (k / 8) as f64, row, 23.5 + 1.0 + miss), DVec3::new(speed, 0.0, 0.0))
        } else {
            // Diagonally through the bulk and on across the box.
            let d = DVec3::new(1.0, 1.0, 0.5).normalize();
            (DVec3::new(2.0 + (k / 8) as f64, 2.0 + miss, row - 14.0), d * speed)
        };
        spheres.push(Sphere { position, velocity, radius: 0.5, mass: 1.0 });
    }
    let scene = Scene::new(bounds, spheres);
    for dt in [DT / 10.0, DT, 4.0 * DT] {
        for mode in [Mode::Detect, Mode::Simulate] {
            for method in [Method::Auto, Method::Grid, Method::Vadop] {
                let contacts = assert_same_contacts_with(&scene, method, mode, None, 8, dt);
                assert!(contacts >= 50, "{method:?} {mode:?} dt {dt}: {contacts} contacts");
            }
        }
    }
}
