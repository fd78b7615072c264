//! `vadop simulate`: builds the scene and the world (or loads a saved one), steps it frame by
//! frame (with a reference method stepped alongside when asked, to count missed and extra pair
//! contacts), streams the contacts and the per-frame rows to their files, and hands the totals to
//! the report. This file owns the frame loop, the accuracy comparison and the numbering of frames
//! across a resume; the arguments live in `args`, the files read and written in `outputs`. It
//! never validates physics input itself: the core library checks scenes, pools, angles,
//! restitution and time steps, and its messages are what the user sees. A frame that fails stops
//! the run, but what was simulated before it is still reported and written. Nothing it keeps grows
//! with the frames.

mod args;
mod outputs;

pub use args::SimulateArgs;

use crate::report::{
    self, Accuracy, Conservation, FrameRow, FrameTotals, FramesCsv, Motion, PoolInfo, Resting, RunInfo, SceneInfo,
    Summary,
};
use crate::CliResult;
use args::{KindArg, ModeArg, ReferenceArg, PILE_GRAVITY, PILE_RESTITUTION};
use outputs::{ContactWriter, Files, Outputs};
use std::path::Path;
use std::time::{Duration, Instant};
use vadop::memory;
use vadop::scene::{GeneratedScene, Scene, SceneLayout, ShapesScene, SphereScene, MAX_SCENE_BODIES};
use vadop::{BodyHandle, Contact, Method, Mode, Rest, Touched, VadopError, World, WorldConfig};

/// Scenes up to this many moving bodies are checked against brute force unless told otherwise.
const DEFAULT_REFERENCE_MAX_BODIES: usize = 3000;
/// The same for scenes with shapes other than spheres: brute force tests every pair, and a pair
/// test of shapes costs about a hundred times one of spheres (an iterative search, not a closed
/// form), so this many take about as long a frame as 3000 spheres.
const DEFAULT_REFERENCE_MAX_SHAPE_BODIES: usize = 300;
/// Runs shorter than this finish before a progress bar would help.
const PROGRESS_DELAY: Duration = Duration::from_secs(2);

/// The core's message, with phi in degrees as the user gave it (the core works in radians).
fn describe(error: VadopError) -> String {
    match error {
        VadopError::BadPhi { got, rho } => format!(
            "--phi {} degrees: phi must lie in [rho, 90] degrees, where rho = {:.4} degrees is the covering radius of the pool, so that every pair of bodies shares an axis",
            got.to_degrees(),
            rho.to_degrees()
        ),
        other => other.to_string(),
    }
}

pub fn run(args: &SimulateArgs) -> CliResult<()> {
    let files = Files::check(args)?;
    if args.floor && args.kind != KindArg::Shapes {
        return Err("--floor lays a floor under --kind shapes only".to_string());
    }
    if let Some(path) = &args.resume {
        return resume(path, files, args);
    }
    let config = WorldConfig {
        method: args.method,
        mode: match args.mode {
            ModeArg::Detect => Mode::Detect,
            ModeArg::Simulate => Mode::Simulate,
        },
        pool_axes: args.pool.0,
        phi: args.phi.map(f64::to_radians),
        restitution: args.restitution.unwrap_or(if args.kind == KindArg::Pile { PILE_RESTITUTION } else { 1.0 }),
        friction: args.friction,
        contact_duration: args.contact_duration,
        threads: args.threads,
        contact_ends: args.contact_ends,
        gravity: args.gravity.unwrap_or(if args.kind == KindArg::Pile { PILE_GRAVITY } else { glam::DVec3::ZERO }),
    };
    let (scene, source) = match &args.scene {
        Some(path) => {
            let scene = Scene::load(path).map_err(describe)?;
            let layout = scene.layout();
            check_memory(layout.count(), reference_method(args, &layout, config.method))?;
            (scene, format!("scene file {}", path.display()))
        }
        None => {
            // Before generating, so that a scene too large is refused before it is built. Only a
            // valid scene's size is worth checking: the core names bad parameters better.
            if args.bodies <= MAX_SCENE_BODIES {
                let expected = match args.kind {
                    KindArg::Shapes => SceneLayout { bodies: args.bodies, ..SceneLayout::default() },
                    _ => SceneLayout { spheres: args.bodies, ..SceneLayout::default() },
                };
                check_memory(args.bodies, reference_method(args, &expected, config.method))?;
            }
            generate(args)?
        }
    };
    let mut scene = scene;
    if let Some(periodic) = args.periodic {
        scene.bounds = scene.bounds.with_periodic(periodic);
    }
    let layout = scene.layout();
    let reference = reference_method(args, &layout, config.method);
    let world = scene.world(config).map_err(describe)?;
    let reference_world = match reference {
        Some(method) => Some(scene.world(WorldConfig { method, ..config }).map_err(describe)?),
        None => None,
    };
    // The scene is kept only to be saved, once the first frame has stepped (so that a run the
    // core refuses replaces no file), and dropped then: at a million bodies it is worth giving back.
    let save = files.save_scene.is_some().then_some(scene);
    run_world(world, reference_world, save, Origin { source, frames_done: 0, layout: Some(layout) }, files, args)
}

/// The scene `--kind` asks for, and where it came from, for the summary.
fn generate(args: &SimulateArgs) -> CliResult<(Scene, String)> {
    let (velocities, what) = match args.kind {
        KindArg::Paper => SphereScene::Paper.velocities(args.max_speed, args.spread),
        KindArg::Gas => SphereScene::Gas.velocities(args.max_speed, args.spread),
        KindArg::Stream => SphereScene::Stream.velocities(args.max_speed, args.spread),
        KindArg::HeavyTail => SphereScene::HeavyTail.velocities(args.max_speed, args.spread),
        KindArg::Pile => (
            SphereScene::Paper.velocities(args.max_speed, args.spread).0,
            format!("granular pile (falling from the paper scene, speeds up to {} diameters/frame", args.max_speed),
        ),
        KindArg::Shapes => {
            let shapes = ShapesScene {
                bodies: args.bodies,
                packing_fraction: args.packing,
                max_speed: args.max_speed,
                max_spin: args.spin,
                floor: args.floor,
                seed: args.seed,
            };
            let floor = if args.floor { ", on a floor mesh" } else { "" };
            let what = format!(
                "mixed shapes (speeds up to {} diameters/frame, spins up to {} rad/frame{floor}, seed {})",
                args.max_speed, args.spin, args.seed
            );
            return Ok((shapes.build().map_err(describe)?, what));
        }
    };
    let generated = GeneratedScene {
        bodies: args.bodies,
        packing_fraction: args.packing,
        velocities,
        radius: 0.5,
        seed: args.seed,
    };
    Ok((generated.build().map_err(describe)?, format!("{what}, seed {})", args.seed)))
}

/// The method stepped alongside a run of a scene of `layout`, if any.
fn reference_method(args: &SimulateArgs, layout: &SceneLayout, method: Method) -> Option<Method> {
    match args.reference {
        Some(ReferenceArg::Brute) => Some(Method::Brute),
        Some(ReferenceArg::Vadop) => Some(Method::Vadop),
        Some(ReferenceArg::None) => None,
        None => {
            let shapes = layout.bodies + layout.static_bodies > 0;
            let most = if shapes { DEFAULT_REFERENCE_MAX_SHAPE_BODIES } else { DEFAULT_REFERENCE_MAX_BODIES };
            // Checking brute force against itself would only double the cost.
            (layout.spheres + layout.bodies <= most && method != Method::Brute).then_some(Method::Brute)
        }
    }
}

/// Refuses a run whose worlds (the run's, and the reference's) cannot fit in the memory left.
fn check_memory(bodies: usize, reference: Option<Method>) -> CliResult<()> {
    let worlds = if reference.is_some() { 2 } else { 1 };
    let needed = memory::world_bytes(bodies).saturating_mul(worlds);
    let with = if reference.is_some() { " with its reference world" } else { "" };
    memory::check(needed).map_err(|shortfall| format!("a run of {bodies} bodies{with} {shortfall}"))
}

/// `--resume FILE`: the saved world, stepped on without a reference (a reference would need the
/// state it had when the world was saved), its frames numbered on from the saved run's.
fn resume(path: &Path, files: Files, args: &SimulateArgs) -> CliResult<()> {
    if matches!(args.reference, Some(ReferenceArg::Brute | ReferenceArg::Vadop)) {
        return Err("--resume cannot be combined with --reference: the reference's state was not saved".to_string());
    }
    // A saved state is a regular file (--save-state writes nothing else), and the core reads it
    // whole: a device or FIFO could deliver without end, and a file too large is refused unread.
    if std::fs::metadata(path).is_ok_and(|meta| !meta.is_file()) {
        return Err(format!("--resume {}: not a regular file, so not a state saved by --save-state", path.display()));
    }
    memory::check_input(path).map_err(|e| format!("--resume {}: {e}", path.display()))?;
    let world = World::load(path).map_err(describe)?;
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(describe(VadopError::BadTimeStep(args.dt)));
    }
    let frames_done = whole_frames(world.time(), args.dt).ok_or_else(|| {
        format!(
            "--resume {}: the saved time {} is not a whole number of frames of --dt {}; resume with the --dt the run was saved with, so that frame numbers go on",
            path.display(),
            world.time(),
            args.dt
        )
    })?;
    let source = format!("saved world {} at time {} (frame {frames_done})", path.display(), world.time());
    let save = files.save_scene.is_some().then(|| Scene::from_world(&world));
    // The world's handles are its own, not a scene's entries.
    run_world(world, None, save, Origin { source, frames_done, layout: None }, files, args)
}

/// Time a frame may end off `frames * dt` in a world that added `dt` frame after frame: a
/// hundredth of a frame, plus a millionth of the time for the rounding that piles up over
/// millions of frames.
fn slack(time: f64, dt: f64) -> f64 {
    0.01 * dt + 1e-6 * time.abs()
}

/// How many frames of `dt` make `time`, when it is a whole number of them.
fn whole_frames(time: f64, dt: f64) -> Option<u64> {
    let frames = (time / dt).round();
    ((0.0..9e15).contains(&frames) && (time - frames * dt).abs() <= slack(time, dt)).then_some(frames as u64)
}

/// Where a run's world came from.
struct Origin {
    /// What the summary calls it: a generated scene, a scene file, a saved world.
    source: String,
    /// Frames stepped before: a resumed run's frame numbers go on from them.
    frames_done: u64,
    /// The scene's body lists, which name its entries in errors; none for a saved world, whose
    /// handles are its own.
    layout: Option<SceneLayout>,
}

/// Steps `world` (and `reference_world` alongside) from frame `origin.frames_done` on, streaming
/// the outputs, then reports. `scene` is what --save-scene writes, when given. Nothing is written
/// before the first frame has stepped: the core checks the time step, the speeds and the
/// overlaps at the first step, and a run it refuses must leave existing files as they were.
fn run_world(
    mut world: World,
    reference_world: Option<World>,
    scene: Option<Scene>,
    origin: Origin,
    files: Files,
    args: &SimulateArgs,
) -> CliResult<()> {
    let config = world.config();
    let mut scene = scene;
    let mut open = || -> CliResult<Outputs> {
        let outputs = Outputs::open(args, origin.frames_done)?;
        if let (Some(path), Some(scene)) = (&files.save_scene, scene.take()) {
            scene.save(path).map_err(describe)?;
        }
        Ok(outputs)
    };
    let info = RunInfo {
        scene: SceneInfo::of(&world, origin.source, args.dt)?,
        method: match config.method {
            Method::Auto if world.on_event_loop() => "auto (event loop)".to_string(),
            Method::Auto => format!("auto ({})", config.method.resolve().name()),
            method => method.name().to_string(),
        },
        mode: match config.mode {
            Mode::Detect => "detect",
            Mode::Simulate => "simulate",
        }
        .to_string(),
        dt: args.dt,
        restitution: config.restitution,
        friction: config.friction,
        gravity: config.gravity.to_array(),
        frames_requested: args.frames,
    };
    let start = Motion::of(&world);
    let frames = origin.frames_done + 1..=origin.frames_done + args.frames;
    let save_state = files.save_state.as_deref();
    let mut outputs = None;
    let mut outcome =
        step_frames(&mut world, reference_world, args, frames, save_state, (&mut outputs, &mut open), origin.layout);
    let Outputs { csv, json, contacts } = outputs.unwrap_or_default();
    // A failed flush loses contacts or rows, not frames: it is reported like a failed frame.
    for finished in [contacts.map(ContactWriter::finish), csv.map(FramesCsv::finish)].into_iter().flatten() {
        if let Err(e) = finished {
            outcome.failure.get_or_insert(e);
        }
    }
    let pool = Some(world.pool()).filter(|_| matches!(world.method(), Method::Vadop | Method::SweptKdop)).map(|pool| {
        let rho = pool.covering_radius();
        PoolInfo {
            axes: pool.len(),
            covering_radius_deg: rho.to_degrees(),
            phi_deg: world.config().phi.unwrap_or(rho).to_degrees(),
            axes_per_body: outcome.frames.axes_per_body(info.scene.bodies),
        }
    });
    let conservation = (config.mode == Mode::Simulate).then(|| {
        // Spins are worth reporting once anything can spin: shapes, static bodies, friction.
        let spins = info.scene.may_spin() || config.friction > 0.0;
        Conservation::new(&start, &Motion::of(&world), spins)
    });
    let mut summary =
        Summary::new(info, &outcome.frames, pool, outcome.accuracy, conservation, outcome.failure.clone());
    summary.resting = resting(&world);
    if !args.quiet && outcome.frames.frames > 0 {
        report::print(&summary.to_string())?;
    }
    let written = json.map_or(Ok(()), |json| json.finish(&summary));
    match outcome.failure {
        Some(message) => Err(message),
        None => written,
    }
}

/// Under the rest rule (simulate mode, gravity, restitution below 1): how many moving bodies lie
/// still and slide at the end.
fn resting(world: &World) -> Option<Resting> {
    let config = world.config();
    if !(config.mode == Mode::Simulate && config.restitution < 1.0 && config.gravity != glam::DVec3::ZERO) {
        return None;
    }
    let mut resting = Resting { still: 0, sliding: 0, bodies: 0 };
    for (handle, _) in world.bodies().filter(|(_, b)| b.mass.is_finite()) {
        resting.bodies += 1;
        match world.rest(handle) {
            Ok(Rest::Still) => resting.still += 1,
            Ok(Rest::Sliding(_)) => resting.sliding += 1,
            _ => {}
        }
    }
    Some(resting)
}

/// What the frame loop produced.
struct Outcome {
    frames: FrameTotals,
    accuracy: Option<Accuracy>,
    /// Why the run stopped early.
    failure: Option<String>,
}

/// Steps `world` (and `reference` alongside) through `frames`, or until a frame fails, writing
/// each frame's contacts and row as it completes, into the outputs `open` makes once the first
/// frame has stepped. `layout` names a scene's entries in the errors of the first step, which
/// checks the scene as a whole.
fn step_frames(
    world: &mut World,
    mut reference: Option<World>,
    args: &SimulateArgs,
    frames: std::ops::RangeInclusive<u64>,
    save_state: Option<&Path>,
    (outputs, open): (&mut Option<Outputs>, &mut dyn FnMut() -> CliResult<Outputs>),
    layout: Option<SceneLayout>,
) -> Outcome {
    let simulate = world.config().mode == Mode::Simulate;
    let mut accuracy = reference.as_ref().map(|r| Accuracy {
        reference: r.config().method.name().to_string(),
        identical_paths: !simulate,
        ..Accuracy::default()
    });
    let mut totals = FrameTotals::default();
    let mut failure = None;
    let bar = report::progress_bar(args.frames, "frames");
    let started = Instant::now();
    let mut may_reveal = !args.quiet;
    // Contacts with these are told apart from those between moving bodies.
    let statics: Vec<BodyHandle> = world.bodies().filter(|(_, b)| !b.mass.is_finite()).map(|(h, _)| h).collect();
    for frame in frames {
        let start = Instant::now();
        match world.step(args.dt) {
            Ok(_) => {}
            Err(e) => {
                // A step fails before changing anything, so a failure of the run's first step is
                // about the scene as given, not about anything a frame did: its entries name the
                // bodies.
                let e = match layout {
                    Some(layout) => layout.name_entries(e),
                    None => e,
                };
                let when =
                    if totals.frames == 0 { "before the first frame".to_string() } else { format!("frame {frame}") };
                failure = Some(format!("{when}: {}", describe(e)));
                break;
            }
        };
        let wall_seconds = start.elapsed().as_secs_f64();
        let outputs = match outputs {
            Some(outputs) => outputs,
            None => match open() {
                Ok(opened) => outputs.insert(opened),
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            },
        };
        let contacts = world.contacts();
        if let Some(out) = &mut outputs.contacts {
            if let Err(e) = out.frame(frame, contacts, world.contact_ends()) {
                failure = Some(e);
                break;
            }
        }
        if let (Some(reference), Some(accuracy)) = (&mut reference, &mut accuracy) {
            let pairs = pair_contacts(contacts);
            match reference.step(args.dt) {
                Ok(expected) => {
                    let expected = pair_contacts(expected);
                    let (missed, extra) = differences(&expected, &pairs);
                    accuracy.reference_pairs += expected.len() as u64;
                    accuracy.missed += missed;
                    accuracy.extra += extra;
                    if missed + extra > 0 && accuracy.first_difference_frame.is_none() {
                        accuracy.first_difference_frame = Some(frame);
                    }
                }
                Err(e) => {
                    failure = Some(format!("frame {frame}: reference method: {}", describe(e)));
                    break;
                }
            }
        }
        if let Some(path) = save_state {
            // The contacts first: a state on disk must never be ahead of the contacts file.
            let synced = outputs.contacts.as_mut().map_or(Ok(()), ContactWriter::sync);
            if let Err(e) =
                synced.and_then(|()| world.save(path).map_err(|e| format!("frame {frame}: {}", describe(e))))
            {
                failure = Some(e);
                break;
            }
        }
        let is_static = |h: &BodyHandle| statics.binary_search(h).is_ok();
        let static_contacts = contacts
            .iter()
            .filter(|c| matches!(c.touched, Touched::Body(other) if is_static(&other) || is_static(&c.body)))
            .count() as u64;
        let row = FrameRow::new(frame, world.time(), world.stats(), static_contacts, wall_seconds);
        totals.add(&row);
        if let Err(e) = outputs.row(&row) {
            failure = Some(e);
            break;
        }
        bar.inc(1);
        if may_reveal && started.elapsed() > PROGRESS_DELAY {
            report::reveal(&bar);
            may_reveal = false;
        }
    }
    bar.finish_and_clear();
    Outcome { frames: totals, accuracy, failure }
}

/// The body-body contacts of a frame as sorted (lower handle, higher handle) pairs.
fn pair_contacts(contacts: &[Contact]) -> Vec<(BodyHandle, BodyHandle)> {
    let mut pairs: Vec<(BodyHandle, BodyHandle)> = contacts
        .iter()
        .filter_map(|c| match c.touched {
            Touched::Body(other) => Some((c.body.min(other), c.body.max(other))),
            Touched::Wall(_) => None,
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// (missed, extra): entries of `expected` absent from `found` and the reverse, as multisets, so a
/// pair that touches twice in a frame must be found twice. Both inputs are sorted.
fn differences<T: Ord>(expected: &[T], found: &[T]) -> (u64, u64) {
    let (mut i, mut j, mut missed, mut extra) = (0, 0, 0u64, 0u64);
    while i < expected.len() && j < found.len() {
        match expected[i].cmp(&found[j]) {
            std::cmp::Ordering::Less => {
                missed += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                extra += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    (missed + (expected.len() - i) as u64, extra + (found.len() - j) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_count_multisets() {
        let expected = [(0, 1), (0, 1), (2, 3), (4, 5)];
        let found = [(0, 1), (2, 3), (6, 7)];
        assert_eq!(differences(&expected, &found), (2, 1));
        assert_eq!(differences(&found, &found), (0, 0));
    }
}
