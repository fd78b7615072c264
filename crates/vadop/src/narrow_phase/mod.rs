//! Narrow phase: the exact time and place of contact of a candidate pair, or of a body and a wall
//! or static geometry, within a window.
//!
//! It owns the contact arithmetic: the spheres' closed forms ([`spheres`]) and their bent paths when one falls onto another at rest
//! ([`falling`]), the conservative
//! advancement of any other shape ([`shapes`]), static level geometry bounded once
//! (`static_geometry`), and the choice between them for two bodies of the store (`contacts`).
//! Every method and the brute-force oracle call the very same functions, so they get
//! bit-identical, canonical times. It never schedules, responds, or changes a body.

pub(crate) mod contacts;
pub mod falling;
pub(crate) mod parked;
pub mod shapes;
pub mod spheres;
pub(crate) mod static_geometry;
