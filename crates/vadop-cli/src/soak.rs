//! `vadop soak`: a long elastic simulate-mode run of the paper's scene until a number of contacts
//! has been processed, checking after every frame that nothing drifts: kinetic energy against the
//! start, momentum against the wall impulses (pair impulses are equal and opposite, so only the
//! walls may change it), no body outside the box, no pair overlapping beyond the contact
//! tolerance, and no contact changed by the jam or TC rule (an elastic gas needs neither). It owns
//! these checks and their summary; it never changes the world beyond stepping
//! it. A violation is reported in the summary and makes the command fail (exit code 2).

use crate::report;
use crate::CliResult;
use clap::Args;
use glam::DVec3;
use std::time::Instant;
use vadop::narrow_phase::spheres::CONTACT_TOLERANCE;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Sphere, Touched, World, WorldConfig};

/// Limits beyond which a soak run fails.
const MAX_ENERGY_DRIFT: f64 = 1e-9;
const MAX_MOMENTUM_ERROR: f64 = 1e-10;
/// Overlap beyond the contact tolerance, relative to the sum of radii.
const MAX_OVERLAP: f64 = 2.0 * CONTACT_TOLERANCE;

#[derive(Debug, Args)]
pub struct SoakArgs {
    /// Stop after this many contacts (body-body and wall)
    #[arg(long, value_name = "N", default_value_t = 10_000_000)]
    contacts: u64,
    /// Number of spheres in the paper's scene
    #[arg(long, value_name = "N", default_value_t = 1000)]
    bodies: usize,
    /// Fraction of the box volume the spheres fill, in (0, 0.6]
    #[arg(long, value_name = "F", default_value_t = 0.3)]
    packing: f64,
    /// Speeds are uniform in [0, S] sphere diameters per frame
    #[arg(long, value_name = "S", default_value_t = 2.0)]
    max_speed: f64,
    /// Seed of the scene generator
    #[arg(long, value_name = "K", default_value_t = 1)]
    seed: u64,
    /// Stop after this many frames even if fewer contacts happened (a scene at rest has none)
    #[arg(long, value_name = "F", default_value_t = 1_000_000)]
    max_frames: u64,
    /// Print no progress bar
    #[arg(long)]
    quiet: bool,
}

/// Worst values seen over the run.
#[derive(Debug, Default)]
struct Worst {
    energy_drift: f64,
    momentum_error: f64,
    escapes: u64,
    overlap: f64,
}

pub fn run(args: &SoakArgs) -> CliResult<()> {
    let scene = PaperScene { seed: args.seed, ..PaperScene::new(args.bodies, args.packing, args.max_speed) }
        .build()
        .map_err(|e| e.to_string())?;
    let mut world = scene.world(WorldConfig::default()).map_err(|e| e.to_string())?;
    let dt = 1.0 / FRAMES_PER_SECOND;
    let energy = world.kinetic_energy();
    let bar = report::progress_bar(args.contacts, "contacts");
    if !args.quiet {
        report::reveal(&bar);
    }
    let started = Instant::now();
    let (mut frames, mut contacts, mut pair_contacts, mut merges) = (0u64, 0u64, 0u64, 0u64);
    let mut worst = Worst::default();
    while contacts < args.contacts && frames < args.max_frames {
        let momentum = world.momentum();
        let scale: f64 = world.spheres().map(|(_, s)| s.mass * s.velocity.length()).sum();
        let found = world.step(dt).map_err(|e| format!("frame {}: {e}", frames + 1))?;
        let wall: DVec3 =
            found.iter().filter(|c| matches!(c.touched, Touched::Wall(_))).map(|c| -c.impulse * c.normal).sum();
        let pairs = found.iter().filter(|c| matches!(c.touched, Touched::Body(_))).count() as u64;
        contacts += found.len() as u64;
        pair_contacts += pairs;
        frames += 1;
        merges += world.stats().jam_contacts + world.stats().tc_contacts;
        let error = (world.momentum() - momentum - wall).length() / scale.max(f64::MIN_POSITIVE);
        worst.momentum_error = worst.momentum_error.max(error);
        worst.energy_drift = worst.energy_drift.max((world.kinetic_energy() - energy).abs() / energy);
        check_positions(&world, &mut worst);
        bar.set_position(contacts.min(args.contacts));
    }
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    let passed = worst.energy_drift <= MAX_ENERGY_DRIFT
        && worst.momentum_error <= MAX_MOMENTUM_ERROR
        && worst.escapes == 0
        && worst.overlap <= MAX_OVERLAP
        && merges == 0;
    let text = format!(
        "scene       {} spheres, packing fraction {}, speeds up to {} diameters/frame, seed {}, restitution 1\n\
         run         {frames} frames, {contacts} contacts ({pair_contacts} body-body), {seconds:.1} s, {:.0} contacts/s\n\
         energy      worst relative drift {:.2e} (limit {MAX_ENERGY_DRIFT:.0e})\n\
         momentum    worst error against wall impulses {:.2e} of the total (limit {MAX_MOMENTUM_ERROR:.0e})\n\
         escapes     {} outside the box at a frame end\n\
         overlap     worst {:.2e} of the radii sum at a frame end (limit {MAX_OVERLAP:.0e})\n\
         rules       {} changed by the jam or TC rule (an elastic gas needs none)\n\
         result      {}\n",
        args.bodies,
        args.packing,
        args.max_speed,
        args.seed,
        contacts as f64 / seconds.max(1e-9),
        worst.energy_drift,
        worst.momentum_error,
        report::number(worst.escapes, "body", "bodies"),
        worst.overlap,
        report::number(merges, "contact", "contacts"),
        if passed { "pass" } else { "FAIL" },
    );
    report::print(&text)?;
    if passed {
        Ok(())
    } else {
        Err("the soak run drifted beyond its limits (see the summary)".to_string())
    }
}

/// Counts bodies outside the box and records the deepest overlap, in O(n) per frame with a grid
/// of cells one largest diameter wide (all radii are equal in the paper's scene).
fn check_positions(world: &World, worst: &mut Worst) {
    let bounds = world.bounds();
    let spheres: Vec<Sphere> = world.spheres().map(|(_, s)| s).collect();
    let diameter = spheres.iter().map(|s| 2.0 * s.radius).fold(0.0, f64::max);
    let cells = ((bounds.max - bounds.min) / diameter).ceil().max(DVec3::ONE);
    let (nx, ny, nz) = (cells.x as usize, cells.y as usize, cells.z as usize);
    let cell_of = |p: DVec3| {
        let c = ((p - bounds.min) / diameter).floor().clamp(DVec3::ZERO, cells - 1.0);
        (c.x as usize, c.y as usize, c.z as usize)
    };
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); nx * ny * nz];
    for (k, s) in spheres.iter().enumerate() {
        let slack = 1e-9 * s.radius;
        if !((s.position - s.radius).cmpge(bounds.min - slack).all()
            && (s.position + s.radius).cmple(bounds.max + slack).all())
        {
            worst.escapes += 1;
        }
        let (x, y, z) = cell_of(s.position);
        grid[(z * ny + y) * nx + x].push(k);
    }
    for (k, a) in spheres.iter().enumerate() {
        let (x, y, z) = cell_of(a.position);
        for cz in z.saturating_sub(1)..=(z + 1).min(nz - 1) {
            for cy in y.saturating_sub(1)..=(y + 1).min(ny - 1) {
                for cx in x.saturating_sub(1)..=(x + 1).min(nx - 1) {
                    for &j in grid[(cz * ny + cy) * nx + cx].iter().filter(|&&j| j > k) {
                        let b = &spheres[j];
                        let reach = a.radius + b.radius;
                        worst.overlap = worst.overlap.max((reach - a.position.distance(b.position)) / reach);
                    }
                }
            }
        }
    }
}
