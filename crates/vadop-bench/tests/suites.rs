//! End-to-end tests of `vadop-bench` on small sizes: every suite runs and writes well-formed
//! tables between its markers, CSVs and PNG plots; quick runs stay out of the published files;
//! bad input ends in an `error:` line and exit code 2. They never look at timings. The suites run
//! the product binary, `vadop`, which the workspace build puts beside `vadop-bench`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bench(dir: &Path, args: &[&str]) -> Output {
    let exe = Path::new(env!("CARGO_BIN_EXE_vadop-bench"));
    assert!(
        exe.with_file_name("vadop").is_file(),
        "build the product binary too: cargo build -p vadop-cli (same profile)"
    );
    Command::new(exe).args(args).current_dir(dir).output().expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A fresh scratch directory per test, so tests running in parallel never share files.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vadop-bench-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_png(path: &Path) {
    let png = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(png.len() > 10_000 && png.starts_with(b"\x89PNG"), "{}: {} bytes", path.display(), png.len());
}

fn assert_usage_error(output: &Output, expected: &str) {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(2), "stderr: {err}");
    assert!(err.starts_with("error: "), "stderr: {err}");
    assert!(err.contains(expected), "expected {expected:?} in: {err}");
    assert!(!err.contains("panicked"), "stderr: {err}");
}

/// The table rows (lines starting with `|`, header and rule left out) after `heading`.
fn table_after<'a>(text: &'a str, heading: &str) -> Vec<&'a str> {
    text.lines()
        .skip_while(|l| !l.starts_with(heading))
        .skip_while(|l| !l.starts_with('|'))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .collect()
}

#[test]
fn core_writes_its_section_between_the_markers() {
    let dir = scratch("core");
    std::fs::write(dir.join("B.md"), "# Benchmarks\n\nKept above.\n\n<!-- core-benchmark:begin -->\nold\n<!-- core-benchmark:end -->\n\nKept below.\n")
        .expect("markdown written");
    let args = ["core", "--bodies", "200", "--speeds", "0.5", "--frames", "3", "--output", "B.md", "--results", "out"];
    let output = bench(&dir, &args);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&dir.join("B.md"));
    assert!(text.starts_with("# Benchmarks\n\nKept above.\n\n<!-- core-benchmark:begin -->"), "{text}");
    assert!(text.ends_with("<!-- core-benchmark:end -->\n\nKept below.\n"), "{text}");
    assert!(!text.contains("\nold\n"), "{text}");
    assert!(text.contains("vadop-bench core --bodies 200") && text.contains("1-minute load average"), "{text}");
    for method in ["| auto (", "| vadop |", "| discrete |", "| brute |"] {
        assert!(text.contains(method), "{method} missing from {text}");
    }
    assert_eq!(read(&dir.join("out/core-benchmark.csv")).lines().count(), 1 + 4);

    // A child that exceeds the timeout is a row that says so, not a failed benchmark.
    let output = bench(&dir, &[&args[..], &["--timeout", "0.000001"]].concat());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(read(&dir.join("B.md")).contains("timed out"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn quick_runs_write_to_scratch_unless_published() {
    let dir = scratch("quick");
    let args = ["core", "--quick", "--bodies", "100", "--speeds", "0.5", "--frames", "2"];
    let output = bench(&dir, &args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(read(&dir.join("target/bench-quick/BENCHMARKS.md")).contains("<!-- core-benchmark:begin -->"));
    assert!(dir.join("target/bench-quick/results/core-benchmark.csv").is_file());
    assert!(!dir.join("BENCHMARKS.md").exists() && !dir.join("results").exists());

    let output = bench(&dir, &[&args[..], &["--publish"]].concat());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(read(&dir.join("BENCHMARKS.md")).contains("<!-- core-benchmark:begin -->"));
    assert!(dir.join("results/core-benchmark.csv").is_file());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn quick_experiments_write_tables_csv_and_plots() {
    let dir = scratch("experiments");
    std::fs::write(dir.join("B.md"), "# Benchmarks\n\nKept.\n").expect("markdown written");
    let output = bench(&dir, &["experiments", "--quick", "--output", "B.md", "--results", "results"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&dir.join("B.md"));
    assert!(text.starts_with("# Benchmarks\n\nKept.\n"), "{text}");
    for needle in [
        "<!-- experiments:begin -->",
        "### 1. Contacts found",
        "| swept-aabb |",
        "| grid |",
        "| auto |",
        "automatic ÷ best",
        "<!-- experiments:end -->",
    ] {
        assert!(text.contains(needle), "{needle} missing from {text}");
    }
    // The continuous methods never miss: the accuracy table's auto and vadop "missed" columns are 0.
    let accuracy_rows = table_after(&text, "### 1.");
    assert_eq!(accuracy_rows.len(), 3, "{text}");
    for row in accuracy_rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!((cells[4], cells[6]), ("0", "0"), "{row}");
    }
    for plot in [
        "1-contacts-vs-speed",
        "2-time-vs-n",
        "3-time-vs-speed",
        "4-time-vs-pool",
        "5-cost-split",
        "6-swaps-vs-speed",
        "7-memory-vs-n",
    ] {
        assert_png(&dir.join(format!("results/experiments/{plot}.png")));
        assert!(text.contains(&format!("results/experiments/{plot}.png")), "{plot} not linked");
    }
    assert!(read(&dir.join("results/experiments/experiments.csv")).lines().count() > 40);
    std::fs::remove_dir_all(dir).ok();
}

/// The whole quick speed suite: every section between its markers, with its CSV and plot.
#[test]
fn quick_speed_suite_writes_every_section() {
    let dir = scratch("speed");
    let output = bench(&dir, &["speed", "--quick", "--output", "B.md", "--results", "results"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&dir.join("B.md"));
    let sections = [
        ("detect", "detect", 3),
        ("candidates", "candidates", 3),
        ("retest", "retest", 6),
        ("throughput", "throughput", 3),
        ("memory", "memory", 1),
        ("methods", "methods-10000", 6),
    ];
    for (name, plot, rows) in sections {
        let begin = format!("<!-- speed-{name}:begin -->");
        assert!(
            text.contains(&begin) && text.contains(&format!("<!-- speed-{name}:end -->")),
            "{name} markers missing"
        );
        let section = &text[text.find(&begin).expect("begin")..];
        assert!(section.contains("1-minute load average"), "{name}: no machine line");
        let table = table_after(section, "Produced by");
        assert!(table.len() >= rows, "{name}: {} rows in {section}", table.len());
        assert!(table.iter().all(|row| !row.contains("failed") && !row.contains("timed out")), "{name}: {table:?}");
        assert_png(&dir.join(format!("results/speed/{plot}.png")));
        let csv = read(&dir.join(format!("results/speed/{name}.csv")));
        let columns = csv.lines().next().expect("header").split(',').count();
        assert!(csv.lines().skip(1).all(|l| l.split(',').count() == columns && l.ends_with(",ok")), "{name}: {csv}");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The peers' table and plot, redrawn from a CSV (running the peers needs Bullet and FCL).
#[test]
fn peers_render_their_table_and_plot_from_a_csv() {
    let dir = scratch("peers");
    let mut csv = String::from(
        "n,speed,pipeline,kind,frames,status,mean_ms,found,missed,false,reference,peak_mib,time_vs_auto\n",
    );
    for (n, scale) in [(10_000, 1.0), (100_000, 12.0)] {
        for speed in [0.5, 5.0] {
            for (pipeline, kind, ms) in [
                ("vadop-auto", "continuous", 2.0),
                ("vadop", "continuous", 5.0),
                ("parry-ccd", "continuous", 3.0),
                ("fcl-dtree", "discrete", 1.0),
                // The reference grid, faster than auto here, is not a peer: the goal check names it apart.
                ("plain-grid", "continuous", 1.6),
            ] {
                csv.push_str(&format!(
                    "{n},{speed},{pipeline},{kind},10,ok,{},100,0,0,100,20.0,\n",
                    ms * scale * speed
                ));
            }
        }
    }
    csv.push_str("100000,5,bullet-sap,discrete,10,timed out after 120 s,,,,,,,\n");
    std::fs::write(dir.join("peers.csv"), csv).expect("csv written");
    let output = bench(&dir, &["peers", "--render", "peers.csv", "--output", "B.md", "--results", "results"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&dir.join("B.md"));
    assert!(text.contains("<!-- peers:begin -->") && text.contains("<!-- peers:end -->"), "{text}");
    assert_eq!(table_after(&text, "| n | speed | pipeline").len(), 21, "{text}");
    assert!(text.contains("| timed out after 120 s |"), "{text}");
    assert!(
        text.contains("- n=100000, speed 5: auto 120.000 ms, exact; faster than every continuous peer that finished"),
        "{text}"
    );
    assert!(
        text.contains(
            "auto ÷ plain-grid 1.25 (96.000 ms); issue 28 (exact, ≤ plain-grid, ≤ 0.5x the fastest exact peer): MISSED."
        ) && text.contains("plain-grid is a reference"),
        "{text}"
    );
    assert_png(&dir.join("results/peers/peers.png"));
    std::fs::remove_dir_all(dir).ok();
}

/// The mixed-shape scene end to end on a few bodies: vadop's pipelines always, and the Bullet
/// and FCL peers' continuous and discrete pipelines where Debian's libbullet-dev and libfcl-dev
/// are installed (scripts/install-peers.sh); rapier/parry is left out, its first build takes
/// minutes. Its own section, CSV and plot; the sphere scene's section stays untouched.
#[test]
fn peers_run_the_mixed_shape_scene_in_its_own_section() {
    let dir = scratch("peers-shapes");
    std::fs::write(dir.join("B.md"), "<!-- peers:begin -->\nspheres\n<!-- peers:end -->\n").expect("markdown written");
    let libraries = Path::new("/usr/include/bullet/btBulletCollisionCommon.h").is_file()
        && Path::new("/usr/include/fcl/fcl.h").is_file();
    let mut pipelines = vec!["vadop-auto", "vadop-brute"];
    if libraries {
        pipelines.extend(["bullet-ccd", "bullet-dbvt", "fcl-ccd", "fcl-dtree"]);
    } else {
        eprintln!("libbullet-dev or libfcl-dev missing: only vadop's pipelines run");
    }
    let (markdown, results) = (dir.join("B.md"), dir.join("results"));
    let args = [
        "peers",
        "--scene",
        "shapes",
        "--quick",
        "--bodies",
        "80",
        "--speeds",
        "2",
        "--frames",
        "3",
        "--pipelines",
        &pipelines.join(","),
        "--output",
        markdown.to_str().unwrap(),
        "--results",
        results.to_str().unwrap(),
    ];
    // Inside the repository, where the C++ peers are built.
    let exe = Path::new(env!("CARGO_BIN_EXE_vadop-bench"));
    let output =
        Command::new(exe).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().expect("the binary runs");
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&markdown);
    assert!(text.starts_with("<!-- peers:begin -->\nspheres\n<!-- peers:end -->\n"), "{text}");
    assert!(text.contains("<!-- peers-shapes:begin -->") && text.contains("Mixed-shape scene"), "{text}");
    let rows = table_after(&text, "| n | speed | pipeline");
    assert_eq!(rows.len(), pipelines.len(), "{text}");
    for row in &rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert!(cells[6].parse::<f64>().is_ok(), "{row}");
        // vadop's pipelines are exact; a peer's misses are its own tolerance's, but it finds contacts.
        let (found, missed, false_contacts) = (cells[7], cells[8], cells[9]);
        if cells[3].starts_with("vadop") {
            assert_eq!((missed, false_contacts), ("0", "0"), "{row}");
        }
        assert!(found.parse::<u64>().is_ok_and(|f| f > 0), "{row}");
    }
    assert_eq!(read(&results.join("peers/shapes.csv")).lines().count(), 1 + pipelines.len());
    assert_png(&results.join("peers/shapes.png"));
    // vadop's discrete method takes spheres only: asking for it is a usage error.
    let refused = bench(&dir, &["peers", "--scene", "shapes", "--pipelines", "vadop-discrete"]);
    assert_usage_error(&refused, "handles spheres only");
    let refused = bench(&dir, &["peers", "--scene", "shapes", "--pipelines", "plain-grid"]);
    assert_usage_error(&refused, "a reference for spheres");
    std::fs::remove_dir_all(dir).ok();
}

/// The reference grid on the sphere scene, end to end beside the default method: both exact
/// against the brute-force reference, fast bodies bouncing several times a frame.
#[test]
fn peers_run_the_plain_grid_exactly_on_the_sphere_scene() {
    let dir = scratch("peers-plain-grid");
    let args = ["peers", "--quick", "--bodies", "300", "--speeds", "5", "--frames", "4"];
    let output = bench(&dir, &[&args[..], &["--pipelines", "vadop-auto,plain-grid", "--output", "B.md"]].concat());
    assert!(output.status.success(), "{}", stderr(&output));
    let text = read(&dir.join("B.md"));
    let rows = table_after(&text, "| n | speed | pipeline");
    assert_eq!(rows.len(), 2, "{text}");
    for row in &rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert!(cells[7].parse::<u64>().is_ok_and(|f| f > 0) && (cells[8], cells[9]) == ("0", "0"), "{row}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_input_is_reported_not_panicked() {
    let dir = scratch("bad");
    assert_usage_error(&bench(&dir, &["core", "--timeout", "-1"]), "--timeout");
    assert_usage_error(&bench(&dir, &["core", "--cpu", "4096"]), "--cpu 4096");
    assert_usage_error(&bench(&dir, &["core", "--vadop", "no-such-binary"]), "no such file");
    assert_usage_error(&bench(&dir, &["speed", "--sections", "nope"]), "invalid value");
    assert_usage_error(&bench(&dir, &["peers", "--render", "missing.csv"]), "missing.csv");
    assert_usage_error(&bench(&dir, &["core", "--publish"]), "--quick");
    assert_usage_error(&bench(&dir, &["core", "--bodies", "100,0"]), "--bodies");
    assert_usage_error(&bench(&dir, &["peers", "--speeds", "nan"]), "--speeds");
    std::fs::write(dir.join("B.md"), "<!-- core-benchmark:end -->\n<!-- core-benchmark:begin -->\n")
        .expect("markdown written");
    assert_usage_error(&bench(&dir, &["core", "--output", "B.md"]), "unbalanced");
    assert_usage_error(
        &bench(&dir, &["--child", "--job", "retest", "--bodies", "0", "--speed", "1"]),
        "at least one sphere",
    );
    std::fs::remove_dir_all(dir).ok();
}
