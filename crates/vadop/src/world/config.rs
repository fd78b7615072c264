//! A world's settings: the method that finds candidate pairs ([`Method`]), the mode, the contact
//! physics and the threads ([`WorldConfig`]), with the limits a step is checked against. It owns
//! their names and defaults; it never builds an engine nor steps anything.

use crate::frame::Mode;
use crate::response::DEFAULT_CONTACT_DURATION;
use glam::DVec3;

/// A body moving more box lengths than this in one frame is rejected: it would bounce off the
/// walls that many times per frame, which is never a meaningful simulation.
pub const MAX_BOX_LENGTHS_PER_FRAME: f64 = 1e4;

/// Declares [`Method`] from one table: each method's variant, its documentation and its name on
/// the command line, in Python and in reports, in the order the benchmarks list them. A new
/// method is one row here and one arm of the world's engine wiring.
macro_rules! methods {
    ($($(#[doc = $doc:literal])* $variant:ident => $name:literal,)*) => {
        /// How candidate pairs are found.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
        pub enum Method {
            $($(#[doc = $doc])* $variant,)*
        }

        impl Method {
            /// Every method, in the order the benchmarks list them.
            pub const ALL: [Method; [$($name),*].len()] = [$(Method::$variant),*];

            /// The method's name on the command line and in reports.
            pub fn name(self) -> &'static str {
                match self {
                    $(Method::$variant => $name,)*
                }
            }
        }
    };
}

methods! {
    /// Continuous: the fastest broad phase (see [`Method::resolve`]).
    Auto => "auto",
    /// Continuous: velocity-aligned volumes, sweep and prune over the axis pool (the paper).
    Vadop => "vadop",
    /// Continuous: hierarchical uniform grid over pieces of the swept paths.
    Grid => "grid",
    /// Continuous baseline: classic sweep and prune over swept axis-aligned boxes (the three
    /// coordinate axes for every body, one sorted list per axis, no tiles), as most engines do.
    SweptAabb => "swept-aabb",
    /// Continuous baseline: the VADOP sweep and prune with *every* pool axis for every body, a
    /// swept k-DOP; isolates what the velocity alignment buys.
    SweptKdop => "swept-kdop",
    /// Pseudo-dynamic: overlap checks at frame instants only (misses what passes in between).
    Discrete => "discrete",
    /// Continuous: every pair tested (the oracle; O(n^2) per frame).
    Brute => "brute",
}

impl Method {
    /// The method called `name` (as [`Method::name`] writes it).
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// True for the methods that find every contact inside the frame.
    pub fn is_continuous(self) -> bool {
        self != Method::Discrete
    }

    /// The broad phase a method steps with: [`Method::Auto`] is the grid, the others are
    /// themselves. Measured by `vadop-bench speed` (BENCHMARKS.md, "where each broad phase wins"):
    /// on every scene it runs — the paper's at 0.05 to 5 diameters a frame, an equilibrium gas, a
    /// stream within 1 to 10 degrees of one direction, heavy-tailed speeds — the grid is the
    /// fastest continuous broad phase, the VADOP sweep and prune 1.3 to 6 times slower (closest in
    /// streams, as velocity alignment predicts). No scene statistic picked out a case where it
    /// wins, so Auto does not switch.
    pub fn resolve(self) -> Method {
        match self {
            Method::Auto => Method::Grid,
            other => other,
        }
    }
}

/// Pool size used when none is given, whatever the bodies' speeds. Measured by experiment 4 of
/// `vadop-bench experiments` (BENCHMARKS.md): with tiled axis lists the 3-axis pool is the fastest at every
/// speed it tests (0.05, 0.5 and 5 diameters per frame, pools of 3 to 39,000 axes), because each
/// extra axis per body costs more in updates and candidate checks than its thinner volume saves.
/// phi stays rho, the smallest angle that keeps every pair sharing an axis; every axis for every
/// body (the swept k-DOP, table 3) is no faster. The paper's finding that the best pool grows
/// with speed holds for untiled lists, where thinner volumes are the only way to cut overlaps;
/// the tiles do that job here.
pub const AUTO_POOL_AXES: usize = 3;

/// World settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorldConfig {
    pub method: Method,
    pub mode: Mode,
    /// Number of pool axes (methods Vadop and SweptKdop); `None` uses [`AUTO_POOL_AXES`].
    pub pool_axes: Option<usize>,
    /// Alignment angle phi in radians; `None` uses the pool's covering radius rho, the smallest
    /// angle for which every pair of bodies shares an axis.
    pub phi: Option<f64>,
    /// Coefficient of restitution for body and wall impacts, in [0, 1].
    pub restitution: f64,
    /// Coulomb friction coefficient of every impact (0: frictionless), finite and >= 0. Friction
    /// acts at the contact point, so it spins bodies up (spheres included).
    #[serde(default)]
    pub friction: f64,
    /// Contact duration t_c of the TC model, in seconds: with restitution below 1, a contact of a
    /// body whose previous contact lies less than t_c before is elastic (see [`crate::response::rules`]).
    #[serde(default = "default_contact_duration")]
    pub contact_duration: f64,
    /// Threads the frame pipeline shares its bulk work among; `None`: every core. Results are
    /// bit-identical whatever the number; with 1, no thread pool is made. At most as many threads
    /// as the system has cores are used ([`WorldConfig::thread_count`]): more would only wait for
    /// each other (1000 threads on 2 cores made a run 375 times slower).
    #[serde(default)]
    pub threads: Option<usize>,
    /// Detect mode: also report when each contact between bodies ends ([`World::contact_ends`](crate::World::contact_ends))
    /// and keep the pairs in contact ([`World::touching`](crate::World::touching)), as started and stopped events.
    /// Off by default: it costs a prediction and a list entry per contact.
    #[serde(default)]
    pub contact_ends: bool,
    /// Uniform acceleration of every moving body (e.g. `[0, 0, -9.81]`); zero by default. Paths
    /// are then parabolas, exact in both modes and for every method and shape. With restitution
    /// below 1 in simulate mode bodies of every shape come to rest on the floor, on each other
    /// and on static geometry ([`crate::response::rest`]).
    #[serde(default)]
    pub gravity: DVec3,
}

fn default_contact_duration() -> f64 {
    DEFAULT_CONTACT_DURATION
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            method: Method::Auto,
            mode: Mode::Simulate,
            pool_axes: None,
            phi: None,
            restitution: 1.0,
            friction: 0.0,
            contact_duration: DEFAULT_CONTACT_DURATION,
            threads: None,
            contact_ends: false,
            gravity: DVec3::ZERO,
        }
    }
}

impl WorldConfig {
    /// The number of threads a step uses: as configured, but never more than the cores the
    /// system reports (its CPU quota, in a container), and every core when not configured. The
    /// bound is applied here, not refused, so that a world saved on a large machine runs on a
    /// small one.
    ///
    /// ```
    /// use vadop::WorldConfig;
    /// let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    /// let config = WorldConfig { threads: Some(100_000), ..WorldConfig::default() };
    /// assert_eq!(config.thread_count(), cores);
    /// assert_eq!(WorldConfig { threads: Some(1), ..config }.thread_count(), 1);
    /// ```
    pub fn thread_count(&self) -> usize {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.threads.map_or(cores, |threads| threads.min(cores))
    }
}
