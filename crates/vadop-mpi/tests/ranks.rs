//! `mpirun -np K vadop-mpi simulate` against `vadop simulate` on one process: the contacts files
//! are the same bytes for K = 1 to 4 (the paper scene, the stream, the gas and heavy tails, every
//! continuous method, detect mode), a world saved by either resumes on the other with any K, and
//! what cannot be split (simulate mode, a ghost layer too thin, a rank that dies) ends the run
//! with a clear error naming what went wrong.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn mpi_binary() -> &'static str {
    env!("CARGO_BIN_EXE_vadop-mpi")
}

/// The one-process `vadop` binary, built beside this crate's by `cargo test --workspace`.
fn vadop_binary() -> PathBuf {
    let path = Path::new(mpi_binary()).with_file_name("vadop");
    assert!(path.exists(), "{} is missing: run the tests with --workspace, which builds vadop-cli too", path.display());
    path
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vadop-mpi-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `mpirun -np ranks vadop-mpi simulate args...`, on as many ranks as asked whatever the cores.
fn mpirun(ranks: usize, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new("mpirun");
    command.args(["--oversubscribe", "--allow-run-as-root", "-np", &ranks.to_string(), mpi_binary(), "simulate"]);
    command.args(args).env("OMPI_MCA_mpi_yield_when_idle", "1");
    for (key, value) in env {
        command.env(key, value);
    }
    command.output().expect("mpirun runs (Debian's openmpi-bin)")
}

fn vadop(args: &[&str]) -> Output {
    Command::new(vadop_binary()).arg("simulate").args(args).output().unwrap()
}

fn succeeded(output: &Output, what: &str) {
    assert!(output.status.success(), "{what} failed: {}", String::from_utf8_lossy(&output.stderr));
}

/// A path as a string that lives as long as the test process.
fn leak(path: &Path) -> &'static str {
    path.to_str().unwrap().to_string().leak()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

/// The contacts of `scene` (arguments of both commands) from one process and from K ranks.
fn same_contacts_for_every_rank_count(name: &str, scene: &[&str]) {
    let one = scratch(&format!("{name}-one.csv"));
    let mut args = vec!["--mode", "detect", "--reference", "none", "--quiet", "--contacts", one.to_str().unwrap()];
    args.extend_from_slice(scene);
    succeeded(&vadop(&args), "vadop simulate");
    let expected = read(&one);
    assert!(expected.lines().count() > 200, "{name}: a scene with contacts to compare ({})", expected.lines().count());
    assert!(expected.contains(",body,"), "{name}: pair contacts too");
    for ranks in 1..=4 {
        let split = scratch(&format!("{name}-{ranks}.csv"));
        let mut args = vec!["--quiet", "--contacts", split.to_str().unwrap()];
        args.extend_from_slice(scene);
        succeeded(&mpirun(ranks, &args, &[]), &format!("{name} on {ranks} ranks"));
        assert!(read(&split) == expected, "{name}: {ranks} ranks differ from one process");
    }
}

#[test]
fn the_paper_scene_gives_one_process_contacts_on_every_rank_count() {
    same_contacts_for_every_rank_count("paper", &["--bodies", "3000", "--max-speed", "2", "--frames", "25"]);
}

#[test]
fn the_stream_gives_one_process_contacts_on_every_rank_count() {
    same_contacts_for_every_rank_count(
        "stream",
        &["--kind", "stream", "--bodies", "2000", "--max-speed", "5", "--frames", "15", "--method", "vadop"],
    );
}

#[test]
fn the_gas_gives_one_process_contacts_on_every_rank_count() {
    same_contacts_for_every_rank_count(
        "gas",
        &[
            "--kind",
            "gas",
            "--bodies",
            "2500",
            "--packing",
            "0.2",
            "--max-speed",
            "1",
            "--frames",
            "15",
            "--method",
            "grid",
        ],
    );
}

#[test]
fn heavy_tails_under_gravity_give_one_process_contacts() {
    let scene =
        ["--kind", "heavy-tail", "--bodies", "1500", "--max-speed", "0.5", "--frames", "20", "--gravity", "0,0,-9.81"];
    same_contacts_for_every_rank_count("heavy-tail", &scene);
}

#[test]
fn a_saved_world_resumes_on_any_rank_count_and_on_one_process() {
    let scene = ["--bodies", "2000", "--max-speed", "3", "--seed", "4"];
    let whole = scratch("resume-whole.csv");
    let mut args = vec!["--mode", "detect", "--reference", "none", "--quiet", "--frames", "20"];
    args.extend_from_slice(&scene);
    succeeded(&vadop(&[&args[..], &["--contacts", whole.to_str().unwrap()]].concat()), "vadop simulate");
    let (first, state) = (scratch("resume-first.csv"), scratch("resume-state.json"));
    let mut split = vec!["--quiet", "--frames", "10", "--contacts", first.to_str().unwrap()];
    split.extend_from_slice(&scene);
    split.extend_from_slice(&["--save-state", state.to_str().unwrap()]);
    succeeded(&mpirun(3, &split, &[]), "the first half on 3 ranks");
    let (on_two, on_one) = (scratch("resume-two.csv"), scratch("resume-one.csv"));
    let state = leak(&state);
    let second = |output: &'static str| ["--quiet", "--frames", "10", "--resume", state, "--contacts", output];
    let (on_two_path, on_one_path) = (leak(&on_two), leak(&on_one));
    succeeded(&mpirun(2, &second(on_two_path), &[]), "the second half on 2 ranks");
    succeeded(&vadop(&second(on_one_path)), "the second half on one process");
    let body = |path: &Path| read(path).lines().skip(1).map(|l| format!("{l}\n")).collect::<String>();
    let joined = read(&first) + &body(&on_two);
    assert!(joined == read(&whole), "3 ranks then 2 differ from one run");
    assert!(read(&first) + &body(&on_one) == read(&whole), "3 ranks then one process differ from one run");
}

#[test]
fn simulate_mode_is_refused_with_the_reason() {
    let output = mpirun(2, &["--mode", "simulate", "--frames", "2"], &[]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("simulate mode is not split over ranks yet"), "{stderr}");
    assert_eq!(stderr.matches("simulate mode is not split").count(), 1, "told once, by rank 0: {stderr}");
}

#[test]
fn a_ghost_layer_too_thin_is_an_error_naming_a_body_and_its_rank() {
    let output = mpirun(2, &["--frames", "3", "--ghost-width", "0.5"], &[]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("farther than the ghost layer (0.5)") && stderr.contains("rank ") && stderr.contains("body "),
        "{stderr}"
    );
}

#[test]
fn a_rank_that_dies_ends_the_run_with_an_error_naming_it() {
    let output = mpirun(3, &["--frames", "10", "--bodies", "2000"], &[("VADOP_MPI_FAIL", "1:4")]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("process rank 1"), "mpirun names the dead rank: {stderr}");
}
