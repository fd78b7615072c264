//! # vadop — exact continuous collision detection of many fast-moving spheres
//!
//! Discrete checks at frame instants miss contacts that happen between frames. vadop finds every
//! contact inside the frame, in time order, with its exact time and place, using
//! velocity-aligned discrete oriented polytopes (VADOPs, Coming & Staadt): each body bounds
//! itself on the few axes of a common pool that are nearly orthogonal to its velocity, so its
//! projections barely move while it flies and keeping them sorted costs almost nothing.
//!
//! The modules follow the pipeline, one stage each:
//! [`axis_pool`] → [`bounding_volume`] → [`sweep_prune`] → [`narrow_phase`] → [`event_queue`] →
//! [`response`] → [`world`]; plus [`collapse`] (the rule that ends inelastic collapse), [`bodies`] (the state store), [`coherent_sort`] (insertion sort with a budget), [`pseudo_dynamic`] (the
//! frame-instant baseline), [`overlap`] (start-of-run validation) and [`scene`] (the paper's scene
//! and the scene file format).
//!
//! ```
//! use vadop::{scene::PaperScene, scene::FRAMES_PER_SECOND, Method, Mode, WorldConfig};
//! // 500 spheres at packing fraction 0.05, speeds up to 5 diameters per frame, detect mode.
//! let scene = PaperScene::new(500, 0.05, 5.0).build().unwrap();
//! let detect = |method| WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() };
//! let mut vadop = scene.world(detect(Method::Vadop)).unwrap();
//! let mut oracle = scene.world(detect(Method::Brute)).unwrap();
//! for _ in 0..10 {
//!     let found = vadop.step(1.0 / FRAMES_PER_SECOND).unwrap().to_vec();
//!     // The same contacts as testing every pair, in the same order.
//!     assert_eq!(found, oracle.step(1.0 / FRAMES_PER_SECOND).unwrap());
//! }
//! ```

pub mod axis_pool;
pub mod bodies;
pub mod bounding_volume;
pub mod collapse;
pub mod coherent_sort;
pub mod error;
pub mod event_queue;
pub mod memory;
pub mod narrow_phase;
pub mod overlap;
pub mod pseudo_dynamic;
pub mod response;
pub mod scene;
pub mod sweep_prune;
pub mod uniform_grid;
pub mod world;

pub use bodies::Sphere;
pub use error::{Result, VadopError};
pub use narrow_phase::Wall;
pub use world::{BoxBounds, Contact, FrameStats, Method, Mode, Touched, World, WorldConfig};
