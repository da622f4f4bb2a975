//! A generated forest: many foliage spheres over a square, for benchmarks and stress tests.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{MaterialTable, Object, Shape, World};

/// What [`forest_of`] grows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForestSpec {
    /// Number of spheres.
    pub count: usize,
    /// Side of the square (centred on the origin) the centres are drawn in, metres.
    pub side: f64,
    /// Radii are drawn uniformly from this range, metres.
    pub radius: (f64, f64),
    /// Radius of the clearing around the origin that no sphere reaches into, metres (0: none).
    pub clearing: f64,
    /// Seed of the draws.
    pub seed: u64,
}

/// `count` foliage spheres (radius 0.3–1.5 m, one in four dense, the rest light, resting on
/// the ground) placed uniformly over a `side` × `side` square centred on the origin, keeping
/// a 2 m clearing around the origin for the sensor. Same `seed`, same forest.
pub fn forest(count: usize, side: f64, seed: u64) -> World {
    forest_of(&ForestSpec {
        count,
        side,
        radius: (0.3, 1.5),
        clearing: 2.0,
        seed,
    })
}

/// The forest of `spec`: spheres resting on the ground, one in four `foliage_dense`, the rest
/// `foliage_light`. Same spec, same forest.
pub fn forest_of(spec: &ForestSpec) -> World {
    let materials = MaterialTable::default();
    let light = materials.id("foliage_light").expect("built-in material");
    let dense = materials.id("foliage_dense").expect("built-in material");
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let half = spec.side / 2.0;
    let mut objects = Vec::with_capacity(spec.count);
    while objects.len() < spec.count {
        let (x, y) = (rng.random_range(-half..half), rng.random_range(-half..half));
        let r = rng.random_range(spec.radius.0..spec.radius.1);
        if spec.clearing > 0.0 && x.hypot(y) < r + spec.clearing {
            continue;
        }
        let material = if rng.random_range(0..4) == 0 {
            dense
        } else {
            light
        };
        objects.push(Object {
            name: None,
            shape: Shape::sphere(DVec3::new(x, y, r), r).expect("positive radius"),
            material,
        });
    }
    World::new(materials, objects)
}
