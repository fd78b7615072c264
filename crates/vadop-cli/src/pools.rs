//! `vadop pools`: a table of axis pools, one row per size m, printed row by row as each pool is
//! built: the exact covering radius rho against Fejes Tóth's lower bound, how long the pool took
//! to get (built, or read from the disk cache that large pools use), and the mean band size,
//! the number of axes a body is bounded on when its velocity points in a random direction and
//! phi = rho. It only measures pools through the core's public API and never changes them.

use crate::report;
use crate::CliResult;
use clap::Args;
use glam::DVec3;
use std::time::Instant;
use vadop::axis_pool::{cache_file, fejes_toth_bound, AxisPool};

/// Directions averaged over for the mean band size.
const DIRECTIONS: usize = 1000;

#[derive(Debug, Args)]
pub struct PoolsArgs {
    /// Pool sizes m to tabulate, comma-separated
    #[arg(
        long,
        value_name = "LIST",
        value_delimiter = ',',
        default_values_t = [3, 4, 6, 7, 10, 13, 16, 21, 32, 46, 65, 81, 130, 200, 1000, 5000, 40000]
    )]
    axes: Vec<usize>,
}

pub fn run(args: &PoolsArgs) -> CliResult<()> {
    report::print(&format!(
        "{:>7} {:>10} {:>10} {:>9} {:>11} {:>6} {:>10}\n",
        "m", "rho (deg)", "bound", "rho/bound", "get ms", "from", "mean band"
    ))?;
    let directions = fibonacci_directions(DIRECTIONS);
    for &m in &args.axes {
        // Read before building: building a large pool writes the cache file.
        let cached = cache_file(m).is_some_and(|path| path.is_file());
        let start = Instant::now();
        let pool = AxisPool::new(m).map_err(|e| e.to_string())?;
        let get_ms = start.elapsed().as_secs_f64() * 1e3;
        let rho = pool.covering_radius();
        let bound = fejes_toth_bound(m);
        let sin_phi = rho.sin();
        let mut band = Vec::with_capacity(pool.len());
        let members: usize = directions
            .iter()
            .map(|&direction| {
                pool.band(direction, sin_phi, &mut band);
                band.len()
            })
            .sum();
        report::print(&format!(
            "{m:>7} {:>10.4} {:>10.4} {:>9.4} {get_ms:>11.2} {:>6} {:>10.2}\n",
            rho.to_degrees(),
            bound.to_degrees(),
            rho / bound,
            if cached { "cache" } else { "built" },
            members as f64 / directions.len() as f64
        ))?;
    }
    Ok(())
}

/// `count` unit vectors spread evenly over the sphere (a Fibonacci spiral): deterministic, so
/// the table is the same on every run.
fn fibonacci_directions(count: usize) -> Vec<DVec3> {
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|k| {
            let z = 1.0 - (2 * k + 1) as f64 / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let angle = golden_angle * k as f64;
            DVec3::new(r * angle.cos(), r * angle.sin(), z)
        })
        .collect()
}
