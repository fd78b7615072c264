//! Reliability of the `vadop` binary: save and resume give the same contacts and state as one
//! uninterrupted run, a run killed mid-way leaves a state file and a contacts file that agree and
//! resume, saved files never replace what is not a regular file, outputs never overwrite each
//! other or the inputs, memory stays flat over long runs and a run too large for the memory left
//! is refused, the short soak passes, and every bad value of the reliability options ends in
//! `error:` and exit code 2.

#[cfg(unix)]
use std::os::unix::fs::FileTypeExt;
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

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_error(output: Output, expected: &str) {
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{err}");
    assert!(err.starts_with("error: ") && err.contains(expected), "expected {expected:?} in {err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

/// `vadop args` under an address-space limit (`ulimit -v`), which the allocator cannot exceed.
fn vadop_within(kib: u64, args: &[&str]) -> Output {
    let script = format!("ulimit -v {kib} && exec \"$0\" \"$@\"");
    Command::new("sh").arg("-c").arg(script).arg(env!("CARGO_BIN_EXE_vadop")).args(args).output().expect("sh runs")
}

#[test]
fn resumed_runs_match_one_uninterrupted_run() {
    let d = dir("resume");
    let (whole, half) = (d.join("whole.json"), d.join("half.json"));
    let (whole_contacts, contacts) = (d.join("whole.csv"), d.join("contacts.csv"));
    let scene = ["--bodies", "150", "--packing", "0.2", "--max-speed", "2", "--restitution", "0.8", "--quiet"];
    let run = |extra: &[&str]| ok(vadop(&[&["simulate"], &scene[..], extra].concat()));
    run(&["--frames", "12", "--save-state", &text(&whole), "--contacts", &text(&whole_contacts)]);
    run(&["--frames", "5", "--save-state", &text(&half), "--contacts", &text(&contacts)]);
    // The contacts file is continued, its frame numbers going on from the saved run's.
    let resumed = ["simulate", "--resume", &text(&half), "--frames", "7", "--quiet"];
    ok(vadop(&[&resumed[..], &["--save-state", &text(&half), "--contacts", &text(&contacts)]].concat()));
    assert_eq!(bytes(&whole), bytes(&half), "the saved states differ");
    assert_eq!(bytes(&whole_contacts), bytes(&contacts), "the contacts differ");
    assert!(bytes(&contacts).iter().filter(|&&b| b == b'\n').count() > 100);
    std::fs::remove_dir_all(d).ok();
}

/// Shapes in detect mode with contact ends: the resumed run's contacts file, ends included, is
/// byte for byte one run's (the ends once differed by about 1e-9 s, their search starting where
/// the resumed run's first window began).
#[test]
fn resumed_contact_ends_of_shapes_match_one_run() {
    let d = dir("resume-ends");
    let (state, whole, contacts) = (d.join("state.json"), d.join("whole.csv"), d.join("contacts.csv"));
    let scene = ["--kind", "shapes", "--bodies", "300", "--mode", "detect", "--contact-ends", "--quiet"];
    let run = |extra: &[&str]| ok(vadop(&[&["simulate"], &scene[..], extra].concat()));
    run(&["--frames", "12", "--contacts", &text(&whole)]);
    run(&["--frames", "5", "--save-state", &text(&state), "--contacts", &text(&contacts)]);
    ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "7", "--quiet", "--contacts", &text(&contacts)]));
    let ends = String::from_utf8(bytes(&whole)).unwrap().lines().filter(|l| l.contains(",body-end,")).count();
    assert!(ends > 100, "only {ends} contact ends");
    assert_eq!(bytes(&whole), bytes(&contacts), "the contacts differ");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn a_killed_run_leaves_a_state_and_contacts_that_agree_and_resume() {
    let d = dir("killed");
    let (state, contacts, whole) = (d.join("state.json"), d.join("contacts.csv"), d.join("whole.csv"));
    // Fast, dense bodies: a frame's contacts overflow the write buffer, so a kill may leave rows
    // of a frame the state has not reached, or half a row.
    let scene = ["--bodies", "1000", "--packing", "0.2", "--max-speed", "3", "--reference", "none", "--quiet"];
    let mut child = Command::new(env!("CARGO_BIN_EXE_vadop"))
        .args(["simulate", "--frames", "100000", "--save-state", &text(&state), "--contacts", &text(&contacts)])
        .args(scene)
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
    let saved: serde_json::Value = serde_json::from_slice(&bytes(&state)).expect("the state parses");
    let frames_saved = (saved["time"].as_f64().expect("a time") * 30.0).round() as u64;
    let summary = ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "2", "--contacts", &text(&contacts)]));
    assert!(summary.contains("frames      2 of 2"), "{summary}");
    assert!(summary.contains(&format!("(frame {frames_saved})")), "{summary}");
    // The same frames in one go give the same contacts, numbered the same, each exactly once.
    let total = (frames_saved + 2).to_string();
    ok(vadop(&[&["simulate", "--frames", &total, "--contacts", &text(&whole)], &scene[..]].concat()));
    assert_eq!(bytes(&whole), bytes(&contacts), "{frames_saved} frames saved");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn resuming_drops_contact_rows_beyond_the_saved_state() {
    let d = dir("rows-beyond");
    let (state, contacts, whole) = (d.join("state.json"), d.join("contacts.csv"), d.join("whole.csv"));
    let scene = ["--bodies", "200", "--packing", "0.2", "--max-speed", "2", "--quiet"];
    let run = |extra: &[&str]| ok(vadop(&[&["simulate"], &scene[..], extra].concat()));
    run(&["--frames", "6", "--contacts", &text(&whole)]);
    run(&["--frames", "4", "--save-state", &text(&state), "--contacts", &text(&contacts)]);
    // What a run killed in frame 5 leaves behind: rows of frame 5 and one cut short.
    let frame_five: String = String::from_utf8(bytes(&whole))
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("5,"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(!frame_five.is_empty());
    let mut killed = bytes(&contacts);
    killed.extend_from_slice(frame_five.as_bytes());
    killed.extend_from_slice(b"5,0.16");
    std::fs::write(&contacts, killed).unwrap();
    ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "2", "--quiet", "--contacts", &text(&contacts)]));
    assert_eq!(bytes(&whole), bytes(&contacts));

    // A contacts file that is not this run's, or another --dt, is refused and left as it was.
    let foreign = d.join("foreign.csv");
    std::fs::write(&foreign, "frame,time\n1,0.5\n").unwrap();
    let resume = |contacts: &Path, dt: &str| {
        vadop(&["simulate", "--resume", &text(&state), "--frames", "1", "--dt", dt, "--contacts", &text(contacts)])
    };
    assert_error(resume(&foreign, "0.03333333333333333"), "not a vadop contacts file");
    assert_eq!(bytes(&foreign), b"frame,time\n1,0.5\n");
    assert_error(resume(&contacts, "0.025"), "not a whole number of frames");
    assert_error(resume(&contacts, "0.016666666666666666"), "is not in frame");
    assert_eq!(bytes(&whole), bytes(&contacts));
    std::fs::remove_dir_all(d).ok();
}

/// A world saved by the library after a body was removed and another took its slot resumes in the
/// CLI, and the contacts file names the newcomer by its handle's number, slot + 2^32 x generation,
/// never by the removed body's.
#[test]
fn contacts_of_a_reused_slot_name_the_body_by_its_handle() {
    use glam::DVec3;
    use vadop::{BoxBounds, Sphere, World, WorldConfig};
    let d = dir("reused-slot");
    let (state, contacts) = (d.join("state.json"), d.join("contacts.csv"));
    let at = |x: f64, speed: f64| Sphere {
        position: DVec3::new(x, 5.0, 5.0),
        velocity: DVec3::new(speed, 0.0, 0.0),
        radius: 0.5,
        mass: 1.0,
    };
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    let removed = world.add_sphere(at(2.0, 0.0)).unwrap();
    let target = world.add_sphere(at(8.0, 0.0)).unwrap();
    world.remove_sphere(removed).unwrap();
    let bullet = world.add_sphere(at(2.0, 30.0)).unwrap();
    assert_eq!((bullet.index(), bullet.generation(), bullet.to_bits()), (0, 1, 1 << 32));
    world.save(&state).unwrap();
    ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "6", "--quiet", "--contacts", &text(&contacts)]));
    let rows = String::from_utf8(bytes(&contacts)).unwrap();
    // The bullet hits the target at t = 1/6.
    let hit =
        rows.lines().skip(1).find(|row| row.contains(",body,")).unwrap_or_else(|| panic!("no pair contact in\n{rows}"));
    let cells: Vec<&str> = hit.split(',').collect();
    assert_eq!(cells[2..5], ["4294967296", "body", &target.to_bits().to_string()], "{hit}");
    assert!(rows.lines().skip(1).all(|row| row.split(',').nth(2) != Some("0")), "{rows}");
    assert!(ok(vadop(&["simulate", "--help"])).contains("slot + 2^32 x generation"));
    std::fs::remove_dir_all(d).ok();
}

#[cfg(unix)]
#[test]
fn saved_files_replace_only_regular_files() {
    let d = dir("targets");
    let fifo = d.join("fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs").success());
    let run =
        |flag: &str, path: &Path| vadop(&["simulate", "--bodies", "20", "--frames", "1", "--quiet", flag, &text(path)]);
    for flag in ["--save-state", "--save-scene"] {
        for target in [fifo.as_path(), Path::new("/dev/null"), d.as_path()] {
            assert_error(run(flag, target), "not a regular file");
        }
    }
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    // A link is followed: the file it points to is written, even one not there yet, and the
    // link stays a link.
    let (link, file) = (d.join("link.json"), d.join("file.json"));
    std::os::unix::fs::symlink("file.json", &link).unwrap();
    ok(run("--save-state", &link));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(bytes(&file).starts_with(b"{\"format\":\"vadop-world\""));
    let fifo_link = d.join("fifo-link");
    std::os::unix::fs::symlink(&fifo, &fifo_link).unwrap();
    assert_error(run("--save-scene", &fifo_link), "not a regular file");
    // Streamed outputs write into what the path names.
    ok(run("--contacts", Path::new("/dev/null")));
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn outputs_never_overwrite_each_other_or_the_inputs() {
    let d = dir("same-file");
    let (state, out) = (d.join("state.json"), d.join("out"));
    ok(vadop(&["simulate", "--bodies", "20", "--frames", "1", "--quiet", "--save-state", &text(&state)]));
    let saved = bytes(&state);
    let spelled_again = d.join(".").join("out");
    let cases: [(&[&str], &str); 6] = [
        (&["--csv", &text(&out), "--json", &text(&spelled_again)], "--json"),
        (&["--contacts", &text(&out), "--save-scene", &text(&out)], "--save-scene"),
        (&["--json", &text(&out), "--save-state", &text(&out)], "--save-state"),
        (&["--resume", &text(&state), "--contacts", &text(&state)], "is the file --resume reads"),
        (&["--resume", &text(&state), "--csv", &text(&state)], "is the file --resume reads"),
        (&["--scene", &text(&state), "--save-scene", &text(&state)], "is the file --scene reads"),
    ];
    for (args, expected) in cases {
        assert_error(vadop(&[&["simulate", "--frames", "1", "--quiet"], args].concat()), expected);
        assert!(!out.exists(), "{args:?} wrote before refusing");
    }
    assert_eq!(bytes(&state), saved, "the resumed state changed");
    // Saving over the state resumed from is how a run goes on.
    ok(vadop(&["simulate", "--resume", &text(&state), "--frames", "1", "--quiet", "--save-state", &text(&state)]));
    std::fs::remove_dir_all(d).ok();
}

#[cfg(unix)]
#[test]
fn long_quiet_runs_keep_memory_flat_and_huge_ones_are_refused() {
    // Half a million frames of one body in 64 MiB of address space (it needs about 12): keeping
    // a 136-byte row per frame would take 71 MiB and abort.
    let long =
        vadop_within(64 << 10, &["simulate", "--bodies", "1", "--frames", "500000", "--reference", "none", "--quiet"]);
    assert!(long.status.success(), "{:?}: {}", long.status, String::from_utf8_lossy(&long.stderr));
    for bodies in ["100000000", "1000000"] {
        let huge = vadop_within(256 << 10, &["simulate", "--bodies", bodies, "--frames", "1", "--reference", "none"]);
        assert_error(huge, &format!("a run of {bodies} bodies needs about"));
    }
    // One world of 300000 bodies fits in 256 MiB (192 MB), two do not.
    let checked = vadop_within(256 << 10, &["simulate", "--bodies", "300000", "--frames", "1", "--reference", "vadop"]);
    assert_error(checked, "a run of 300000 bodies with its reference world needs about");
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
        (
            vec!["simulate".into(), "--resume".into(), text(&saved), "--bodies".into(), "5".into()],
            "cannot be used with",
        ),
        (vec!["simulate".into(), "--resume".into(), text(&saved), "--dt".into(), "nan".into()], "time step"),
        (
            vec![
                "simulate".into(),
                "--frames".into(),
                "1".into(),
                "--save-state".into(),
                "/nonexistent/dir/s.json".into(),
            ],
            "/nonexistent/dir/s.json",
        ),
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

/// A run the core refuses at its first step (a bad time step, an absurd speed, bodies
/// overlapping at the start) leaves every existing output as it was: they once kept only a
/// header.
#[test]
fn a_refused_run_leaves_existing_outputs_as_they_were() {
    let d = dir("refused");
    let scene = |name: &str, spheres: &str| {
        let path = d.join(name);
        let bounds = r#"{"min": [0, 0, 0], "max": [10, 10, 10]}"#;
        std::fs::write(&path, format!(r#"{{"bounds": {bounds}, "spheres": [{spheres}]}}"#)).unwrap();
        text(&path)
    };
    let ball =
        |x: f64, v: f64| format!(r#"{{"position": [{x}, 5, 5], "velocity": [{v}, 0, 0], "radius": 0.5, "mass": 1}}"#);
    let absurd = scene("absurd.json", &ball(5.0, 1e12));
    let overlap = scene("overlap.json", &format!("{}, {}", ball(5.0, 0.0), ball(5.5, 0.0)));
    let cases: [(Vec<&str>, &str); 3] = [
        (vec!["--bodies", "20", "--dt", "-1"], "time step"),
        (vec!["--scene", &absurd], "box lengths in one frame"),
        (vec!["--scene", &overlap], "overlap"),
    ];
    let outputs = ["--csv", "--json", "--contacts", "--save-scene"];
    for (run, expected) in &cases {
        let mut args = vec!["simulate", "--frames", "2"];
        args.extend(run);
        let paths: Vec<String> = outputs.iter().map(|flag| text(&d.join(format!("{}.out", &flag[2..])))).collect();
        for (flag, path) in outputs.iter().zip(&paths) {
            std::fs::write(path, format!("kept {flag}\n")).unwrap();
            args.extend([*flag, path.as_str()]);
        }
        assert_error(vadop(&args), expected);
        for (flag, path) in outputs.iter().zip(&paths) {
            assert_eq!(bytes(Path::new(path)), format!("kept {flag}\n").as_bytes(), "{run:?} {flag}");
        }
    }
    std::fs::remove_dir_all(d).ok();
}

/// Inputs are read within the memory left: a device that never ends is refused at once, a file
/// larger than the memory left before it is read, and a state only from a regular file.
#[cfg(unix)]
#[test]
fn endless_or_huge_inputs_are_refused_before_they_fill_memory() {
    let started = Instant::now();
    assert_error(vadop(&["simulate", "--scene", "/dev/zero"]), "/dev/zero: expected value at line 1 column 1");
    assert_error(vadop(&["simulate", "--resume", "/dev/zero"]), "--resume /dev/zero: not a regular file");
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    // A sparse file of 64 GiB takes no disk, and far more memory than 1 GiB of address space.
    let d = dir("huge");
    let huge = d.join("huge.json");
    std::fs::File::create(&huge).unwrap().set_len(64 << 30).unwrap();
    for flag in ["--scene", "--resume"] {
        let output = vadop_within(1 << 20, &["simulate", flag, &text(&huge)]);
        assert_error(output, "a file of 64.0 GiB needs about 128.0 GiB of memory, but only");
    }
    std::fs::remove_dir_all(d).ok();
}

/// More threads than cores are not used: 100000 once ran for minutes, 1000 took 15 s for what
/// takes 0.04 s, and the contacts are the same whatever the count.
#[test]
fn thread_counts_beyond_the_cores_cost_nothing() {
    let d = dir("threads");
    let run = |threads: &str| {
        let contacts = d.join(format!("contacts-{threads}.csv"));
        let started = Instant::now();
        ok(vadop(&[
            "simulate",
            "--bodies",
            "200",
            "--frames",
            "2",
            "--threads",
            threads,
            "--quiet",
            "--contacts",
            &text(&contacts),
        ]));
        (started.elapsed(), bytes(&contacts))
    };
    let (took, contacts) = run("100000");
    assert!(took < Duration::from_secs(10), "{took:?}");
    assert_eq!(contacts, run("1").1);
    std::fs::remove_dir_all(d).ok();
}
