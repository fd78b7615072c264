//! The `vadop` binary with bodies of every shape: scene files with shapes run beside brute force
//! with nothing missed, `--kind shapes` prints a summary that says what it holds and reports spins,
//! its scene saves and replays, a run of shapes resumes bit-exactly, and every mistake in a scene
//! file ends in `error:` naming the entry and exit code 2, never a panic.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn vadop(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vadop")).args(args).output().expect("the binary runs")
}

fn ok(output: Output) -> String {
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vadop-cli-shapes-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

fn text(path: &Path) -> String {
    path.to_str().expect("utf-8 path").to_string()
}

/// A scene file written by hand: two spheres, a spinning brick and rod that cross them, a rock,
/// a triangle-mesh ramp and a half-space floor.
const HAND_WRITTEN: &str = r#"{
  "bounds": {"min": [0, 0, 0], "max": [12, 12, 12]},
  "spheres": [
    {"position": [2, 6, 6], "velocity": [9, 0.5, 0], "radius": 0.5, "mass": 1},
    {"position": [10, 6, 6.3], "velocity": [-9, 0, 0], "radius": 0.5, "mass": 1}
  ],
  "shapes": [
    {"name": "brick", "shape": {"Cuboid": {"half_extents": [0.6, 0.3, 0.3]}}},
    {"name": "rod", "shape": {"Capsule": {"half_height": 0.8, "radius": 0.2}}},
    {"name": "rock", "shape": {"ConvexHull": {"points": [[0.5, 0, 0], [-0.3, 0.4, 0.1], [-0.2, -0.4, 0.2], [0, 0.1, -0.5], [0.1, 0, 0.45]]}}},
    {"name": "ramp", "shape": {"TriMesh": {"vertices": [[0, 0, 0], [12, 3, 0], [0, 0, 12], [12, 3, 12]], "triangles": [[0, 1, 2], [1, 3, 2]]}}},
    {"name": "floor", "shape": {"HalfSpace": {"normal": [0, 1, 0]}}}
  ],
  "bodies": [
    {"shape": "brick", "position": [6, 9, 6], "orientation": [0, 0, 0.3826834323650898, 0.9238795325112867],
     "velocity": [0, -8, 0], "angular_velocity": [0, 0, 6], "mass": 2},
    {"shape": "rod", "position": [6, 6, 2], "velocity": [0, 0, 10], "angular_velocity": [4, 0, 0], "mass": 1},
    {"shape": "rock", "position": [3, 9, 9], "velocity": [2, -6, -3], "mass": 0.5}
  ],
  "static_bodies": [
    {"shape": "ramp", "position": [0, 0.5, 0]},
    {"shape": "floor", "position": [0, 0.3, 0], "orientation": [0, 0, 0, 1]}
  ]
}"#;

#[test]
fn shape_scene_files_run_beside_brute_force_with_nothing_missed() {
    let d = dir("files");
    let hand = d.join("hand.json");
    std::fs::write(&hand, HAND_WRITTEN).unwrap();
    let generated = d.join("generated.json");
    let args = ["--kind", "shapes", "--bodies", "40", "--max-speed", "2", "--spin", "1.5", "--floor", "--frames", "1"];
    ok(vadop(&[&["simulate", "--quiet", "--save-scene", &text(&generated)], &args[..]].concat()));
    for scene in [&hand, &generated] {
        for (method, mode) in [("auto", "detect"), ("vadop", "detect"), ("auto", "simulate"), ("grid", "simulate")] {
            let run = ["simulate", "--scene", &text(scene), "--frames", "15", "--mode", mode, "--method", method];
            let summary = ok(vadop(&[&run[..], &["--reference", "brute", "--friction", "0.3"]].concat()));
            assert!(summary.contains(": 0 missed, 0 extra of "), "{}: {summary}", scene.display());
            let pairs = summary.lines().find(|l| l.starts_with("accuracy")).unwrap();
            assert!(
                !pairs.contains("extra of 0 reference"),
                "{} {method} {mode}: no pair contacts: {pairs}",
                scene.display()
            );
            assert!(
                summary.contains(if mode == "detect" { "exact misses" } else { "paths never diverged" }),
                "{summary}"
            );
        }
    }
    let summary = ok(vadop(&["simulate", "--scene", &text(&hand), "--frames", "1"]));
    assert!(summary.contains("5 bodies (2 spheres, 1 cuboid, 1 capsule, 1 convex hull) and 2 static bodies (1 triangle mesh, 1 half-space)"), "{summary}");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn kind_shapes_prints_what_it_holds_and_reports_spins_and_its_scene_replays() {
    let d = dir("kind");
    let (scene, json, replay) = (d.join("scene.json"), d.join("run.json"), d.join("replay.json"));
    let args = ["simulate", "--kind", "shapes", "--bodies", "150", "--frames", "10", "--spin", "1", "--floor"];
    let summary = ok(vadop(&[&args[..], &["--save-scene", &text(&scene), "--json", &text(&json)]].concat()));
    let scene_lines: Vec<&str> = summary.lines().take(3).collect();
    assert!(
        scene_lines[0].contains(
            "mixed shapes (speeds up to 0.5 diameters/frame, spins up to 1 rad/frame, on a floor mesh, seed 1)"
        ),
        "{summary}"
    );
    for kind in ["spheres", "cuboids", "capsules", "cylinders", "cones", "convex hulls"] {
        assert!(scene_lines[1].contains(kind), "no {kind} in {summary}");
    }
    assert!(
        scene_lines[1].starts_with("            150 bodies (")
            && scene_lines[1].ends_with("and 1 static body (1 triangle mesh)"),
        "{summary}"
    );
    assert!(scene_lines[2].contains("max spin ") && scene_lines[2].contains("rad/frame"), "{summary}");
    assert!(summary.contains(": 0 missed, 0 extra of "), "{summary}");
    let energy = summary.lines().find(|l| l.starts_with("energy")).unwrap_or_else(|| panic!("{summary}"));
    assert!(energy.contains("(translation and spin)") && energy.contains("angular momentum change"), "{energy}");
    assert!(energy.contains("walls and static bodies exchange momentum and angular momentum"), "{energy}");
    // Elastic and frictionless: the energy, spins included, is kept.
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let conservation = &report["summary"]["conservation"];
    assert!(conservation["kinetic_relative_drift"].as_f64().unwrap().abs() < 1e-9, "{conservation}");
    assert!(conservation["angular_momentum_change"].as_f64().is_some(), "{conservation}");
    let total = report["summary"]["contacts"]["total"].as_u64().unwrap();
    // The saved scene holds the shapes, and runs again as a file with the same contacts.
    let saved: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    let names: Vec<&str> = saved["shapes"].as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["cuboid", "capsule", "cylinder", "cone", "rock", "floor"]);
    ok(vadop(&["simulate", "--scene", &text(&scene), "--frames", "10", "--quiet", "--json", &text(&replay)]));
    let replayed: serde_json::Value = serde_json::from_slice(&std::fs::read(&replay).unwrap()).unwrap();
    assert_eq!(replayed["summary"]["contacts"]["total"].as_u64(), Some(total));
    // Brute force tests every pair, which for shapes costs far more: by default it checks only
    // scenes of up to 300 bodies with shapes (3000 of spheres).
    let large = ok(vadop(&["simulate", "--kind", "shapes", "--bodies", "400", "--frames", "1"]));
    assert!(large.contains("accuracy    not checked"), "{large}");
    // A sphere-only run says nothing of spins.
    let spheres = ok(vadop(&["simulate", "--bodies", "100", "--frames", "2"]));
    assert!(!spheres.contains("spin"), "{spheres}");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn a_run_of_shapes_resumes_bit_exactly_and_its_world_saves_as_a_scene() {
    let d = dir("resume");
    let (whole, half) = (d.join("whole.json"), d.join("half.json"));
    let (whole_contacts, contacts, scene) = (d.join("whole.csv"), d.join("contacts.csv"), d.join("scene.json"));
    let kind = ["--kind", "shapes", "--bodies", "120", "--packing", "0.1", "--max-speed", "2", "--floor"];
    let physics = ["--restitution", "0.7", "--friction", "0.4", "--quiet"];
    let run = |extra: &[&str]| ok(vadop(&[&["simulate"], &kind[..], &physics[..], extra].concat()));
    run(&["--frames", "10", "--save-state", &text(&whole), "--contacts", &text(&whole_contacts)]);
    run(&["--frames", "4", "--save-state", &text(&half), "--contacts", &text(&contacts)]);
    let resumed = ["simulate", "--resume", &text(&half), "--frames", "6", "--quiet", "--save-state", &text(&half)];
    ok(vadop(&[&resumed[..], &["--contacts", &text(&contacts), "--save-scene", &text(&scene)]].concat()));
    assert_eq!(std::fs::read(&whole).unwrap(), std::fs::read(&half).unwrap(), "the saved states differ");
    assert_eq!(std::fs::read(&whole_contacts).unwrap(), std::fs::read(&contacts).unwrap(), "the contacts differ");
    // The resumed world, saved as a scene before stepping on, holds its shapes and the floor.
    let saved: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    assert_eq!(saved["static_bodies"].as_array().map(Vec::len), Some(1));
    let moving = saved["spheres"].as_array().unwrap().len() + saved["bodies"].as_array().unwrap().len();
    assert_eq!(moving, 120);
    ok(vadop(&["simulate", "--scene", &text(&scene), "--frames", "2", "--quiet"]));
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn mistakes_in_shape_scene_files_are_errors_naming_the_entry() {
    let d = dir("mistakes");
    let cases: [(&str, &str, &str); 10] = [
        (r#""shape": "rod""#, r#""shape": "Rod""#, r#"error: body 1: no shape named "Rod" in the scene's shapes"#),
        (r#"{"shape": "ramp""#, r#"{"shape": "slope""#, r#"error: static body 0: no shape named "slope""#),
        (r#"{"name": "rock""#, r#"{"name": "brick""#, r#"error: shape 2 ("brick"): the name is taken by shape 0"#),
        (r#""shape": "rod""#, r#""shape": "floor""#, r#"error: body 1: shape "floor" is level geometry"#),
        (r#""half_height": 0.8"#, r#""half_height": 0"#, r#"error: shape 1 ("rod"): capsule half height must be"#),
        (r#""velocity": [0, 0, 10]"#, r#""velocity": [0, 0, 1e300]"#, "error: body 1: velocity 1e300 is out of range"),
        (r#""mass": 0.5"#, r#""mass": -0.5"#, "error: body 2: mass must be a finite number > 0, got -0.5"),
        (
            r#""position": [3, 9, 9]"#,
            r#""position": [3, 9, 11.8]"#,
            "error: body 2: the body at [3.0, 9.0, 11.8] reaches out of the box",
        ),
        (
            r#""orientation": [0, 0, 0, 1]"#,
            r#""orientation": [0, 0, 0, 0]"#,
            "error: static body 1: orientation must be a finite, non-zero quaternion",
        ),
        (
            r#""position": [6, 6, 2]"#,
            r#""position": [2.5, 6, 6]"#,
            "error: before the first frame: sphere 0 and body 1 overlap by ",
        ),
    ];
    for (k, (from, to, expected)) in cases.into_iter().enumerate() {
        assert!(HAND_WRITTEN.contains(from), "{from}");
        let path = d.join(format!("mistake-{k}.json"));
        std::fs::write(&path, HAND_WRITTEN.replacen(from, to, 1)).unwrap();
        let output = vadop(&["simulate", "--scene", &text(&path), "--frames", "2"]);
        let err = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{expected}: {err}");
        assert!(err.starts_with(expected), "expected {expected:?}, got {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(output.stdout.is_empty(), "{expected}: a summary of nothing");
    }
    // The overlap is only a mistake when bodies collide: detect mode runs the same file.
    let overlapping = d.join("mistake-9.json");
    ok(vadop(&["simulate", "--scene", &text(&overlapping), "--frames", "2", "--mode", "detect", "--quiet"]));
    // A misspelt field, the discrete method and a floor under spheres are refused too.
    let misspelt = d.join("misspelt.json");
    std::fs::write(&misspelt, HAND_WRITTEN.replacen("angular_velocity", "angular_speed", 1)).unwrap();
    let hand = d.join("hand.json");
    std::fs::write(&hand, HAND_WRITTEN).unwrap();
    for (args, expected) in [
        (vec!["--scene", &text(&misspelt)], "unknown field `angular_speed`"),
        (
            vec!["--scene", &text(&hand), "--method", "discrete"],
            "body 0: the discrete method checks overlaps of spheres only",
        ),
        (vec!["--kind", "shapes", "--method", "discrete"], "the discrete method"),
        (vec!["--floor"], "--floor lays a floor under --kind shapes only"),
        (vec!["--kind", "shapes", "--packing", "0.5"], "too dense to place 1000 separate bodies"),
        (vec!["--kind", "shapes", "--spin", "nan"], "max spin must be finite"),
    ] {
        let output = vadop(&[&["simulate", "--frames", "1"], &args[..]].concat());
        let err = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: ") && err.contains(expected), "{args:?}: expected {expected:?} in {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    std::fs::remove_dir_all(d).ok();
}
