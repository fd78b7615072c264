//! Scene files with shapes: sphere-only files load and save as they always did, a scene of every
//! shape round-trips through its file and builds the world it describes (entries in file order),
//! a world's scene describes it, and every mistake a file can hold is an error naming its entry,
//! never a panic.

use glam::{DQuat, DVec3};
use vadop::error::SceneEntry;
use vadop::scene::{NamedShape, Scene, SceneBody, StaticBody};
use vadop::shape::Shape;
use vadop::{Body, BodyShape, BoxBounds, Method, Mode, Sphere, Touched, VadopError, World, WorldConfig};

fn detect() -> WorldConfig {
    WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }
}

/// A scratch file per test, so tests running in parallel never share one.
fn scratch(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("vadop-scene-files-{}-{name}.json", std::process::id()))
}

fn ball(position: DVec3, velocity: DVec3) -> Sphere {
    Sphere { position, velocity, radius: 0.5, mass: 1.0 }
}

fn body(shape: &str, position: DVec3) -> SceneBody {
    SceneBody {
        shape: shape.to_string(),
        position,
        orientation: DQuat::from_rotation_y(0.3) * DQuat::from_rotation_x(1.1),
        velocity: DVec3::new(1.0, -2.0, 0.5),
        angular_velocity: DVec3::new(0.0, 3.0, -1.0),
        mass: 2.0,
    }
}

/// A box of 20 with two spheres that meet off-centre, a body of every moving shape in a row at y = 10, and three
/// static bodies: a mesh floor, a half-space ceiling and a fixed cuboid.
fn every_shape() -> Scene {
    let mut scene = Scene::new(
        BoxBounds::cube(20.0).unwrap(),
        vec![ball(DVec3::new(3.0, 4.0, 4.0), 3.0 * DVec3::X), ball(DVec3::new(6.0, 4.0, 4.5), -3.0 * DVec3::X)],
    );
    let moving = [
        ("ball", Shape::Sphere { radius: 0.5 }),
        ("brick", Shape::Cuboid { half_extents: DVec3::new(0.6, 0.3, 0.2) }),
        ("rod", Shape::Capsule { half_height: 0.5, radius: 0.2 }),
        ("drum", Shape::Cylinder { half_height: 0.3, radius: 0.4 }),
        ("cone", Shape::Cone { half_height: 0.4, radius: 0.3 }),
        (
            "rock",
            Shape::ConvexHull {
                points: vec![
                    DVec3::new(0.5, 0.0, 0.0),
                    DVec3::new(-0.3, 0.4, 0.1),
                    DVec3::new(-0.2, -0.4, 0.2),
                    DVec3::new(0.0, 0.1, -0.5),
                    DVec3::new(0.1, 0.0, 0.45),
                ],
            },
        ),
    ];
    for (k, (name, shape)) in moving.into_iter().enumerate() {
        scene.shapes.push(NamedShape::new(name, shape));
        scene.bodies.push(body(name, DVec3::new(2.0 + 3.0 * k as f64, 10.0, 10.0)));
    }
    let floor = Shape::TriMesh {
        vertices: vec![
            DVec3::ZERO,
            DVec3::new(20.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 20.0),
            DVec3::new(20.0, 0.0, 20.0),
        ],
        triangles: vec![[0, 1, 2], [1, 3, 2]],
    };
    scene.shapes.push(NamedShape::new("floor", floor));
    scene.shapes.push(NamedShape::new("ceiling", Shape::HalfSpace { normal: DVec3::Y }));
    let flat =
        |shape: &str, position: DVec3, orientation: DQuat| StaticBody { shape: shape.into(), position, orientation };
    scene.static_bodies.push(flat("floor", DVec3::new(0.0, 1.0, 0.0), DQuat::IDENTITY));
    // A half-space whose solid lies above y = 19: its normal turned to point down.
    scene.static_bodies.push(flat("ceiling", DVec3::new(0.0, 19.0, 0.0), DQuat::from_rotation_x(std::f64::consts::PI)));
    scene.static_bodies.push(flat("brick", DVec3::new(15.0, 4.0, 15.0), DQuat::from_rotation_z(0.5)));
    scene
}

#[test]
fn sphere_only_files_load_unchanged_and_are_written_as_before() {
    let text = r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "spheres": [{"position": [2, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}]}"#;
    let scene: Scene = serde_json::from_str(text).unwrap();
    assert_eq!(scene, Scene::new(BoxBounds::cube(10.0).unwrap(), vec![ball(DVec3::new(2.0, 5.0, 5.0), DVec3::X)]));
    // No new keys: a file written now reads in an older vadop too.
    assert_eq!(
        serde_json::to_string(&scene).unwrap(),
        r#"{"bounds":{"min":[0.0,0.0,0.0],"max":[10.0,10.0,10.0]},"spheres":[{"position":[2.0,5.0,5.0],"velocity":[1.0,0.0,0.0],"radius":0.5,"mass":1.0}]}"#
    );
}

#[test]
fn a_scene_of_every_shape_round_trips_and_builds_its_world_in_file_order() {
    let scene = every_shape();
    let path = scratch("every-shape");
    scene.save(&path).unwrap();
    let loaded = Scene::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(loaded, scene, "bit for bit");
    let text = serde_json::to_string(&scene).unwrap();
    // The quaternion order written is [x, y, z, w].
    let q = scene.bodies[0].orientation;
    assert!(text.contains(&serde_json::to_string(&[q.x, q.y, q.z, q.w]).unwrap()), "{text}");

    let world = scene.world(detect()).unwrap();
    let layout = scene.layout();
    assert_eq!((layout.spheres, layout.bodies, layout.static_bodies, layout.count()), (2, 6, 3, 11));
    assert_eq!(world.len(), layout.count());
    for (handle, placed) in world.bodies() {
        let (position, orientation) = match layout.entry(handle).unwrap() {
            SceneEntry::Sphere(i) => {
                assert_eq!(placed.shape, BodyShape::Sphere { radius: 0.5 });
                (scene.spheres[i].position, placed.orientation)
            }
            SceneEntry::Body(i) => {
                let b = &scene.bodies[i];
                assert_eq!((placed.velocity, placed.mass), (b.velocity, b.mass));
                assert!((placed.angular_velocity - b.angular_velocity).length() < 1e-12);
                (b.position, b.orientation)
            }
            SceneEntry::StaticBody(i) => {
                assert_eq!((placed.velocity, placed.mass), (DVec3::ZERO, f64::INFINITY));
                (scene.static_bodies[i].position, scene.static_bodies[i].orientation)
            }
        };
        assert!((placed.position - position).length() < 1e-12, "{handle}");
        assert!(placed.orientation.dot(orientation).abs() > 1.0 - 1e-12, "{handle}");
    }
    // Slots follow the lists: the first body is slot 2, the first static body slot 8.
    let slots: Vec<SceneEntry> = world.bodies().map(|(h, _)| layout.entry(h).unwrap()).collect();
    assert_eq!((slots[2], slots[8]), (SceneEntry::Body(0), SceneEntry::StaticBody(0)));
    assert_eq!(layout.entry(vadop::BodyHandle::from_bits(11)), None);
}

#[test]
fn left_out_orientations_and_spins_are_none_and_misspelt_fields_are_refused() {
    let text = r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
        "shapes": [{"name": "brick", "shape": {"Cuboid": {"half_extents": [1, 0.5, 0.5]}}}],
        "bodies": [{"shape": "brick", "position": [5, 5, 5], "velocity": [1, 0, 0], "mass": 3}],
        "static_bodies": [{"shape": "brick", "position": [2, 2, 2]}]}"#;
    let scene: Scene = serde_json::from_str(text).unwrap();
    assert!(scene.spheres.is_empty());
    assert_eq!((scene.bodies[0].orientation, scene.bodies[0].angular_velocity), (DQuat::IDENTITY, DVec3::ZERO));
    assert_eq!(scene.static_bodies[0].orientation, DQuat::IDENTITY);
    scene.world(WorldConfig::default()).unwrap();
    for (misspelt, field) in [
        (r#""angular_velocty": [0, 0, 1], "mass": 3"#, "angular_velocty"),
        (r#""mass": 3, "orientaton": [0, 0, 0, 1]"#, "orientaton"),
    ] {
        let text = text.replace(r#""mass": 3"#, misspelt);
        let path = scratch(field);
        std::fs::write(&path, text).unwrap();
        let message = Scene::load(&path).unwrap_err().to_string();
        std::fs::remove_file(&path).unwrap();
        assert!(message.contains(&format!("unknown field `{field}`")), "{message}");
    }
}

/// An unknown key anywhere in a file is refused with its name, not ignored: at the top (a
/// misspelt `static_bodies` once ran with no floor), in a sphere entry and in the box.
#[test]
fn unknown_keys_are_refused_everywhere() {
    let text = r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
        "spheres": [{"position": [2, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}],
        "shapes": [{"name": "ground", "shape": {"HalfSpace": {"normal": [0, 1, 0]}}}],
        "static_bodies": [{"shape": "ground", "position": [0, 1, 0]}]}"#;
    serde_json::from_str::<Scene>(text).unwrap().world(WorldConfig::default()).unwrap();
    for (original, changed, key) in [
        (r#""static_bodies":"#, r#""static_body":"#, "static_body"),
        (r#""radius":"#, r#""radus":"#, "radus"),
        (r#""mass": 1"#, r#""mass": 1, "colour": 3"#, "colour"),
        (r#""max":"#, r#""mx":"#, "mx"),
        (r#""max": [10, 10, 10]"#, r#""max": [10, 10, 10], "centre": [5, 5, 5]"#, "centre"),
    ] {
        let changed = text.replacen(original, changed, 1);
        let path = scratch(key);
        std::fs::write(&path, changed).unwrap();
        let message = Scene::load(&path).unwrap_err().to_string();
        std::fs::remove_file(&path).unwrap();
        assert!(message.contains(&format!("unknown field `{key}`")) && message.contains(" line "), "{message}");
    }
}

/// A device that never ends is no scene: it is refused at its first byte, not read until memory
/// runs out (`/dev/zero` once took 23.8 GB).
#[test]
fn endless_inputs_are_refused_without_reading_them_whole() {
    let started = std::time::Instant::now();
    let message = Scene::load("/dev/zero".as_ref()).unwrap_err().to_string();
    assert!(message.starts_with("/dev/zero: expected value at line 1 column 1"), "{message}");
    // A world file too (`--resume`, Python's `World.load`).
    let message = vadop::World::load("/dev/zero".as_ref()).unwrap_err().to_string();
    assert!(message.starts_with("/dev/zero: expected value at line 1 column 1"), "{message}");
    assert!(started.elapsed().as_secs_f64() < 5.0);
}

/// A generated crowd's speeds are in each body's own diameters (its bounding sphere's), as the
/// CLI's summary measures them: none beyond the maximum asked (a cone once ran at 0.5796 for
/// 0.5), and the fastest near it.
#[test]
fn shape_crowds_keep_their_speed_bound_in_each_bodys_diameters() {
    use vadop::scene::{ShapesScene, FRAMES_PER_SECOND};
    for seed in 1..=3 {
        let scene = ShapesScene { seed, floor: seed == 2, ..ShapesScene::new(400, 0.05, 0.5) }.build().unwrap();
        let world = scene.world(detect()).unwrap();
        let mut fastest = 0.0f64;
        for (_, body) in world.bodies().filter(|(_, b)| b.mass.is_finite()) {
            let radius = match body.shape {
                BodyShape::Sphere { radius } => radius,
                BodyShape::Shape(id) => world.shape(id).unwrap().bounding_radius().unwrap(),
            };
            fastest = fastest.max(body.velocity.length() / FRAMES_PER_SECOND / (2.0 * radius));
        }
        assert!(fastest <= 0.5 * (1.0 + 1e-12) && fastest > 0.45, "seed {seed}: {fastest}");
    }
}

/// Every mistake a scene can hold, as a change to a valid scene and the start of the message
/// that must name it.
#[test]
fn every_mistake_is_an_error_naming_its_entry() {
    type Change = Box<dyn Fn(&mut Scene)>;
    let cases: Vec<(Change, &str)> = vec![
        (Box::new(|s| s.bodies[1].shape = "brik".into()), r#"body 1: no shape named "brik" in the scene's shapes"#),
        (Box::new(|s| s.static_bodies[2].shape = "Brick".into()), r#"static body 2: no shape named "Brick""#),
        (
            Box::new(|s| s.shapes.push(NamedShape::new("brick", Shape::Sphere { radius: 1.0 }))),
            r#"shape 8 ("brick"): the name is taken by shape 1"#,
        ),
        (
            Box::new(|s| s.shapes[2].shape = Shape::Capsule { half_height: -1.0, radius: 0.2 }),
            r#"shape 2 ("rod"): capsule half height must be a finite number > 0, got -1"#,
        ),
        (
            Box::new(|s| s.bodies[3].shape = "floor".into()),
            r#"body 3: shape "floor" is level geometry (a triangle mesh or a half-space): only a static body"#,
        ),
        (Box::new(|s| s.bodies[0].mass = 0.0), "body 0: mass must be a finite number > 0, got 0"),
        (Box::new(|s| s.bodies[4].velocity.y = f64::NAN), "body 4: velocity must be finite"),
        (Box::new(|s| s.bodies[4].angular_velocity.z = f64::INFINITY), "body 4: angular velocity must be finite"),
        (
            Box::new(|s| s.bodies[5].orientation = DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)),
            "body 5: orientation must be a finite, non-zero quaternion",
        ),
        (Box::new(|s| s.bodies[2].position.x = 19.8), "body 2: the body at [19.8, 10.0, 10.0] reaches out of the box"),
        (Box::new(|s| s.spheres[1].radius = -0.5), "sphere 1: radius must be a finite number > 0, got -0.5"),
        (Box::new(|s| s.spheres[0].position.z = 25.0), "sphere 0: sphere at [3.0, 4.0, 25.0] with radius 0.5"),
        (
            Box::new(|s| s.static_bodies[1].orientation = DQuat::from_xyzw(f64::NAN, 0.0, 0.0, 1.0)),
            "static body 1: orientation must be a finite, non-zero quaternion",
        ),
    ];
    for (change, expected) in cases {
        let mut scene = every_shape();
        change(&mut scene);
        for mode in [Mode::Detect, Mode::Simulate] {
            let message = scene.world(WorldConfig { mode, ..WorldConfig::default() }).unwrap_err().to_string();
            assert!(message.starts_with(expected), "expected {expected:?}, got {message:?}");
        }
    }
    // The discrete method takes spheres only; the bodies are refused, the first named.
    let discrete = WorldConfig { method: Method::Discrete, ..WorldConfig::default() };
    let message = every_shape().world(discrete).unwrap_err().to_string();
    assert!(message.starts_with("body 0: the discrete method checks overlaps of spheres only"), "{message}");
}

#[test]
fn overlapping_entries_are_named_in_simulate_mode_and_pass_in_detect_mode() {
    let overlaps = [
        // A body on a sphere, a body in the fixed cuboid, a body through the mesh floor.
        (DVec3::new(3.3, 4.0, 4.0), (SceneEntry::Sphere(0), SceneEntry::Body(1))),
        (DVec3::new(15.0, 4.5, 15.0), (SceneEntry::Body(1), SceneEntry::StaticBody(2))),
        (DVec3::new(8.0, 1.1, 8.0), (SceneEntry::Body(1), SceneEntry::StaticBody(0))),
    ];
    for (position, (a, b)) in overlaps {
        let mut scene = every_shape();
        scene.bodies[1].position = position;
        // The world checks overlaps at its first step, naming bodies by handle...
        let mut world = scene.world(WorldConfig::default()).unwrap();
        let error = world.step(0.01).unwrap_err();
        assert!(matches!(error, VadopError::Overlap { .. }), "{error}");
        // ...which the scene's layout turns into its entries.
        let named = scene.layout().name_entries(error);
        assert!(matches!(named, VadopError::SceneOverlap { a: x, b: y, .. } if (x, y) == (a, b)), "{named}");
        assert!(named.to_string().starts_with(&format!("{a} and {b} overlap by ")), "{named}");
        // Detect mode lets bodies pass through each other: the same scene steps.
        scene.world(detect()).unwrap().step(0.01).unwrap();
    }
    // Errors without handles of the scene pass through unchanged.
    let other = VadopError::BadTimeStep(-1.0);
    assert_eq!(every_shape().layout().name_entries(other.clone()), other);
}

#[test]
fn a_worlds_scene_describes_it_and_builds_the_same_world() {
    // Friction spins the spheres up: a scene keeps a spinning sphere as a body of a ball shape.
    let config = WorldConfig { friction: 0.5, restitution: 0.8, ..WorldConfig::default() };
    let mut world = every_shape().world(config).unwrap();
    let mut sphere_contacts = 0;
    for _ in 0..30 {
        let contacts = world.step(1.0 / 30.0).unwrap();
        sphere_contacts +=
            contacts.iter().filter(|c| c.body.index() < 2 && matches!(c.touched, Touched::Body(_))).count();
    }
    assert!(sphere_contacts > 0, "the spheres never met");
    let scene = Scene::from_world(&world);
    let path = scratch("from-world");
    scene.save(&path).unwrap();
    assert_eq!(Scene::load(&path).unwrap(), scene);
    std::fs::remove_file(&path).unwrap();
    let names: Vec<&str> = scene.shapes.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        ["shape 0", "shape 1", "shape 2", "shape 3", "shape 4", "shape 5", "shape 6", "shape 7", "ball of radius 0.5"]
    );
    assert_eq!((scene.spheres.len(), scene.bodies.len(), scene.static_bodies.len()), (0, 8, 3));
    // The scene's world holds the same bodies, in the order of the scene's lists.
    let rebuilt = scene.world(config).unwrap();
    let describe = |w: &World| {
        let mut bodies: Vec<Body> = w.bodies().map(|(_, b)| b).collect();
        bodies.sort_by(|a, b| a.position.to_array().partial_cmp(&b.position.to_array()).unwrap());
        bodies.into_iter().map(|b| (b.position, b.velocity, b.angular_velocity, b.mass)).collect::<Vec<_>>()
    };
    let (before, after) = (describe(&world), describe(&rebuilt));
    assert_eq!(before.len(), after.len());
    for (x, y) in before.iter().zip(&after) {
        assert!(
            (x.0 - y.0).length() < 1e-9 && (x.1 - y.1).length() < 1e-9 && (x.2 - y.2).length() < 1e-9,
            "{x:?} {y:?}"
        );
        assert_eq!(x.3, y.3);
    }
    // A world of still spheres keeps them spheres.
    let spheres = Scene::new(BoxBounds::cube(10.0).unwrap(), vec![ball(DVec3::splat(5.0), DVec3::X)]);
    assert_eq!(Scene::from_world(&spheres.world(detect()).unwrap()), spheres);
}

#[test]
fn a_scene_files_mistakes_in_json_are_io_errors_naming_the_file() {
    let path = scratch("broken");
    for text in [
        r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "bodies": [{"shape": "brick"}]}"#,
        r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "shapes": [{"name": "x", "shape": {"Pyramid": {}}}]}"#,
        r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "bodies": [{"shape": "brick", "position": [1, 1, 1], "orientation": [0, 0, 1], "velocity": [0, 0, 0], "mass": 1}]}"#,
    ] {
        std::fs::write(&path, text).unwrap();
        let error = Scene::load(&path).unwrap_err();
        assert!(matches!(&error, VadopError::Io { path: p, .. } if p.contains("broken")), "{error}");
    }
    std::fs::remove_file(&path).unwrap();
}
