//! Moving bodies between worlds bit for bit (`World::record`, `World::add_record`,
//! `World::start_at`): a world rebuilt from records, in any order of its bodies, steps to the
//! same contacts as the original; and a box split into slabs, each a world of its own bodies plus
//! copies of its neighbours' bodies near the border, reports exactly the whole world's contacts
//! (detect mode), each once. This is the guarantee vadop-mpi stands on.

mod common;

use glam::DVec3;
use proptest::prelude::*;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{
    BodyHandle, BoxBounds, Contact, Method, Mode, Rest, Sphere, SphereRecord, Touched, VadopError, World, WorldConfig,
};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn detect(method: Method) -> WorldConfig {
    WorldConfig { mode: Mode::Detect, method, ..WorldConfig::default() }
}

/// A contact as bits, in frame `frame`, with its bodies named by global ids, the lower id first
/// (a pair named the other way round has its normal turned).
#[derive(Debug, Clone, PartialEq)]
struct Named {
    frame: u64,
    time: u64,
    first: u64,
    touched: String,
    point: [u64; 3],
    normal: [u64; 3],
    impulse: u64,
}

impl Named {
    fn new(frame: u64, contact: &Contact, id: impl Fn(BodyHandle) -> u64) -> Named {
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        let body = id(contact.body);
        let (first, touched, normal) = match contact.touched {
            Touched::Body(other) if id(other) < body => (id(other), format!("body {body}"), -contact.normal),
            Touched::Body(other) => (body, format!("body {}", id(other)), contact.normal),
            Touched::Wall(wall) => (body, format!("{wall:?}"), contact.normal),
        };
        Named {
            frame,
            time: contact.time.to_bits(),
            first,
            touched,
            point: bits(contact.point),
            normal: bits(normal),
            impulse: contact.impulse.to_bits(),
        }
    }

    /// The one-process order: frame, time, then the lower id, then what it touched.
    fn sort(contacts: &mut [Named]) {
        let key = |c: &Named| (c.frame, f64::from_bits(c.time), c.first, c.touched.clone());
        contacts.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    }
}

#[test]
fn a_record_moves_a_body_on_its_very_motion() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    let ball =
        Sphere { position: DVec3::new(1.0, 5.0, 5.0), velocity: DVec3::new(-30.0, 1.0, 0.0), radius: 0.5, mass: 2.0 };
    let handle = world.add_sphere(ball).unwrap();
    // Before any step the record is the body as added.
    let record = world.record(handle).unwrap();
    assert_eq!((record.position, record.since, record.last_contact), (ball.position, 0.0, None));
    world.step(0.1).unwrap();
    let record = world.record(handle).unwrap();
    assert_eq!(record.since, 1.0 / 60.0, "it bounced off the wall at x = 0");
    assert_eq!(record.last_contact, Some(1.0 / 60.0));
    let mut other = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    other.start_at(world.time()).unwrap();
    let moved = other.add_record(&record).unwrap();
    // The history waits for the engine, and is there after a step too.
    assert_eq!(other.record(moved).unwrap(), record);
    world.step(0.1).unwrap();
    other.step(0.1).unwrap();
    assert_eq!(other.record(moved).unwrap(), world.record(handle).unwrap());
}

#[test]
fn records_and_start_times_that_stepping_could_not_make_are_refused() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    world.start_at(2.0).unwrap();
    let good = SphereRecord {
        position: DVec3::splat(5.0),
        since: 1.5,
        velocity: DVec3::new(1.0, 0.0, 0.0),
        radius: 0.5,
        mass: 1.0,
        last_contact: Some(1.5),
        crossings: [0; 3],
        rest: Rest::Falling,
    };
    let mut refused = |record: SphereRecord| world.add_record(&record).err();
    assert!(matches!(refused(SphereRecord { since: 2.5, ..good }), Some(VadopError::BadRecordTime { .. })));
    assert!(matches!(refused(SphereRecord { since: f64::NAN, ..good }), Some(VadopError::BadRecordTime { .. })));
    assert!(matches!(
        refused(SphereRecord { last_contact: Some(3.0), ..good }),
        Some(VadopError::BadRecordTime { .. })
    ));
    assert!(matches!(refused(SphereRecord { crossings: [1, 0, 0], ..good }), Some(VadopError::CrossingsInWalledBox)));
    assert!(matches!(refused(SphereRecord { radius: 0.0, ..good }), Some(VadopError::BadRadius(_))));
    // Lying still needs gravity (and no velocity).
    assert!(matches!(refused(SphereRecord { rest: Rest::Still, ..good }), Some(VadopError::BadRecordRest(_))));
    // Inside the box at its last velocity change, outside now: 4.6 past x = 5 at 1 per second.
    assert!(matches!(
        refused(SphereRecord {
            since: -2.6,
            position: DVec3::new(0.9, 5.0, 5.0),
            velocity: DVec3::new(-1.0, 0.0, 0.0),
            ..good
        }),
        Some(VadopError::OutsideBox { .. })
    ));
    assert_eq!(world.len(), 0, "nothing was added");
    world.add_record(&good).unwrap();
    assert_eq!(world.start_at(3.0), Err(VadopError::AlreadyStarted));
    let mut empty = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    assert_eq!(empty.start_at(-1.0), Err(VadopError::BadStartTime(-1.0)));
    assert_eq!(empty.start_at(f64::INFINITY), Err(VadopError::BadStartTime(f64::INFINITY)));
}

/// Steps `world` for `frames` frames and returns the contacts named by `id`.
fn run(world: &mut World, frames: usize, id: &dyn Fn(BodyHandle) -> u64) -> Vec<Named> {
    let mut out = Vec::new();
    for frame in 0..frames {
        out.extend(world.step(DT).unwrap().iter().map(|c| Named::new(frame as u64, c, id)));
    }
    Named::sort(&mut out);
    out
}

/// Splits the box into `parts` slabs across x; each part's world holds the bodies whose centres
/// lie in its slab at the frame start and copies of the others within `ghost` of it, rebuilt
/// from records every frame; a part keeps a pair contact when it holds the lower id, a wall
/// contact when it holds the body. Returns every part's kept contacts, as `run` names them.
fn split_run(whole: &World, parts: usize, frames: usize, ghost: f64, method: Method) -> Vec<Named> {
    let bounds = whole.bounds();
    let mut records: Vec<(u64, SphereRecord)> =
        whole.spheres().map(|(h, _)| (h.to_bits(), whole.record(h).unwrap())).collect();
    let mut time = whole.time();
    let width = (bounds.max.x - bounds.min.x) / parts as f64;
    let slab = |x: f64| (((x - bounds.min.x) / width) as usize).min(parts - 1);
    let mut out = Vec::new();
    for frame in 0..frames {
        let mut next = Vec::new();
        for part in 0..parts {
            let (low, high) = (bounds.min.x + part as f64 * width, bounds.min.x + (part + 1) as f64 * width);
            let mut world = World::new(bounds, detect(method)).unwrap();
            world.start_at(time).unwrap();
            let mut ids = Vec::new();
            // Any order will do: add the bodies of this part from the top id down.
            for (id, record) in records.iter().rev() {
                let x = position_at(record, time).x;
                let own = slab(x) == part;
                if own || (x > low - ghost && x < high + ghost) {
                    let handle = world.add_record(record).unwrap();
                    ids.push((handle, *id, own));
                }
            }
            if ids.is_empty() {
                continue;
            }
            let id = |h: BodyHandle| ids.iter().find(|(k, _, _)| *k == h).unwrap().1;
            let owned = |h: BodyHandle| ids.iter().find(|(k, _, _)| *k == h).unwrap().2;
            let contacts = world.step(DT).unwrap().to_vec();
            for c in &contacts {
                let keep = match c.touched {
                    Touched::Body(other) => owned(if id(other) < id(c.body) { other } else { c.body }),
                    Touched::Wall(_) => owned(c.body),
                };
                if keep {
                    out.push(Named::new(frame as u64, c, id));
                }
            }
            for &(handle, id, own) in &ids {
                if own {
                    next.push((id, world.record(handle).unwrap()));
                }
            }
        }
        // As a world's clock moves: every part's stands at the same bits.
        time += DT;
        next.sort_by_key(|&(id, _)| id);
        assert_eq!(next.len(), records.len(), "frame {frame}: every body has one owner");
        records = next;
    }
    Named::sort(&mut out);
    out
}

fn position_at(record: &SphereRecord, t: f64) -> DVec3 {
    record.position + (t - record.since) * record.velocity
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// A world rebuilt from its bodies' records mid-run, in a shuffled order, steps on to the
    /// very contacts of the original, whatever the method.
    #[test]
    fn a_world_rebuilt_from_records_in_any_order_steps_to_the_same_bits(
        bodies in 2usize..300,
        packing_fraction in 0.02f64..0.3,
        max_speed in 0.05f64..6.0,
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid), Just(Method::Brute)],
        seed in any::<u64>(),
    ) {
        // A few bodies in a dense box may not fit at random: such a case is no case.
        let scene = PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed }.build();
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let mut world = scene.world(detect(method)).unwrap();
        for _ in 0..3 {
            world.step(DT).unwrap();
        }
        let mut order: Vec<BodyHandle> = world.spheres().map(|(h, _)| h).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let mut rebuilt = World::new(world.bounds(), detect(method)).unwrap();
        rebuilt.start_at(world.time()).unwrap();
        let mut ids = Vec::new();
        for &h in &order {
            ids.push((rebuilt.add_record(&world.record(h).unwrap()).unwrap(), h.to_bits()));
        }
        let original = run(&mut world, 12, &|h| h.to_bits());
        let copy = run(&mut rebuilt, 12, &|h| ids.iter().find(|(k, _)| *k == h).unwrap().1);
        prop_assert_eq!(original, copy);
    }

    /// A box split into slabs, each stepped as a world of its own with its neighbours' bodies
    /// near the border copied in, reports the whole world's contacts, each exactly once.
    #[test]
    fn a_box_split_into_slabs_reports_the_whole_worlds_contacts(
        bodies in 2usize..400,
        packing_fraction in 0.02f64..0.3,
        max_speed in 0.05f64..6.0,
        parts in 2usize..5,
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid)],
        seed in any::<u64>(),
    ) {
        // A few bodies in a dense box may not fit at random: such a case is no case.
        let scene = PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed }.build();
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let mut world = scene.world(detect(method)).unwrap();
        let fastest = scene.spheres.iter().map(|s| s.velocity.length()).fold(0.0, f64::max);
        // Two bodies that touch within a frame start at most two frames' travel and two radii apart.
        let ghost = 2.0 * fastest * DT + 2.0 * 0.5;
        let split = split_run(&world, parts, 8, ghost * (1.0 + 1e-9), method);
        let whole = run(&mut world, 8, &|h| h.to_bits());
        prop_assert_eq!(whole, split);
    }
}
