//! Response: what an impact does to the bodies once the narrow phase found it.
//!
//! It owns the impulse arithmetic ([`impulse`]: spheres along the line of centres, rigid bodies
//! of any shape at their contact points with restitution and friction), the contact rules that
//! keep every frame finite ([`rules`]: the TC model and the jam rule; [`rest`]: how bodies come to rest under gravity) and the one impact policy
//! both engines call (`impact`: which rule and which arithmetic a contact gets, and what it
//! changes). It never decides *when* bodies touch (the narrow phase) nor what a velocity change
//! must re-test (the pipeline).

pub(crate) mod impact;
pub mod impulse;
pub mod rest;
pub mod rules;

pub use impulse::{pair_impulse, resolve_impact, rigid_impulse, wall_bounce, Impacted, RigidSide, IMPACT_SWEEPS};
pub use rules::DEFAULT_CONTACT_DURATION;
