//! Scenes: the paper's test scene (spheres in a cube at a given packing fraction, random
//! directions, speeds up to a maximum in diameters per frame, 30 frames per second), the same
//! placement with other velocities (an equilibrium gas, a stream, heavy-tailed speeds), a crowd of
//! mixed shapes ([`ShapesScene`]), and the scene file format.
//!
//! It owns scene generation, which is seeded and deterministic, and reading, writing and
//! resolving scene files: a scene names its shapes, and [`Scene::world`] turns the names into the
//! world's shapes. It never steps anything. Generated bodies never overlap: each lies within a
//! ball one diameter across about a site of a jittered face-centred cubic grid spread over the
//! whole box, so the same scene serves simulate mode.
//!
//! # File format
//!
//! JSON; units are free (the generated scenes use diameters and seconds). A sphere-only file, the
//! original format, holds a box and spheres:
//!
//! ```json
//! {"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
//!  "spheres": [{"position": [2, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}]}
//! ```
//!
//! A box may have periodic axes: `"bounds": {"min": ..., "max": ..., "periodic": [true, true,
//! false]}` (x, y, z; left out: all walled, see [`BoxBounds::with_periodic`](crate::BoxBounds::with_periodic)).
//!
//! Bodies of other shapes take three more lists, each optional (`spheres` too):
//!
//! - `shapes`, the table of named shapes: `{"name": "brick", "shape": {"cuboid": {"half_extents":
//!   [0.5, 0.25, 0.25]}}}`. A shape is written as [`Shape`](crate::shape::Shape) serialises, under its kind's name
//!   ([`ShapeKind::name`](crate::shape::ShapeKind::name), the names Python and the viewer use):
//!   `{"sphere": {"radius": r}}`, `{"cuboid": {"half_extents": [x, y, z]}}`, `{"capsule":
//!   {"half_height": h, "radius": r}}`, `cylinder` and `cone` alike, `{"convex_hull": {"points":
//!   [[x, y, z], ...]}}`, `{"trimesh": {"vertices": [[x, y, z], ...], "triangles": [[i, j, k],
//!   ...]}}` and `{"halfspace": {"normal": [x, y, z]}}`, sizes in the shape's own frame (see
//!   [`crate::shape`]). Older files name the kinds `Sphere`, `Cuboid`,
//!   `ConvexHull`, `TriMesh`, `HalfSpace`, ...; they are read as well. Names are unique and
//!   case-sensitive.
//! - `bodies`, the moving bodies: `{"shape": "brick", "position": [x, y, z], "orientation": [x, y,
//!   z, w], "velocity": [x, y, z], "angular_velocity": [x, y, z], "mass": m}`. `position` places
//!   the shape's origin; `orientation` is a quaternion in the order **[x, y, z, w]**, the vector
//!   part first and the scalar last (`[0, 0, 0, 1]` is no rotation; any non-zero length, it is
//!   normalised); `angular_velocity` is in world axes, radians per unit of time. `orientation`
//!   and `angular_velocity` may be left out: no rotation, no spin. A triangle mesh or a half-space
//!   cannot move.
//! - `static_bodies`, level geometry or any shape fixed in place: `{"shape": "floor", "position":
//!   [x, y, z], "orientation": [x, y, z, w]}` (`orientation` optional). A static body never moves,
//!   has infinite mass and may reach beyond the box.
//!
//! An unknown key, anywhere (a misspelt `static_body` at the top, a `radus` in a sphere entry, a
//! third corner in `bounds`), is refused with its name, line and column rather than ignored.
//! [`Scene::world`] validates everything else and names the offending entry: `shape 2
//! ("floor")`, `sphere 7`, `body 3`, `static body 0`. A world built from a scene holds its spheres,
//! then its bodies, then its static bodies, in file order, in slots 0, 1, 2, ...: [`SceneLayout`]
//! names the entry behind a handle, so that the overlap a simulate-mode world finds at its first
//! step is reported as between entries too.

mod file;
mod paper;
mod placement;
mod shapes;

pub use crate::error::SceneEntry;
pub use file::{NamedShape, Scene, SceneBody, SceneLayout, StaticBody};
pub use paper::{GeneratedScene, PaperScene, SphereScene, Velocities, HEAVY_TAIL_INDEX};
pub use shapes::{ShapesScene, DEFAULT_MAX_SPIN};

/// Most bodies a generated scene holds: more would not fit in memory, and generating them would
/// run for hours before failing.
pub const MAX_SCENE_BODIES: usize = 100_000_000;

/// Frame rate of the paper's scene.
pub const FRAMES_PER_SECOND: f64 = 30.0;

#[cfg(test)]
mod tests {
    use super::shapes::{crowd_shapes, CROWD_RADIUS};
    use super::*;
    use crate::error::VadopError;
    use crate::world::WorldConfig;
    use glam::DVec3;
    use std::collections::BTreeSet;

    #[test]
    fn dense_scenes_do_not_overlap_and_fit_the_box() {
        for (n, fraction) in [(1usize, 0.05), (7, 0.1), (1001, 0.4), (500, 0.6)] {
            let scene = PaperScene { bodies: n, packing_fraction: fraction, max_speed: 1.0, radius: 0.5, seed: 3 }
                .build()
                .unwrap();
            assert_eq!(scene.spheres.len(), n);
            let world = scene.world(WorldConfig::default()).unwrap();
            assert_eq!(world.len(), n);
            for (i, a) in scene.spheres.iter().enumerate() {
                for b in &scene.spheres[i + 1..] {
                    assert!(a.position.distance(b.position) >= 1.0 - 1e-9);
                }
            }
        }
    }

    #[test]
    fn same_seed_same_scene() {
        let a = PaperScene::new(200, 0.1, 2.0).build().unwrap();
        let b = PaperScene::new(200, 0.1, 2.0).build().unwrap();
        assert_eq!(a, b);
        let c = PaperScene { seed: 2, ..PaperScene::new(200, 0.1, 2.0) }.build().unwrap();
        assert_ne!(a, c);
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert!(PaperScene::new(0, 0.1, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.0, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.7, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.1, f64::NAN).build().is_err());
    }

    #[test]
    fn crowd_shapes_lie_within_half_a_diameter_of_their_origin() {
        for (name, shape) in crowd_shapes() {
            let geometry = shape.geometry().unwrap();
            let support = geometry.parry_shape().as_support_map().unwrap();
            // A spiral of directions over the sphere; the farthest support point is the reach.
            let reach = (0..2000)
                .map(|i| {
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
                    let (r, phi) = ((1.0 - z * z).sqrt(), i as f64 * 2.399963229728653);
                    support.local_support_point(DVec3::new(r * phi.cos(), r * phi.sin(), z)).length()
                })
                .fold(0.0, f64::max);
            assert!(reach <= CROWD_RADIUS, "{name} reaches {reach}");
        }
    }

    #[test]
    fn shapes_scenes_place_every_kind_apart_within_their_limits() {
        for (bodies, packing_fraction, floor) in [(5, 0.02, false), (600, 0.05, true), (300, 0.15, false)] {
            let parameters = ShapesScene { bodies, packing_fraction, max_speed: 2.0, max_spin: 1.5, floor, seed: 4 };
            let scene = parameters.build().unwrap();
            assert_eq!(scene.spheres.len() + scene.bodies.len(), bodies);
            assert_eq!(scene.static_bodies.len(), usize::from(floor));
            if bodies > 100 {
                let kinds: BTreeSet<&str> = scene.bodies.iter().map(|b| b.shape.as_str()).collect();
                assert_eq!(kinds.len(), crowd_shapes().len());
                assert!(!scene.spheres.is_empty());
            }
            // The crowd fills its cube (the box above the floor) to the packing fraction.
            let side = scene.bounds.max.x;
            let volume: f64 =
                scene.spheres.iter().map(|s| s.mass).sum::<f64>() + scene.bodies.iter().map(|b| b.mass).sum::<f64>();
            assert!((volume / side.powi(3) - packing_fraction).abs() < 1e-12);
            let speeds = scene.spheres.iter().map(|s| s.velocity).chain(scene.bodies.iter().map(|b| b.velocity));
            assert!(speeds.map(|v| v.length()).all(|v| v <= 2.0 * FRAMES_PER_SECOND * (1.0 + 1e-12)));
            assert!(scene
                .bodies
                .iter()
                .all(|b| b.angular_velocity.length() <= 1.5 * FRAMES_PER_SECOND * (1.0 + 1e-12)));
            // Simulate mode refuses overlapping bodies at the first step, and every body is in the box.
            let mut world = scene.world(WorldConfig::default()).unwrap();
            world.step(1.0 / FRAMES_PER_SECOND).unwrap();
            assert_eq!(scene, parameters.build().unwrap(), "the same seed, the same scene");
            assert_ne!(scene, ShapesScene { seed: 5, ..parameters }.build().unwrap());
        }
    }

    #[test]
    fn bad_shapes_scene_parameters_are_errors() {
        let good = ShapesScene::new(100, 0.05, 1.0);
        for (bad, expected) in [
            (ShapesScene { bodies: 0, ..good }, "at least one body"),
            (ShapesScene { packing_fraction: 0.7, ..good }, "packing fraction"),
            (ShapesScene { packing_fraction: 0.5, ..good }, "too dense to place 100 separate bodies"),
            (ShapesScene { max_speed: -1.0, ..good }, "max speed"),
            (ShapesScene { max_spin: f64::INFINITY, ..good }, "max spin"),
        ] {
            let message = bad.build().unwrap_err().to_string();
            assert!(message.contains(expected), "{bad:?}: {message}");
        }
    }

    #[test]
    fn files_round_trip() {
        let scene = PaperScene::new(20, 0.1, 1.0).build().unwrap();
        let path = std::env::temp_dir().join(format!("vadop-scene-{}.json", std::process::id()));
        scene.save(&path).unwrap();
        assert_eq!(Scene::load(&path).unwrap(), scene);
        std::fs::remove_file(&path).unwrap();
        assert!(matches!(Scene::load(&path), Err(VadopError::Io { .. })));
    }
}
