//! # vadop — exact continuous collision detection of many fast-moving bodies
//!
//! Discrete checks at frame instants miss contacts that happen between frames. vadop finds every
//! contact inside the frame, in time order, with its exact time and place, using
//! velocity-aligned discrete oriented polytopes (VADOPs, Coming & Staadt): each body bounds
//! itself on the few axes of a common pool that are nearly orthogonal to its velocity, so its
//! projections barely move while it flies and keeping them sorted costs almost nothing; a
//! hierarchical grid over pieces of the swept paths is the other broad phase, and the default
//! picks the faster for the scene.
//!
//! The modules follow the pipeline, one stage each, every stage importing only what lies below
//! it: the vocabulary every stage speaks ([`Mode`], [`Contact`], [`Touched`], [`FrameStats`],
//! [`BoxBounds`], [`Wall`], [`motion`] with [`motion::free_rotation`], [`numeric`], [`error`],
//! [`handle`], [`window`]) → [`axis_pool`] → [`bounding_volume`] → [`shape`] and the body store →
//! [`broad_phase`] (over its proxy table, [`broad_phase::proxy`]) →
//! [`narrow_phase`] (the spheres' closed forms, [`narrow_phase::spheres`]; any other shape by
//! conservative advancement, [`narrow_phase::shapes`]) → the event queue → [`response`] (the
//! impulses, and the [`response::rules`] that keep inelastic and jammed contacts finite) → the
//! frame pipeline → [`world`]; plus [`scene`] (the paper's scene and the scene file format) and
//! [`memory`] (what a world needs and may still take). The body store, the event queue, the frame
//! pipeline and how bulk work is shared between threads are private: they are how a step runs,
//! not what it answers.
//!
//! ```
//! use vadop::{scene::PaperScene, scene::FRAMES_PER_SECOND, Method, Mode, WorldConfig};
//! // 500 spheres at packing fraction 0.05, speeds up to 5 diameters per frame, detect mode.
//! let scene = PaperScene::new(500, 0.05, 5.0).build().unwrap();
//! let detect = |method| WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() };
//! let mut fast = scene.world(detect(Method::Auto)).unwrap();
//! let mut oracle = scene.world(detect(Method::Brute)).unwrap();
//! for _ in 0..10 {
//!     let found = fast.step(1.0 / FRAMES_PER_SECOND).unwrap().to_vec();
//!     // The same contacts as testing every pair, in the same order.
//!     assert_eq!(found, oracle.step(1.0 / FRAMES_PER_SECOND).unwrap());
//! }
//! ```

// Comparisons are written `!(t < end)` on purpose throughout: a NaN then fails the check
// instead of passing it, which `t >= end` would not do.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// Vocabulary and helpers, below every stage.
pub mod error;
mod frame;
pub mod handle;
mod interrupt;
pub mod memory;
pub mod motion;
pub mod numeric;
pub(crate) mod parallel;
mod slab;
mod walls;
pub mod window;

// The stages, in pipeline order.
pub mod axis_pool;
pub(crate) mod bodies;
pub mod bounding_volume;
pub mod broad_phase;
pub(crate) mod event_loop;
pub(crate) mod event_queue;
pub mod narrow_phase;
pub(crate) mod pipeline;
pub mod response;
pub mod scene;
pub mod shape;
pub mod world;

pub use bodies::{Rest, Sphere};
pub use error::{Result, VadopError};
pub use frame::{Contact, FrameStats, Mode, Touched};
/// The vector and quaternion types of the API (`DVec3`, `DQuat`), re-exported so that a user
/// needs no glam dependency of their own, nor to match its version:
///
/// ```
/// use vadop::glam::DVec3;
/// let ball = vadop::Sphere { position: DVec3::splat(5.0), velocity: DVec3::X, radius: 0.5, mass: 1.0 };
/// assert_eq!(ball.position.x, 5.0);
/// ```
pub use glam;
pub use handle::BodyHandle;
pub use walls::{BoxBounds, Periodic, Wall, MIN_PERIODIC_DIAMETERS};
pub use window::Window;
pub use world::{Body, BodyShape, Method, ShapeId, SphereRecord, World, WorldConfig};

/// The README's Rust examples, compiled and run with the doctests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeExamples;
