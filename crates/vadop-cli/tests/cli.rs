//! End-to-end tests of the `vadop` binary on small scenes: summaries, accuracy against brute
//! force, outputs that parse with one row per frame, and bad input that must end in an `error:`
//! line and exit code 2, never a panic. They only run the built binary and read what it writes;
//! they never depend on timings. The benchmarks' tests are in crates/vadop-bench/tests.

use std::path::PathBuf;
use std::process::{Command, Output};

fn vadop(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vadop")).args(args).output().expect("the binary runs")
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A fresh scratch directory per test, so tests running in parallel never share files.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vadop-cli-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// The first number after `label` on the summary line that starts with `line`.
fn number_after(summary: &str, line: &str, label: &str) -> f64 {
    let text = summary.lines().find(|l| l.starts_with(line)).unwrap_or_else(|| panic!("no {line} line in\n{summary}"));
    let rest = &text[text.find(label).unwrap_or_else(|| panic!("no {label} in {text}")) + label.len()..];
    let number: String = rest.trim_start().chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    number.parse().unwrap_or_else(|_| panic!("no number after {label} in {text}"))
}

fn assert_usage_error(output: &Output, expected: &str) {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(2), "stderr: {err}");
    assert!(err.starts_with("error: "), "stderr: {err}");
    assert!(err.contains(expected), "expected {expected:?} in: {err}");
    assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "stderr: {err}");
}

#[test]
fn every_mode_and_method_prints_a_summary() {
    for mode in ["detect", "simulate"] {
        for method in ["vadop", "brute", "discrete"] {
            let output = vadop(&["simulate", "--bodies", "150", "--frames", "5", "--mode", mode, "--method", method]);
            assert!(output.status.success(), "{mode} {method}: {}", stderr(&output));
            let summary = stdout(&output);
            for field in [
                "scene",
                "method",
                "pool",
                "frames",
                "contacts",
                "accuracy",
                "ms/frame",
                "cost split",
                "per frame",
                "memory",
            ] {
                assert!(
                    summary.lines().any(|l| l.starts_with(field)),
                    "{mode} {method}: no {field} line in\n{summary}"
                );
            }
            assert!(summary.contains(&format!("{method}, {mode} mode")), "{summary}");
            assert!(summary.contains("frames      5 of 5"), "{summary}");
            assert_eq!(summary.lines().any(|l| l.starts_with("energy")), mode == "simulate", "{summary}");
            if method == "vadop" {
                assert!(summary.contains("axes per body"), "{summary}");
            }
        }
        // The default method says what stepped: the event loop in simulate mode of spheres.
        let output = vadop(&["simulate", "--bodies", "150", "--frames", "5", "--mode", mode]);
        assert!(output.status.success(), "{mode} auto: {}", stderr(&output));
        let stepper = if mode == "simulate" { "event loop" } else { "grid" };
        assert!(stdout(&output).contains(&format!("auto ({stepper}), {mode} mode")), "{}", stdout(&output));
    }
}

#[test]
fn vadop_misses_nothing_and_discrete_misses_fast_contacts() {
    let run = |method: &str| {
        let output = vadop(&[
            "simulate",
            "--bodies",
            "400",
            "--frames",
            "10",
            "--max-speed",
            "5",
            "--mode",
            "detect",
            "--method",
            method,
            "--reference",
            "brute",
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        stdout(&output)
    };
    let exact = run("vadop");
    assert_eq!(number_after(&exact, "accuracy", "vs brute:"), 0.0, "{exact}");
    assert!(exact.contains("0 missed, 0 extra"), "{exact}");
    let discrete = run("discrete");
    assert!(number_after(&discrete, "accuracy", "vs brute:") > 0.0, "{discrete}");
}

#[test]
fn csv_and_json_have_one_row_per_frame() {
    let dir = scratch("outputs");
    let (csv, json, contacts, scene) = (dir.join("f.csv"), dir.join("f.json"), dir.join("c.csv"), dir.join("s.json"));
    let path = |p: &PathBuf| p.to_str().expect("utf-8 path").to_string();
    let output = vadop(&[
        "simulate",
        "--bodies",
        "200",
        "--frames",
        "7",
        "--quiet",
        "--csv",
        &path(&csv),
        "--json",
        &path(&json),
        "--contacts",
        &path(&contacts),
        "--save-scene",
        &path(&scene),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).is_empty(), "--quiet printed {}", stdout(&output));

    let text = std::fs::read_to_string(&csv).expect("csv written");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 7);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(&header[..5], ["frame", "time", "contacts", "pair_contacts", "ms"]);
    for (k, line) in lines[1..].iter().enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), header.len());
        assert_eq!(cells[0], (k + 1).to_string());
        assert!(cells.iter().all(|c| c.parse::<f64>().is_ok()), "{line}");
    }

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json written")).expect("json parses");
    assert_eq!(report["frames"].as_array().map(Vec::len), Some(7));
    assert_eq!(report["summary"]["frames_completed"], 7);
    let total = report["summary"]["contacts"]["total"].as_u64().expect("contact total");
    let contact_lines = std::fs::read_to_string(&contacts).expect("contacts written").lines().count() as u64;
    assert_eq!(contact_lines, 1 + total);
    // The elastic run's pressure: the CSV's per-frame virial sums to the summary's W, and the
    // impacts push apart, so Z exceeds the ideal gas's 1.
    let column = header.iter().position(|&c| c == "pair_virial").expect("a pair_virial column");
    let virial: f64 = lines[1..].iter().map(|l| l.split(',').nth(column).unwrap().parse::<f64>().unwrap()).sum();
    let pressure = &report["summary"]["pressure"];
    let reported = pressure["virial"].as_f64().expect("the summary's virial");
    assert!((virial - reported).abs() <= 1e-9 * reported.abs() && reported > 0.0, "{virial} vs {pressure}");
    assert!(pressure["z"].as_f64().expect("Z") > 1.0, "{pressure}");

    // The saved scene runs again as a scene file and gives the same contacts.
    let again = vadop(&["simulate", "--scene", &path(&scene), "--frames", "7", "--json", &path(&json), "--quiet"]);
    assert!(again.status.success(), "{}", stderr(&again));
    let replay: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json written")).expect("json parses");
    assert_eq!(replay["summary"]["contacts"]["total"].as_u64(), Some(total));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_arguments_are_reported_not_panicked() {
    let cases: [(&[&str], &str); 7] = [
        (&["--bodies", "0"], "at least one sphere"),
        (&["--packing", "2"], "packing fraction"),
        (&["--dt", "-1"], "time step"),
        (&["--restitution", "3"], "restitution"),
        (&["--pool", "1"], "axis pool size"),
        (&["--phi", "5", "--pool", "7"], "phi"),
        (&["--scene", "/nonexistent/vadop-scene.json"], "/nonexistent/vadop-scene.json"),
    ];
    for (args, expected) in cases {
        let mut full = vec!["simulate", "--frames", "2"];
        full.extend_from_slice(args);
        assert_usage_error(&vadop(&full), expected);
    }
}

#[test]
fn bad_scene_files_are_reported_not_panicked() {
    let dir = scratch("scenes");
    let sphere = |position: &str, radius: &str| {
        format!(
            r#"{{"bounds": {{"min": [0, 0, 0], "max": [10, 10, 10]}}, "spheres": [{{"position": {position}, "velocity": [1, 0, 0], "radius": {radius}, "mass": 1}}]}}"#
        )
    };
    let two_spheres = |second: &str| {
        format!(
            r#"{{"bounds": {{"min": [0, 0, 0], "max": [10, 10, 10]}}, "spheres": [{{"position": [2, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}}, {second}]}}"#
        )
    };
    let cases = [
        ("nan", sphere("[5, 5, NaN]", "0.5"), "nan.json"),
        ("negative-radius", sphere("[5, 5, 5]", "-0.5"), "sphere 0: radius must be a finite number > 0, got -0.5"),
        ("outside", sphere("[5, 5, 12]", "0.5"), "sphere 0: sphere at [5.0, 5.0, 12.0] with radius 0.5 does not fit"),
        (
            "second-bad",
            two_spheres(r#"{"position": [8, 5, 5], "velocity": [0, 0, 0], "radius": 0, "mass": 1}"#),
            "sphere 1: radius",
        ),
        // Nothing has been stepped yet: the error is about the scene, not about frame 1.
        (
            "overlap",
            two_spheres(r#"{"position": [2.5, 5, 5], "velocity": [0, 0, 0], "radius": 0.5, "mass": 1}"#),
            "error: before the first frame: sphere 0 and sphere 1 overlap",
        ),
        (
            "empty",
            r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "spheres": []}"#.to_string(),
            "before the first frame: the world is empty",
        ),
    ];
    for (name, text, expected) in cases {
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, text).expect("scene written");
        assert_usage_error(&vadop(&["simulate", "--scene", path.to_str().expect("utf-8 path")]), expected);
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_summary_reads_as_written_by_hand() {
    let dir = scratch("one-body");
    let path = dir.join("one.json");
    std::fs::write(
        &path,
        r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]}, "spheres": [{"position": [5, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}]}"#,
    )
    .expect("scene written");
    let output = vadop(&["simulate", "--scene", path.to_str().expect("utf-8 path"), "--frames", "2"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = stdout(&output);
    assert!(summary.contains(" 1 body, cube of side 10"), "{summary}");
    assert!(summary.contains(", dt 1/30 s, "), "{summary}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn pools_tabulate_covering_radius_against_the_bound() {
    let output = vadop(&["pools", "--axes", "3,6,13"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = stdout(&output);
    let rows: Vec<Vec<f64>> =
        table.lines().skip(1).map(|l| l.split_whitespace().filter_map(|c| c.parse().ok()).collect()).collect();
    assert_eq!(rows.len(), 3, "{table}");
    for row in rows {
        // m, rho, bound, rho/bound, ms, mean band: no pool beats the lower bound.
        assert!(row[3] >= 1.0 - 1e-9, "{table}");
        assert!(row[5] >= 1.0, "{table}");
    }
    assert_usage_error(&vadop(&["pools", "--axes", "2"]), "axis pool size");
}

#[test]
fn contact_ends_are_written_beside_the_starts_in_time_order() {
    let dir = scratch("contact-ends");
    let contacts = dir.join("contacts.csv");
    let out = vadop(&[
        "simulate",
        "--bodies",
        "300",
        "--max-speed",
        "2",
        "--mode",
        "detect",
        "--frames",
        "20",
        "--contact-ends",
        "--contacts",
        contacts.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&contacts).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let (starts, ends) =
        (rows.iter().filter(|r| r[3] == "body").count(), rows.iter().filter(|r| r[3] == "body-end").count());
    assert!(starts > 0 && ends > 0 && ends <= starts, "{starts} starts, {ends} ends");
    // One time order across starts and ends, and every end follows its pair's start.
    let times: Vec<f64> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]));
    let mut open = std::collections::BTreeSet::new();
    for r in rows.iter().filter(|r| r[3] != "wall") {
        let pair = (r[2].to_string(), r[4].to_string());
        assert_eq!(open.insert(pair.clone()), r[3] == "body", "row {r:?}");
        if r[3] == "body-end" {
            open.remove(&pair);
        }
    }
    // Refused in simulate mode, with the core's reason.
    let out = vadop(&["simulate", "--bodies", "10", "--frames", "1", "--contact-ends"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("detect mode"), "{}", stderr(&out));
}

/// The summary's figures say what they measure: contacts with static bodies apart from those
/// between bodies, in the singular when there is one, and the default method named as such.
#[test]
fn contacts_with_static_bodies_are_counted_apart_and_in_the_singular() {
    let dir = scratch("statics");
    let (scene, csv) = (dir.join("scene.json"), dir.join("frames.csv"));
    // Two spheres meet, a third lands on a static ground plane, all within the first frame.
    std::fs::write(
        &scene,
        r#"{"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
            "spheres": [{"position": [4.45, 5, 5], "velocity": [3, 0, 0], "radius": 0.5, "mass": 1},
                        {"position": [5.55, 5, 5], "velocity": [-3, 0, 0], "radius": 0.5, "mass": 1},
                        {"position": [2, 1.55, 5], "velocity": [0, -3, 0], "radius": 0.5, "mass": 1}],
            "shapes": [{"name": "ground", "shape": {"HalfSpace": {"normal": [0, 1, 0]}}}],
            "static_bodies": [{"shape": "ground", "position": [0, 1, 0]}]}"#,
    )
    .expect("scene written");
    let path = |p: &PathBuf| p.to_str().expect("utf-8 path").to_string();
    let output = vadop(&["simulate", "--scene", &path(&scene), "--frames", "2", "--csv", &path(&csv)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = stdout(&output);
    assert!(summary.contains("contacts    2 (1 body pair, 1 with static bodies, 0 with walls)"), "{summary}");
    assert!(summary.contains("rules       0 contacts made elastic"), "{summary}");
    assert!(summary.contains("method      auto (grid), simulate mode"), "{summary}");
    assert!(summary.contains("the default, the fastest method here; --method vadop runs the paper's"), "{summary}");
    let text = std::fs::read_to_string(&csv).expect("csv written");
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let first: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    let cell = |name: &str| first[header.iter().position(|h| *h == name).unwrap()];
    assert_eq!((cell("contacts"), cell("pair_contacts"), cell("static_contacts")), ("2", "1", "1"));
    std::fs::remove_dir_all(dir).ok();
}

/// Axes per body is the mean over the frames that start a window (it was 0.57 where it is about
/// 2.4, counting the frames between windows as zero); the energy change of a run with losses is
/// a loss, not a drift; the momentum change comes with its scale.
#[test]
fn the_summarys_means_and_energy_line_say_what_they_measure() {
    let dir = scratch("means");
    let json = dir.join("run.json");
    let run = |restitution: &str| {
        let output = vadop(&[
            "simulate",
            "--bodies",
            "500",
            "--frames",
            "20",
            "--method",
            "vadop",
            "--restitution",
            restitution,
            "--json",
            json.to_str().expect("utf-8 path"),
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        stdout(&output)
    };
    let summary = run("0.8");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json written")).expect("json parses");
    let starts: Vec<f64> = report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["windows"].as_u64() > Some(0))
        .map(|f| f["list_entries"].as_f64().unwrap() / 500.0)
        .collect();
    assert!(!starts.is_empty() && starts.len() < 20, "{} frames start a window", starts.len());
    let expected = starts.iter().sum::<f64>() / starts.len() as f64;
    let pool = summary.lines().find(|l| l.starts_with("pool")).expect("a pool line");
    let axes: f64 = pool.split(" axes per body").next().and_then(|t| t.rsplit(' ').next()).unwrap().parse().unwrap();
    assert!((axes - expected).abs() < 0.006 && axes > 1.5, "{axes} vs {expected}: {summary}");
    assert!(summary.contains("kinetic energy relative change -"), "{summary}");
    assert!(summary.contains("(a loss by design: restitution 0.8)"), "{summary}");
    assert!(summary.contains("of the bodies' sum of |m v| at the start"), "{summary}");
    let elastic = run("1");
    assert!(elastic.contains("kinetic energy relative drift") && !elastic.contains("loss"), "{elastic}");
    std::fs::remove_dir_all(dir).ok();
}

/// `--help` explains every summary line and every CSV column (README.md's "Reading the summary"
/// too), and the tool says it handles shapes, not spheres only.
#[test]
fn help_explains_every_summary_line_and_csv_column() {
    let help = stdout(&vadop(&["simulate", "--help"]));
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).expect("README");
    let section = &readme[readme.find("## Reading the summary").expect("the README section")..];
    let section = &section[..section[3..].find("\n## ").expect("a next section")];
    let dir = scratch("help");
    let csv = dir.join("f.csv");
    let output = vadop(&["simulate", "--bodies", "20", "--frames", "1", "--csv", csv.to_str().unwrap()]);
    let summary = stdout(&output);
    for line in summary.lines().filter(|l| !l.starts_with(' ')) {
        let label = line.split("  ").next().unwrap();
        assert!(help.contains(&format!("\n  {label} ")), "--help does not explain {label:?}");
        assert!(section.contains(&format!("- `{label}`")), "README does not explain {label:?}");
    }
    let text = std::fs::read_to_string(&csv).expect("csv written");
    for column in text.lines().next().unwrap().split(',') {
        assert!(help.contains(column), "--help does not name the CSV column {column}");
        assert!(section.contains(&format!("`{column}`")), "README does not name the CSV column {column}");
    }
    let about = stdout(&vadop(&["--help"]));
    assert!(about.contains("spheres and spinning rigid shapes") && about.contains("--method vadop"), "{about}");
    std::fs::remove_dir_all(dir).ok();
}

/// `--gravity` bends the paths, keeps the oracle's contacts and counts the potential energy; a
/// bad vector is a clear error.
#[test]
fn a_periodic_gas_runs_exact_with_its_pressure() {
    let args =
        ["simulate", "--kind", "gas", "--bodies", "500", "--packing", "0.2", "--frames", "20", "--periodic", "xyz"];
    let output = vadop(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = stdout(&output);
    assert!(summary.contains("(periodic in xyz)"), "{summary}");
    assert!(summary.contains("0 missed, 0 extra"), "{summary}");
    assert!(summary.contains("0 with walls"), "{summary}");
    assert!(summary.contains("a periodic box has no walls"), "{summary}");
    assert!(summary.contains("Z = PV/NkT"), "{summary}");
    let bad = vadop(&["simulate", "--frames", "1", "--periodic", "xq"]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("expected axes among x, y and z"), "{}", stderr(&bad));
}

/// Shapes fall too: exact against brute force in both modes, on a static floor too; elastic runs
/// keep kinetic plus potential energy; with restitution below 1 in simulate mode shapes settle
/// on the floor mesh and lie still, as brute force has them.
#[test]
fn shapes_fall_exactly_under_gravity() {
    let shapes = ["simulate", "--kind", "shapes", "--bodies", "60", "--frames", "20", "--gravity", "0,0,-9.81"];
    for extra in [&["--mode", "detect", "--floor"][..], &["--mode", "simulate"], &["--mode", "simulate", "--floor"]] {
        let output = vadop(&[&shapes[..], extra].concat());
        assert!(output.status.success(), "{}", stderr(&output));
        let summary = stdout(&output);
        assert!(summary.contains("0 missed, 0 extra"), "{summary}");
        assert!(!summary.contains("0 with walls"), "{summary}");
    }
    let elastic = stdout(&vadop(&[&shapes[..], &["--mode", "simulate"]].concat()));
    assert!(elastic.contains("kinetic energy (translation and spin) plus potential relative drift"), "{elastic}");
    // With restitution below 1 they come to rest, here on the bumpy floor mesh (gravity down y).
    let pile =
        ["simulate", "--kind", "shapes", "--bodies", "40", "--frames", "100", "--gravity", "0,-9.81,0", "--floor"];
    let settled = vadop(&[&pile[..], &["--restitution", "0.5", "--friction", "0.3"]].concat());
    assert!(settled.status.success(), "{}", stderr(&settled));
    let summary = stdout(&settled);
    assert!(summary.contains("0 missed, 0 extra"), "{summary}");
    // Most lie still after 3.3 s (the last may still be hopping down the bumps).
    let still = summary.split_once("at rest").and_then(|(_, rest)| rest.split_whitespace().next()?.parse::<u32>().ok());
    assert!(still.is_some_and(|n| n >= 30), "{summary}");
}

#[test]
fn gravity_runs_exact_and_counts_the_potential_energy() {
    let output = vadop(&["simulate", "--bodies", "300", "--frames", "30", "--gravity", "0,0,-9.81"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = stdout(&output);
    assert!(summary.contains("0 missed, 0 extra"), "{summary}");
    assert!(summary.contains("kinetic energy plus potential relative drift"), "{summary}");
    assert!(!summary.contains("pressure"), "no gas pressure under gravity: {summary}");
    let bad = vadop(&["simulate", "--frames", "1", "--gravity", "0,-9.81"]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("expected three numbers x,y,z"), "{}", stderr(&bad));
}

/// `--kind pile` drops the paper scene under gravity with restitution 0.5: it runs exact against
/// brute force while the bodies come to rest, says how many lie still, and counts the potential
/// energy in the loss; `--restitution` and `--gravity` still override its defaults.
#[test]
fn a_pile_settles_exactly_and_says_how_many_bodies_lie_still() {
    let args = ["simulate", "--kind", "pile", "--bodies", "300", "--packing", "0.2", "--frames", "150"];
    let output = vadop(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = stdout(&output);
    assert!(summary.contains("granular pile") && summary.contains("restitution 0.5"), "{summary}");
    assert!(summary.contains("0 missed, 0 extra"), "{summary}");
    assert!(summary.contains("by the rest rule"), "{summary}");
    assert!(summary.contains("kinetic energy plus potential relative change -"), "{summary}");
    let line = summary.lines().find(|l| l.starts_with("at rest")).expect("an at rest line");
    let still: u64 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    assert!(still >= 290 && line.contains("of 300 bodies lie still"), "{line}");
    // An elastic pile keeps bouncing: no rest rule, no at rest line.
    let elastic = stdout(&vadop(&[&args[..], &["--restitution", "1", "--frames", "5"]].concat()));
    assert!(!elastic.contains("at rest") && !elastic.contains("rest rule"), "{elastic}");
}
