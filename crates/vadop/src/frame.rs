//! The vocabulary of a frame: what a step is asked to do ([`Mode`], and the physics it is stepped
//! with) and what it reports ([`Contact`], [`Touched`], [`FrameStats`]). Every engine and the
//! world speak it; it holds data only and never steps, predicts or resolves anything.

use crate::handle::BodyHandle;
use crate::walls::{BoxBounds, Wall};
use glam::DVec3;

/// Whether bodies collide with each other or only report contacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Mode {
    /// Full response between bodies and with the walls.
    #[default]
    Simulate,
    /// Bodies pass through each other (contacts are reported, not resolved) and bounce only off
    /// the walls, so every method sees exactly the same paths.
    Detect,
}

/// What a contact's body touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Touched {
    Body(BodyHandle),
    Wall(Wall),
}

/// One contact found in a frame. Bodies are named by the handles they have at the contact, which
/// are their current handles: bodies are only removed between frames.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// Absolute simulation time of first touch.
    pub time: f64,
    /// The body (of a pair, the one with the lower index).
    pub body: BodyHandle,
    /// What it touched.
    pub touched: Touched,
    /// Contact point.
    pub point: DVec3,
    /// Unit normal from `body` towards what it touched.
    pub normal: DVec3,
    /// Magnitude of the impulse applied along the normal (0 when not resolved: detect mode
    /// resolves only contacts with walls and static bodies; 0 for a contact's end).
    pub impulse: f64,
}

impl Contact {
    /// The header of a contacts CSV file (`vadop simulate --contacts`, and `vadop-mpi`'s, which
    /// must match it byte for byte).
    pub const CSV_HEADER: &'static str =
        "frame,time,body,touched,other,point_x,point_y,point_z,normal_x,normal_y,normal_z,impulse";

    /// This contact as a row of a contacts CSV file (see [`Contact::CSV_HEADER`]), in frame
    /// `frame` (numbered from 1); `ended` for the end of a contact between bodies. Numbers are
    /// written to round-trip exactly; bodies by the number of their handle
    /// ([`BodyHandle::to_bits`]).
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BodyHandle, Contact, Touched, Wall};
    /// let contact = Contact {
    ///     time: 0.25,
    ///     body: BodyHandle::from_bits(7),
    ///     touched: Touched::Wall(Wall::MinX),
    ///     point: DVec3::new(0.0, 1.5, 2.0),
    ///     normal: DVec3::new(-1.0, 0.0, 0.0),
    ///     impulse: 3.0,
    /// };
    /// assert_eq!(contact.csv_row(8, false).to_string(), "8,0.25,7,wall,MinX,0,1.5,2,-1,0,0,3");
    /// ```
    pub fn csv_row(&self, frame: u64, ended: bool) -> impl std::fmt::Display + '_ {
        CsvRow { contact: self, frame, ended }
    }
}

struct CsvRow<'a> {
    contact: &'a Contact,
    frame: u64,
    ended: bool,
}

impl std::fmt::Display for CsvRow<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = self.contact;
        let (p, n) = (c.point, c.normal);
        write!(f, "{},{},{},", self.frame, c.time, c.body.to_bits())?;
        match c.touched {
            Touched::Body(other) => write!(f, "{},{}", if self.ended { "body-end" } else { "body" }, other.to_bits())?,
            Touched::Wall(wall) => write!(f, "wall,{wall:?}")?,
        }
        write!(f, ",{},{},{},{},{},{},{}", p.x, p.y, p.z, n.x, n.y, n.z, c.impulse)
    }
}

/// Counters and timings of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Seconds spent refreshing bounding volumes at window starts (c_update).
    pub update_seconds: f64,
    /// Seconds spent sorting or binning them (c_sort).
    pub sort_seconds: f64,
    /// Seconds spent finding candidates and predicting contacts at window starts (c_test).
    pub test_seconds: f64,
    /// Seconds spent processing contacts: response, volume rebuilds and re-tests (c_response).
    pub response_seconds: f64,
    /// Broad-phase windows started in the frame (a window may span several frames).
    pub windows: u64,
    /// Insertion-sort moves over all lists (sweep and prune) or entries binned (grid).
    pub endpoint_swaps: u64,
    /// Entries held by the broad phase after its last window start.
    pub list_entries: u64,
    /// Candidate pairs reported at window starts.
    pub candidate_pairs: u64,
    /// Narrow-phase pair tests, re-tests included.
    pub narrow_tests: u64,
    /// Bodies re-tested after a velocity change (or entered mid-window).
    pub retests: u64,
    /// Contacts reported.
    pub contacts: u64,
    /// Of which body-body.
    pub pair_contacts: u64,
    /// Predictions voided by a velocity change before their time came.
    pub invalidations: u64,
    /// Bytes held by the engine: broad phase, proxies, event queue.
    pub broad_phase_bytes: u64,
    /// Contacts made elastic by the TC model (restitution below 1; see [`crate::response::rules`]).
    pub tc_contacts: u64,
    /// Contacts resolved as resting contact by the jam rule (see [`crate::response::rules`]).
    pub jam_contacts: u64,
    /// Contacts at which a body came to rest under gravity instead of bouncing (see
    /// [`crate::response::rest`]).
    #[serde(default)]
    pub rest_contacts: u64,
    /// Contacts between bodies that ended (detect mode, when contact ends are reported).
    #[serde(default)]
    pub contact_ends: u64,
    /// The collisional virial of the frame's impacts between moving bodies: over each impact,
    /// the separation of the centres (second minus first) dotted with the momentum the second
    /// gained (mass x length^2 / time; 0 in detect mode, where bodies pass through each other).
    /// Over a run of duration T and translational kinetic energy K it gives the pressure:
    /// PV = NkT + W / (3T), so Z = PV/NkT = 1 + W / (2KT) with W the sum over the frames (in a
    /// walled box the walls' impulses give the same, with V the volume the centres can reach).
    #[serde(default)]
    pub pair_virial: f64,
}

impl FrameStats {
    /// c_total = c_update + c_sort + c_test + c_response, in seconds.
    pub fn total_seconds(&self) -> f64 {
        self.update_seconds + self.sort_seconds + self.test_seconds + self.response_seconds
    }
}

/// The physics a frame is stepped with.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Physics {
    pub bounds: BoxBounds,
    pub mode: Mode,
    pub restitution: f64,
    /// Coulomb friction coefficient of every impact.
    pub friction: f64,
    pub contact_duration: f64,
    /// Detect mode only: contact ends are reported and touching pairs kept.
    pub report_ends: bool,
}

impl Mode {
    /// Whether a contact turns its bodies back, `level` when one side is a wall or static
    /// geometry: every contact in simulate mode; in detect mode, where moving bodies pass through
    /// each other, only one against the level.
    ///
    /// ```
    /// use vadop::Mode;
    /// assert!(Mode::Simulate.turns_back(false) && Mode::Detect.turns_back(true));
    /// assert!(!Mode::Detect.turns_back(false));
    /// ```
    #[inline]
    pub fn turns_back(self, level: bool) -> bool {
        self == Mode::Simulate || level
    }
}

impl Physics {
    /// [`Mode::turns_back`] in this world's mode.
    #[inline]
    pub fn turns_back(&self, level: bool) -> bool {
        self.mode.turns_back(level)
    }
}

/// What a frame produces.
pub(crate) struct Output<'a> {
    pub contacts: &'a mut Vec<Contact>,
    /// The contacts that ended, in time order (when ends are reported).
    pub ends: &'a mut Vec<Contact>,
    pub stats: &'a mut FrameStats,
}
