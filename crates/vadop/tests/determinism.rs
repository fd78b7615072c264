//! Determinism and save/resume: the same input gives bit-identical contacts and states across
//! runs, threads, and a save and load in the middle of a run; damaged world files are errors.

mod common;

use common::{contact_bits, state_bits};
use glam::DVec3;
use std::path::PathBuf;
use vadop::scene::{PaperScene, Scene};
use vadop::{BodyHandle, Method, Mode, Sphere, Touched, VadopError, World, WorldConfig};

const DT: f64 = 1.0 / 30.0;

fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("vadop-determinism-{}-{name}.json", std::process::id()))
}

fn scene() -> Scene {
    PaperScene { bodies: 300, packing_fraction: 0.3, max_speed: 3.0, radius: 0.5, seed: 21 }.build().unwrap()
}

/// The handle of the live body in `slot`, whatever its generation.
fn body_in_slot(world: &World, slot: u32) -> BodyHandle {
    world.spheres().map(|(handle, _)| handle).find(|handle| handle.index() == slot).unwrap()
}

/// Edits between frames, so slots are freed, reused and bodies wait unplaced across a save.
fn edit(world: &mut World, frame: usize) {
    match frame % 4 {
        1 => {
            world.remove_sphere(body_in_slot(world, frame as u32)).unwrap();
        }
        2 => {
            world.set_velocity(body_in_slot(world, frame as u32 + 1), DVec3::new(-0.0, 20.0, -3.5)).unwrap();
        }
        3 => {
            // A small sphere in a corner, which may be free or not: only the outcome must match.
            let corner = Sphere {
                position: world.bounds().min + 0.11,
                velocity: DVec3::new(1.0, -0.0, 2.0),
                radius: 0.1,
                mass: 0.01,
            };
            if world.spheres().all(|(_, s)| s.position.distance(corner.position) > s.radius + corner.radius) {
                world.add_sphere(corner).unwrap();
            }
        }
        _ => {}
    }
}

/// Runs `frames` frames from `world`, editing between frames, and returns every frame's bits.
fn run(world: &mut World, first: usize, frames: usize) -> Vec<Vec<String>> {
    (first..first + frames)
        .map(|frame| {
            edit(world, frame);
            let contacts = contact_bits(world.step(DT).unwrap());
            contacts
        })
        .collect()
}

#[test]
fn save_and_resume_is_bit_exact_for_every_method_and_mode() {
    for method in [Method::Vadop, Method::Brute, Method::Discrete] {
        for (mode, restitution) in [(Mode::Detect, 1.0), (Mode::Simulate, 1.0), (Mode::Simulate, 0.3)] {
            let config = WorldConfig { method, mode, restitution, ..WorldConfig::default() };
            let mut straight = scene().world(config).unwrap();
            let expected = run(&mut straight, 0, 20);

            let mut first = scene().world(config).unwrap();
            let mut found = run(&mut first, 0, 10);
            // Save with an edit pending (an unplaced body, a freed id), then resume.
            edit(&mut first, 10);
            let path = scratch(&format!("{method:?}-{mode:?}-{restitution}"));
            first.save(&path).unwrap();
            let mut resumed = World::load(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            assert_eq!(state_bits(&resumed), state_bits(&first), "{config:?}: loaded state differs");
            assert_eq!(resumed.config(), config);
            found.push(contact_bits(resumed.step(DT).unwrap()));
            found.extend(run(&mut resumed, 11, 9));
            assert_eq!(found, expected, "{config:?}: resumed run differs");
            assert_eq!(state_bits(&resumed), state_bits(&straight), "{config:?}: final state differs");
        }
    }
}

#[test]
fn same_input_same_bits_across_runs_and_threads() {
    let config = WorldConfig { restitution: 0.7, ..WorldConfig::default() };
    let go = move || {
        let mut world = scene().world(config).unwrap();
        let contacts = run(&mut world, 0, 15);
        (contacts, state_bits(&world))
    };
    let here = go();
    assert!(here.0.iter().map(Vec::len).sum::<usize>() > 100);
    assert_eq!(here, go(), "two runs on one thread differ");
    let threads: Vec<_> = (0..2).map(|_| std::thread::spawn(go)).collect();
    for thread in threads {
        assert_eq!(thread.join().unwrap(), here, "a run on another thread differs");
    }
}

/// The frame pipeline shares its work among threads: contacts and states are bit-identical for
/// 1, 2, 3 and 8 threads (more threads than cores included), for every method and mode, and a
/// world saved with one count resumes with another.
#[test]
fn every_thread_count_gives_the_same_bits() {
    for method in [Method::Auto, Method::Vadop, Method::Grid, Method::Brute, Method::Discrete, Method::SweptAabb] {
        for (mode, restitution) in [(Mode::Detect, 1.0), (Mode::Simulate, 1.0), (Mode::Simulate, 0.3)] {
            let config =
                |threads| WorldConfig { method, mode, restitution, threads: Some(threads), ..WorldConfig::default() };
            let go = |threads: usize| {
                let mut world = scene().world(config(threads)).unwrap();
                let contacts = run(&mut world, 0, 12);
                (contacts, state_bits(&world))
            };
            let one = go(1);
            assert!(one.0.iter().map(Vec::len).sum::<usize>() > 50, "{method:?} {mode:?}");
            for threads in [2, 3, 8] {
                assert_eq!(go(threads), one, "{method:?} {mode:?} with {threads} threads");
            }
            // Saved with 3 threads, resumed with 1.
            let mut first = scene().world(config(3)).unwrap();
            let mut found = run(&mut first, 0, 6);
            let path = scratch(&format!("threads-{method:?}-{mode:?}-{restitution}"));
            first.save(&path).unwrap();
            let text = std::fs::read_to_string(&path).unwrap().replace("\"threads\":3", "\"threads\":1");
            std::fs::write(&path, text).unwrap();
            let mut resumed = World::load(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            assert_eq!(resumed.config().threads, Some(1));
            found.extend(run(&mut resumed, 6, 6));
            assert_eq!(found, one.0, "{method:?} {mode:?}: saved with 3 threads, resumed with 1");
        }
    }
}

#[test]
fn a_world_saved_before_its_first_step_resumes_too() {
    let mut world = scene().world(WorldConfig::default()).unwrap();
    let path = scratch("unstepped");
    world.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(run(&mut resumed, 0, 3), run(&mut world, 0, 3));
}

#[test]
fn damaged_or_foreign_files_are_errors() {
    let mut world = scene().world(WorldConfig::default()).unwrap();
    world.step(DT).unwrap();
    let path = scratch("damaged");
    world.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let damaged = [
        text[..text.len() / 2].to_string(),
        text.replace("\"version\":5", "\"version\":99"),
        text.replace("vadop-world", "something-else"),
        text.replacen("\"radius\":0.5", "\"radius\":-0.5", 1),
        text.replacen("\"mass\":", "\"mass\":-", 1),
        text.replacen("\"free_slots\":[]", "\"free_slots\":[3]", 1),
        text.replacen("\"unplaced\":[]", "\"unplaced\":[100000]", 1),
        text.replacen("\"restitution\":1.0", "\"restitution\":2.0", 1),
        text.replacen("\"position\":[", "\"position\":[1e300,", 1),
        "{}".to_string(),
        String::new(),
    ];
    for (k, bad) in damaged.iter().enumerate() {
        assert_ne!(bad, &text, "case {k} must change the file");
        std::fs::write(&path, bad).unwrap();
        let err = World::load(&path).unwrap_err();
        assert!(!err.to_string().is_empty(), "case {k}");
    }
    // Well-formed files that stepping could never have produced: the state is checked as a whole.
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edited = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut value = json.clone();
        edit(&mut value);
        value.to_string()
    };
    let impossible = [
        (edited(&|v| v["slots"][0]["since"] = serde_json::json!(1.0)), "since must be finite and <= time"),
        (
            edited(&|v| v["slots"][0]["last_contact"] = serde_json::json!(5.0)),
            "last contact must be finite and <= time",
        ),
        (edited(&|v| v["slots"][1] = v["slots"][0].clone()), "overlap"),
        (edited(&|v| v["slots"][0]["velocity"] = serde_json::json!([1e3, 0.0, 0.0])), "does not fit inside the box"),
        (edited(&|v| v["time"] = serde_json::json!(-1.0)), "time must be finite"),
        (edited(&|v| v["slots"][0]["generation"] = serde_json::json!(1u64 << 31)), "slot 0: generation must lie in"),
    ];
    for (bad, message) in impossible {
        std::fs::write(&path, bad).unwrap();
        let err = World::load(&path)
            .map(|_| format!("loaded, but it should say {message}"))
            .unwrap_or_else(|e| e.to_string());
        assert!(err.contains(message), "{err} should say {message}");
    }
    std::fs::remove_file(&path).unwrap();
    assert!(matches!(World::load(&path), Err(VadopError::Io { .. })));
    // A save into a missing directory is an error, and leaves no file behind.
    let nowhere = std::env::temp_dir().join("vadop-no-such-dir").join("world.json");
    assert!(matches!(world.save(&nowhere), Err(VadopError::Io { .. })));
}

#[test]
fn contacts_name_live_bodies_only() {
    // A world resumed after removals never reports a removed body, nor a slot's old handle.
    let mut world = scene().world(WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    let removed: Vec<BodyHandle> = world.spheres().map(|(handle, _)| handle).step_by(3).collect();
    for &handle in &removed {
        world.remove_sphere(handle).unwrap();
    }
    // A few slots taken again, by bodies of the next generation.
    let added = world.add_spheres(&[small_sphere(0.5), small_sphere(2.5), small_sphere(4.5)]).unwrap();
    assert_eq!(added.iter().map(|h| (h.index(), h.generation())).collect::<Vec<_>>(), [(0, 1), (3, 1), (6, 1)]);
    let path = scratch("removed");
    world.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let mut named = std::collections::BTreeSet::new();
    for _ in 0..10 {
        for c in resumed.step(DT).unwrap().to_vec() {
            let others = match c.touched {
                Touched::Body(other) => vec![c.body, other],
                Touched::Wall(_) => vec![c.body],
            };
            for handle in others {
                assert!(!removed.contains(&handle), "{handle} was removed");
                assert!(resumed.sphere(handle).is_ok(), "{handle} is not live");
                named.insert(handle);
            }
        }
    }
    assert!(added.iter().any(|handle| named.contains(handle)), "no contact of a body in a reused slot");
}

/// A sphere of radius 0.1 near the box's lower corner, `x` along its edge: small enough to fit
/// between the scene's bodies there or not, which the test does not care about (detect mode).
fn small_sphere(x: f64) -> Sphere {
    Sphere { position: DVec3::new(0.11 + x, 0.11, 0.11), velocity: DVec3::new(0.0, 30.0, 0.0), radius: 0.1, mass: 1.0 }
}

/// Save and resume keep every slot's generation: the resumed world refuses the same stale
/// handles with the same errors, and gives the same handles to the next bodies added.
#[test]
fn save_and_resume_keep_generations() {
    let mut world = scene().world(WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    let first = body_in_slot(&world, 4);
    world.remove_sphere(first).unwrap();
    let second = world.add_sphere(small_sphere(0.0)).unwrap();
    world.remove_sphere(second).unwrap();
    let third = world.add_sphere(small_sphere(1.0)).unwrap();
    let emptied = body_in_slot(&world, 9);
    world.remove_sphere(emptied).unwrap();
    assert_eq!([first, second, third].map(|h| (h.index(), h.generation())), [(4, 0), (4, 1), (4, 2)]);
    world.step(DT).unwrap();
    let path = scratch("generations");
    world.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let unknown = BodyHandle::from_bits(9 | 1 << 33);
    for handle in [first, second, third, emptied, unknown] {
        assert_eq!(resumed.sphere(handle), world.sphere(handle), "{handle}");
    }
    assert_eq!(
        resumed.sphere(second),
        Err(VadopError::StaleHandle { handle: second, current: Some(third) }),
        "a stale handle stays stale"
    );
    assert_eq!(resumed.sphere(emptied), Err(VadopError::StaleHandle { handle: emptied, current: None }));
    assert_eq!(resumed.sphere(unknown), Err(VadopError::NoSuchBody(unknown)));
    let next = [small_sphere(2.0), small_sphere(3.0)];
    assert_eq!(resumed.add_spheres(&next).unwrap(), world.add_spheres(&next).unwrap());
    assert_eq!(body_in_slot(&resumed, 9).generation(), 1);
    assert_eq!(run(&mut resumed, 0, 3), run(&mut world, 0, 3));
}

/// A slot whose generations have run out is retired: its last body's handle can never name
/// another body, because no other body ever takes the slot. (Reaching the last generation takes
/// 2^31 removals; a saved file gets there at once.)
#[test]
fn a_slot_out_of_generations_is_retired() {
    let mut world = scene().world(WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    world.remove_sphere(body_in_slot(&world, 2)).unwrap();
    let path = scratch("retired");
    world.save(&path).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["slots"][2]["generation"] = serde_json::json!(BodyHandle::MAX_GENERATION);
    std::fs::write(&path, json.to_string()).unwrap();
    let mut resumed = World::load(&path).unwrap();
    let last = resumed.add_sphere(small_sphere(0.0)).unwrap();
    assert_eq!((last.index(), last.generation()), (2, BodyHandle::MAX_GENERATION));
    assert!(i64::try_from(last.to_bits()).is_ok());
    resumed.remove_sphere(last).unwrap();
    let next = resumed.add_sphere(small_sphere(1.0)).unwrap();
    assert_eq!((next.index(), next.generation()), (300, 0), "a new slot, not the retired one");
    assert_eq!(resumed.sphere(last), Err(VadopError::StaleHandle { handle: last, current: None }));
    // The retired slot stays retired across a save, and a file listing it as free is refused.
    resumed.save(&path).unwrap();
    let mut again = World::load(&path).unwrap();
    assert_eq!(again.sphere(last), Err(VadopError::StaleHandle { handle: last, current: None }));
    assert_eq!(again.add_sphere(small_sphere(2.0)).unwrap().index(), 301);
    let text = std::fs::read_to_string(&path).unwrap().replacen("\"free_slots\":[]", "\"free_slots\":[2]", 1);
    std::fs::write(&path, text).unwrap();
    let err = World::load(&path).map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("free and unplaced slots do not match"), "{err}");
    std::fs::remove_file(&path).unwrap();
}

/// Files saved before generations existed (version 2) still load: their bodies are generation 0,
/// so their ids are their handles, and a body added to a removed slot is generation 1.
#[test]
fn version_2_files_load_with_removed_ids_stale() {
    let mut world = scene().world(WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    let removed = body_in_slot(&world, 7);
    world.remove_sphere(removed).unwrap();
    world.step(DT).unwrap();
    let path = scratch("version-2");
    world.save(&path).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["version"] = serde_json::json!(2);
    for slot in json["slots"].as_array_mut().unwrap() {
        slot.as_object_mut().unwrap().remove("generation").unwrap();
    }
    std::fs::write(&path, json.to_string()).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(state_bits(&resumed), state_bits(&world));
    assert!(resumed.spheres().all(|(handle, _)| handle.generation() == 0));
    assert_eq!(resumed.sphere(removed), Err(VadopError::StaleHandle { handle: removed, current: None }));
    let added = resumed.add_sphere(small_sphere(0.0)).unwrap();
    assert_eq!((added.index(), added.generation()), (7, 1));
    assert_eq!(added, world.add_sphere(small_sphere(0.0)).unwrap());
}

/// Spinning shapes, whose searches the pipeline parks at a window's end and takes up in the
/// next: contacts and states are bit-identical for 1, 2 and 3 threads, for every method and mode,
/// and for a run resumed from a file (which keeps no parked search, so its searches start from
/// their references again).
#[test]
fn shapes_give_the_same_bits_for_every_thread_count_and_when_resumed() {
    let scene = vadop::scene::ShapesScene::new(300, 0.05, 0.5).build().unwrap();
    for method in [Method::Auto, Method::Vadop, Method::Grid, Method::Brute] {
        for (mode, restitution) in [(Mode::Detect, 1.0), (Mode::Simulate, 0.5)] {
            let config =
                |threads| WorldConfig { method, mode, restitution, threads: Some(threads), ..WorldConfig::default() };
            let go = |threads: usize| {
                let mut world = scene.world(config(threads)).unwrap();
                let contacts = run(&mut world, 0, 10);
                (contacts, state_bits(&world))
            };
            let one = go(1);
            assert!(one.0.iter().map(Vec::len).sum::<usize>() > 20, "{method:?} {mode:?}");
            for threads in [2, 3] {
                assert_eq!(go(threads), one, "{method:?} {mode:?} with {threads} threads");
            }
            let mut first = scene.world(config(2)).unwrap();
            let mut found = run(&mut first, 0, 4);
            let path = scratch(&format!("shape-threads-{method:?}-{mode:?}"));
            first.save(&path).unwrap();
            let mut resumed = World::load(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            found.extend(run(&mut resumed, 4, 6));
            assert_eq!(found, one.0, "{method:?} {mode:?}: saved and resumed");
            assert_eq!(state_bits(&resumed), one.1, "{method:?} {mode:?}: state after resuming");
        }
    }
}

/// Steps `count` frames: each frame's contact starts and ends as bits.
fn frames(world: &mut World, count: usize) -> Vec<(Vec<String>, Vec<String>)> {
    (0..count)
        .map(|_| {
            let starts = contact_bits(world.step(DT).unwrap());
            (starts, contact_bits(world.contact_ends()))
        })
        .collect()
}

/// Shapes in detect mode reporting contact ends: a contact's end is searched from its start,
/// which the file keeps, so a resumed run's ends match one run's to the bit (they once differed
/// by about 1e-9 when the search started wherever the window in progress began).
#[test]
fn contact_ends_of_shapes_resume_bit_exactly() {
    let scene = vadop::scene::ShapesScene::new(300, 0.05, 0.5).build().unwrap();
    let config = WorldConfig { mode: Mode::Detect, contact_ends: true, ..WorldConfig::default() };
    let mut straight = scene.world(config).unwrap();
    let expected = frames(&mut straight, 15);
    let mut first = scene.world(config).unwrap();
    let mut found = frames(&mut first, 5);
    assert!(!first.touching().is_empty(), "the save must hold contacts in progress");
    let path = scratch("shape-ends");
    first.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    // A version 4 file, which does not say when the contacts in progress started, still loads.
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["version"] = serde_json::json!(4);
    json.as_object_mut().unwrap().remove("touching_since").unwrap();
    std::fs::write(&path, json.to_string()).unwrap();
    assert_eq!(World::load(&path).unwrap().touching(), first.touching());
    std::fs::remove_file(&path).unwrap();
    found.extend(frames(&mut resumed, 10));
    let ends: usize = expected[5..].iter().map(|(_, ends)| ends.len()).sum();
    assert!(ends > 20, "only {ends} contact ends after the save");
    for (frame, (found, expected)) in found.iter().zip(&expected).enumerate() {
        assert_eq!(found.0, expected.0, "frame {frame}: contact starts differ");
        assert_eq!(found.1, expected.1, "frame {frame}: contact ends differ");
    }
    assert_eq!(state_bits(&resumed), state_bits(&straight));
}

/// A step interrupted from another thread stops soon and leaves the world as it was: stepping on
/// gives the bits of a run never interrupted, for spheres in simulate mode, for a pile coming to
/// rest under gravity (its rest states too) and for shapes in detect mode with contact ends, on
/// one thread and on a pool.
#[test]
fn an_interrupted_step_is_undone() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::{Duration, Instant};
    let spheres = PaperScene { bodies: 3000, packing_fraction: 0.3, max_speed: 3.0, radius: 0.5, seed: 5 }.build();
    let shapes = vadop::scene::ShapesScene::new(600, 0.05, 0.5).build();
    let pile = PaperScene { bodies: 3000, packing_fraction: 0.2, max_speed: 0.5, radius: 0.5, seed: 6 }.build();
    let falling =
        WorldConfig { gravity: glam::DVec3::new(0.0, 0.0, -9.81), restitution: 0.5, ..WorldConfig::default() };
    let cases = [
        (spheres.unwrap(), WorldConfig { restitution: 0.9, threads: Some(1), ..WorldConfig::default() }),
        (pile.unwrap(), WorldConfig { threads: Some(2), ..falling }),
        (
            shapes.unwrap(),
            WorldConfig { mode: Mode::Detect, contact_ends: true, threads: Some(2), ..WorldConfig::default() },
        ),
    ];
    for (scene, config) in cases {
        let mut straight = scene.world(config).unwrap();
        let expected = frames(&mut straight, 6);
        let mut world = scene.world(config).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        world.set_interrupt(Some(stop.clone()));
        let mut found = frames(&mut world, 3);
        let all = |w: &World| {
            let rests: Vec<_> = w.bodies().map(|(h, _)| w.rest(h).ok()).collect();
            (state_bits(w), format!("{:?} {rests:?}", w.bodies().collect::<Vec<_>>()))
        };
        let before = all(&world);
        let raiser = {
            let stop = stop.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(200));
                stop.store(true, Ordering::Relaxed);
                Instant::now()
            })
        };
        // Hundreds of frames in one step: many seconds, unless interrupted.
        let err = world.step(300.0 * DT).map(|c| c.len()).unwrap_err();
        let returned = Instant::now();
        let raised = raiser.join().unwrap();
        assert_eq!(err, VadopError::Interrupted, "{config:?}");
        assert!(returned.duration_since(raised) < Duration::from_millis(500), "{config:?}: too slow to stop");
        assert_eq!(all(&world), before, "{config:?}: the interrupted step changed the world");
        assert!(world.contacts().is_empty() && world.contact_ends().is_empty());
        assert_eq!(world.step(DT).map(|_| ()), Err(VadopError::Interrupted), "raised: every step is refused");
        stop.store(false, Ordering::Relaxed);
        found.extend(frames(&mut world, 3));
        assert_eq!(found, expected, "{config:?}: the run after the interrupted step differs");
        assert_eq!(all(&world), all(&straight));
    }
}

/// Watched steps (an interrupt flag given, so undoable) started from a thread of another rayon
/// pool, as the Python package's calls are, all finish: showing the flag to the world's own
/// threads once sent them a broadcast, which from another pool's thread now and then waited
/// forever (one pytest run in five hung).
#[test]
fn watched_steps_started_from_another_pool_finish() {
    use std::sync::atomic::AtomicBool;
    use std::sync::{mpsc, Arc};
    use std::time::Duration;
    let scene =
        PaperScene { bodies: 200, packing_fraction: 0.05, max_speed: 1.0, radius: 0.5, seed: 8 }.build().unwrap();
    let (done, finished) = mpsc::channel();
    std::thread::spawn(move || {
        for mode in [Mode::Detect, Mode::Simulate].into_iter().cycle().take(400) {
            let mut world = scene.world(WorldConfig { mode, threads: Some(2), ..WorldConfig::default() }).unwrap();
            world.set_interrupt(Some(Arc::new(AtomicBool::new(false))));
            rayon::scope(|s| {
                s.spawn(|_| {
                    for _ in 0..5 {
                        world.step(DT).unwrap();
                    }
                })
            });
        }
        done.send(()).unwrap();
    });
    assert!(finished.recv_timeout(Duration::from_secs(240)).is_ok(), "a watched step hung");
}

/// Simulate mode of spheres (the event loop) and its oracle step through their events whatever the
/// caller's frames: one frame of a second, frames of an eighth, or frames of a 64th to half a
/// second (all powers of two, so every run ends at the same instant) give the same contacts, in
/// order, and the same states to the bit, in a periodic gas and a walled one, elastic and not.
#[test]
fn contacts_do_not_depend_on_the_frame_length() {
    use vadop::scene::{GeneratedScene, Velocities};
    for (periodic, restitution) in [([true; 3], 1.0), ([false; 3], 0.5)] {
        let generated = GeneratedScene {
            bodies: 400,
            packing_fraction: 0.3,
            velocities: Velocities::Maxwell { rms_speed: 0.6 },
            radius: 0.5,
            seed: 4,
        };
        let mut scene = generated.build().unwrap();
        scene.bounds = scene.bounds.with_periodic(periodic);
        let partitions: [&[f64]; 3] = [&[1.0], &[0.125; 8], &[0.015625, 0.5, 0.25, 0.0625, 0.125, 0.046875]];
        for method in [Method::Auto, Method::Brute] {
            let runs: Vec<_> = partitions
                .iter()
                .map(|frames| {
                    let mut world = scene.world(WorldConfig { method, restitution, ..WorldConfig::default() }).unwrap();
                    let contacts: Vec<String> =
                        frames.iter().flat_map(|&dt| contact_bits(world.step(dt).unwrap())).collect();
                    (contacts, state_bits(&world))
                })
                .collect();
            assert!(runs[0].0.len() > 500, "{method:?}: {} contacts", runs[0].0.len());
            for run in &runs[1..] {
                assert_eq!(run, &runs[0], "{method:?} {periodic:?}: frames of other lengths differ");
            }
        }
    }
}
