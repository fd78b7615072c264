//! The axis pool: special cases, covering quality, the exact covering radius against sampling,
//! the band query against a full scan, the shared-axis guarantee, and the caches.

use glam::DVec3;
use std::sync::{Arc, Once};
use vadop::axis_pool::{cache_file, covering_radius, fejes_toth_bound, AxisPool, MAX_AXES, MIN_AXES};
use vadop::VadopError;

/// Points every test at a private cache directory, once, before any pool is built, so tests
/// neither read nor write the user's cache.
fn pool(m: usize) -> Arc<AxisPool> {
    static ISOLATE: Once = Once::new();
    ISOLATE.call_once(|| {
        let dir = std::env::temp_dir().join(format!("vadop-axis-pool-test-{}", std::process::id()));
        // Set before any other thread of this test binary reads the environment.
        std::env::set_var("VADOP_CACHE_DIR", dir);
    });
    AxisPool::new(m).unwrap()
}

/// A fixed-seed generator of unit vectors (SplitMix64).
struct Random(u64);

impl Random {
    fn unit_interval(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    fn unit_vector(&mut self) -> DVec3 {
        let z = 2.0 * self.unit_interval() - 1.0;
        let longitude = std::f64::consts::TAU * self.unit_interval();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * longitude.cos(), r * longitude.sin(), z)
    }
}

/// The largest angle from `samples` spiral directions to their nearest ±a.
fn sampled_covering_radius(axes: &[DVec3], samples: usize) -> f64 {
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..samples)
        .map(|s| {
            // The upper hemisphere is enough: directions d and -d are equally far from the axes.
            let z = 1.0 - (s as f64 + 0.5) / samples as f64;
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * (golden_angle * s as f64).cos(), r * (golden_angle * s as f64).sin(), z);
            let nearest = axes.iter().map(|a| a.dot(d).abs()).fold(0.0, f64::max);
            nearest.min(1.0).acos()
        })
        .fold(0.0, f64::max)
}

fn full_scan(pool: &AxisPool, direction: DVec3, sin_phi: f64) -> Vec<u32> {
    (0..pool.len() as u32).filter(|&id| pool.axis(id).dot(direction).abs() <= sin_phi).collect()
}

#[test]
fn sizes_outside_the_range_are_rejected() {
    for m in [0, 1, MIN_AXES - 1, MAX_AXES + 1, usize::MAX] {
        assert_eq!(AxisPool::new(m).unwrap_err(), VadopError::BadPoolSize { got: m, min: MIN_AXES, max: MAX_AXES });
    }
}

#[test]
fn three_and_six_axes_are_the_known_best_coverings() {
    let coordinate = pool(3);
    let mut axes = coordinate.axes().to_vec();
    axes.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    assert_eq!(axes, vec![DVec3::Z, DVec3::Y, DVec3::X]);
    // The cube's corner direction is acos(1/sqrt 3) from every coordinate axis.
    assert!((coordinate.covering_radius() - (1.0 / 3f64.sqrt()).acos()).abs() < 1e-14);

    let icosahedron = pool(6);
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    // Each pair of vertex axes makes the angle atan 2 (63.43 degrees) between them.
    for (i, a) in icosahedron.axes().iter().enumerate() {
        assert!((a.length() - 1.0).abs() < 1e-15);
        for b in &icosahedron.axes()[i + 1..] {
            assert!((a.dot(*b).abs() - 1.0 / 5f64.sqrt()).abs() < 1e-15);
        }
    }
    // A face centre is the farthest direction: the angle from a vertex to it.
    let face_centre = DVec3::new(0.0, 1.0, golden) + DVec3::new(0.0, -1.0, golden) + DVec3::new(golden, 0.0, 1.0);
    let expected = DVec3::new(0.0, 1.0, golden).normalize().angle_between(face_centre.normalize());
    assert!((icosahedron.covering_radius() - expected).abs() < 1e-14);
    assert!((expected.to_degrees() - 37.3774).abs() < 1e-4);
}

#[test]
fn pools_cover_within_ten_percent_of_the_fejes_toth_bound() {
    for m in [4, 7, 10, 13, 16, 21, 32, 46, 81, 200, 1000] {
        let pool = pool(m);
        assert_eq!(pool.len(), m);
        assert!(pool.axes().iter().all(|a| (a.length() - 1.0).abs() < 1e-14));
        let ratio = pool.covering_radius() / fejes_toth_bound(m);
        assert!((1.0..=1.10).contains(&ratio), "m = {m}: ratio {ratio}");
        // Recomputed from the stored order, the same up to rounding.
        assert!((covering_radius(pool.axes()) - pool.covering_radius()).abs() < 1e-14);
    }
    // The ten-point antipodal sets cannot get close to the bound, which is far from tight there.
    assert!(pool(5).covering_radius() / fejes_toth_bound(5) <= 1.12);
}

#[test]
fn known_good_coverings_are_matched() {
    // Best known antipodal coverings, in degrees, with a little slack for the optimiser.
    for (m, known) in [(16, 22.69), (21, 20.91), (46, 13.68), (81, 10.81)] {
        let degrees = pool(m).covering_radius().to_degrees();
        assert!(degrees <= known * 1.03, "m = {m}: {degrees} degrees, best known {known}");
    }
}

#[test]
fn the_same_size_gives_the_same_shared_pool() {
    let first = pool(13);
    assert!(Arc::ptr_eq(&first, &pool(13)));
    assert!(!Arc::ptr_eq(&first, &pool(16)));
}

#[test]
fn exact_covering_radius_agrees_with_dense_sampling() {
    let mut random = Random(7);
    let random_axes: Vec<DVec3> = (0..9).map(|_| random.unit_vector()).collect();
    let cube_diagonals =
        [DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, 1.0, -1.0), DVec3::new(1.0, -1.0, 1.0), DVec3::new(-1.0, 1.0, 1.0)]
            .map(DVec3::normalize);
    let pools = [pool(4), pool(7)];
    let sets: [&[DVec3]; 4] = [pools[0].axes(), pools[1].axes(), &random_axes, &cube_diagonals];
    for axes in sets {
        let exact = covering_radius(axes);
        let sampled = sampled_covering_radius(axes, 1_000_000);
        assert!(sampled <= exact * (1.0 + 1e-12), "sampling {sampled} exceeds the exact {exact}");
        assert!(sampled >= exact * 0.995, "sampling {sampled} far below the exact {exact}");
    }
    // The cube's diagonals: a coordinate axis is acos(1/sqrt 3) from each of them.
    assert!((covering_radius(&cube_diagonals) - (1.0 / 3f64.sqrt()).acos()).abs() < 1e-14);
}

#[test]
fn degenerate_axis_sets_have_the_right_covering_radius() {
    let right_angle = std::f64::consts::FRAC_PI_2;
    assert_eq!(covering_radius(&[]), right_angle);
    assert_eq!(covering_radius(&[DVec3::X, DVec3::Y]), right_angle);
    // Coplanar axes leave their plane's normal 90 degrees from all of them.
    let coplanar: Vec<DVec3> = (0..5).map(|k| DVec3::new((k as f64).cos(), (k as f64).sin(), 0.0)).collect();
    assert_eq!(covering_radius(&coplanar), right_angle);
    // Zero, non-finite, unnormalised and repeated axes do not change the answer.
    let messy = [DVec3::ZERO, DVec3::X * 3.0, DVec3::NAN, -DVec3::Y, DVec3::Z, DVec3::X, DVec3::INFINITY];
    assert!((covering_radius(&messy) - (1.0 / 3f64.sqrt()).acos()).abs() < 1e-14);
}

#[test]
fn band_is_exactly_the_full_scan() {
    let mut random = Random(11);
    let mut band = Vec::new();
    for m in [13, 200, 5000] {
        let pool = pool(m);
        let rho = pool.covering_radius();
        for sin_phi in [0.0, 0.01, rho.sin(), (2.0 * rho).min(1.5).sin(), 1.0] {
            for k in 0..400 {
                // Some directions along an axis or the coordinate axes, where ties are likeliest.
                let direction = match k {
                    0 => DVec3::Z,
                    1 => DVec3::X,
                    2..=9 => pool.axis(k as u32 % m as u32),
                    _ => random.unit_vector(),
                };
                pool.band(direction, sin_phi, &mut band);
                assert_eq!(
                    band,
                    full_scan(&pool, direction, sin_phi),
                    "m = {m}, sin phi = {sin_phi}, direction {direction}"
                );
            }
        }
    }
}

#[test]
fn band_does_not_allocate_when_the_buffer_is_large_enough() {
    let pool = pool(200);
    let mut band = Vec::with_capacity(pool.len());
    let buffer = band.as_ptr();
    pool.band(DVec3::X, 1.0, &mut band);
    assert_eq!(band.len(), pool.len());
    pool.band(DVec3::Y, pool.covering_radius().sin(), &mut band);
    assert_eq!((band.as_ptr(), band.capacity()), (buffer, pool.len()));
}

#[test]
fn any_two_bands_share_an_axis() {
    let mut random = Random(5);
    let mut first = Vec::new();
    let mut second = Vec::new();
    for m in [3, 6, 7, 13, 46, 200, 5000] {
        let pool = pool(m);
        let sin_phi = pool.covering_radius().sin() * (1.0 + 1e-12) + 1e-15;
        for k in 0..3000 {
            let u1 = random.unit_vector();
            let u2 = match k % 3 {
                0 => random.unit_vector(),
                1 => u1,
                // Nearly parallel, at angles down to 1e-9 rad.
                _ => (u1 + random.unit_vector() * 10f64.powi(-(k % 10))).normalize(),
            };
            pool.band(u1, sin_phi, &mut first);
            pool.band(u2, sin_phi, &mut second);
            assert!(
                first.iter().any(|id| second.binary_search(id).is_ok()),
                "m = {m}: bands of {u1} and {u2} are disjoint"
            );
        }
    }
}

/// The build time is measured by `vadop pools` (BENCHMARKS.md), not asserted: shared machines
/// are too noisy for a timed test.
#[test]
fn forty_thousand_axes_cover_the_sphere_near_the_bound() {
    let pool = pool(40_000);
    let ratio = pool.covering_radius() / fejes_toth_bound(40_000);
    assert!(ratio <= 1.10, "ratio {ratio}");
}

#[test]
fn disk_cache_is_read_validated_and_rewritten() {
    pool(3); // isolates the cache directory
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let m = 2002;
    let spiral: Vec<DVec3> = (0..m)
        .map(|i| {
            let z = 1.0 - (i as f64 + 0.5) / m as f64;
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * (golden_angle * i as f64).cos(), r * (golden_angle * i as f64).sin(), z)
        })
        .collect();
    let file = |axes: &[DVec3]| {
        let mut bytes = b"VADOPAX1".to_vec();
        bytes.extend_from_slice(&(axes.len() as u64).to_le_bytes());
        axes.iter().flat_map(|a| a.to_array()).for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
        bytes
    };
    let sorted = |axes: &[DVec3]| {
        let mut axes: Vec<[f64; 3]> = axes.iter().map(|a| a.to_array()).collect();
        axes.sort_by(|a, b| a.partial_cmp(b).unwrap());
        axes
    };

    // A valid file is used as it is, and its covering radius is computed, not trusted.
    let path = cache_file(m).unwrap();
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, file(&spiral)).unwrap();
    let loaded = pool(m);
    assert_eq!(sorted(loaded.axes()), sorted(&spiral));
    assert_eq!(loaded.covering_radius(), covering_radius(&spiral));

    // A file with an axis that is not unit length is ignored: the pool is built and saved.
    let m = 2003;
    let mut bad = spiral[..m - 1].to_vec();
    bad.push(DVec3::new(0.0, 0.0, 1.1));
    let path = cache_file(m).unwrap();
    std::fs::write(&path, file(&bad)).unwrap();
    let built = pool(m);
    assert_ne!(sorted(built.axes()), sorted(&bad));
    assert!(built.covering_radius() / fejes_toth_bound(m) <= 1.10);
    assert_eq!(std::fs::read(&path).unwrap().len(), 16 + 24 * m);

    // So is a truncated one.
    let m = 2004;
    let path = cache_file(m).unwrap();
    std::fs::write(&path, &file(&spiral)[..100]).unwrap();
    assert!(pool(m).covering_radius() / fejes_toth_bound(m) <= 1.10);
}
