//! Reliability of the `vadop` binary: save and resume give the same contacts and state as one
//! uninterrupted run, a run killed mid-way leaves a state file that resumes, the short soak
//! passes, and every bad value of the reliability options ends in `error:` and exit code 2.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn vadop(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vadop")).args(args).output().expect("the binary runs")
}

fn dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vadop-reliability-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

fn text(path: &Path) -> String {
    path.to_str().expect("utf-8 path").to_string()
}

fn ok(output: Output) -> String {
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// The contacts file without its frame column (frames restart at 1 after a resume).
fn contact_rows(path: &Path) -> Vec<String> {
    let all = std::fs::read_to_string(path).expect("contacts written");
    all.lines().skip(1).map(|line| line.split_once(',').expect("csv row").1.to_string()).collect()
}

#[test]
fn resumed_runs_match_one_uninterrupted_run() {
    let d = dir("resume");
    let (whole, half) = (d.join("whole.json"), d.join("half.json"));
    let scene = ["--bodies", "150", "--packing", "0.2", "--max-speed", "2", "--restitution", "0.8", "--quiet"];
    let run = |extra: &[&str]| ok(vadop(&[&["simulate"], &scene[..], extra].concat()));
    run(&["--frames", "12", "--save-state", &text(&whole), "--contacts", &text(&d.join("whole.csv"))]);
    run(&["--frames", "5", "--save-state", &text(&half), "--contacts", &text(&d.join("first.csv"))]);
    let resumed = ["simulate", "--resume", &text(&half), "--frames", "7", "--quiet"];
    ok(vadop(&[&resumed[..], &["--save-state", &text(&half), "--contacts", &text(&d.join("second.csv"))]].concat()));
    assert_eq!(std::fs::read(&whole).unwrap(), std::fs::read(&half).unwrap(), "the saved states differ");
    let mut parts = contact_rows(&d.join("first.csv"));
    parts.extend(contact_rows(&d.join("second.csv")));
    assert_eq!(contact_rows(&d.join("whole.csv")), parts, "the contacts differ");
    assert!(parts.len() > 100);
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn a_killed_run_leaves_a_state_that_resumes() {
    let d = dir("killed");
    let state = d.join("state.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_vadop"))
        .args(["simulate", "--bodies", "2000", "--frames", "100000", "--quiet", "--reference", "none", "--save-state", &text(&state)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the binary starts");
    let started = Instant::now();
    while !state.exists() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let it write a few more frames, then kill it wherever it is.
    std::thread::sleep(Duration::from_millis(300));
    child.kill().expect("killed");
    child.wait().expect("reaped");
    let summary = ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "2"]));
    assert!(summary.contains("frames      2 of 2"), "{summary}");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn the_short_soak_passes() {
    let summary = ok(vadop(&["soak", "--contacts", "100000", "--bodies", "300", "--quiet"]));
    assert!(summary.contains("result      pass"), "{summary}");
    assert!(summary.contains("escapes     0 bodies"), "{summary}");
    assert!(summary.contains("rules       0 contacts changed"), "{summary}");
}

#[test]
fn bad_reliability_options_are_errors() {
    let d = dir("bad");
    let saved = d.join("saved.json");
    ok(vadop(&["simulate", "--bodies", "20", "--frames", "1", "--quiet", "--save-state", &text(&saved)]));
    let garbage = d.join("garbage.json");
    std::fs::write(&garbage, "{\"format\": \"vadop-world\", \"version\": 1").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["simulate".into(), "--resume".into(), "/nonexistent/state.json".into()], "/nonexistent/state.json"),
        (vec!["simulate".into(), "--resume".into(), text(&garbage)], "EOF"),
        (vec!["simulate".into(), "--resume".into(), text(&saved), "--reference".into(), "brute".into()], "--reference"),
        (vec!["simulate".into(), "--resume".into(), text(&saved), "--bodies".into(), "5".into()], "cannot be used with"),
        (vec!["simulate".into(), "--resume".into(), text(&saved), "--dt".into(), "nan".into()], "time step"),
        (vec!["simulate".into(), "--frames".into(), "1".into(), "--save-state".into(), "/nonexistent/dir/s.json".into()], "/nonexistent/dir/s.json"),
        (vec!["simulate".into(), "--bodies".into(), "10000000000000".into()], "at most"),
        (vec!["soak".into(), "--bodies".into(), "0".into()], "at least one sphere"),
        (vec!["soak".into(), "--packing".into(), "0.7".into()], "packing fraction"),
        (vec!["soak".into(), "--max-speed".into(), "nan".into()], "max speed"),
        (vec!["soak".into(), "--contacts".into(), "-1".into()], "unexpected argument"),
    ];
    for (args, expected) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = vadop(&args);
        let err = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: ") && err.contains(expected), "{args:?}: expected {expected:?} in {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // A soak of bodies at rest stops at its frame limit instead of waiting forever for contacts.
    let rest = ok(vadop(&["soak", "--max-speed", "0", "--bodies", "50", "--max-frames", "20", "--quiet"]));
    assert!(rest.contains("20 frames, 0 contacts"), "{rest}");
    std::fs::remove_dir_all(d).ok();
}
