//! A generated forest: many foliage spheres over a square, for benchmarks and stress tests.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{MaterialTable, Object, Shape, World};

/// `count` foliage spheres (radius 0.3–1.5 m, one in four dense, the rest light, resting on
/// the ground) placed uniformly over a `side` × `side` square centred on the origin, keeping
/// a 2 m clearing around the origin for the sensor. Same `seed`, same forest.
pub fn forest(count: usize, side: f64, seed: u64) -> World {
    let materials = MaterialTable::default();
    let light = materials.id("foliage_light").expect("built-in material");
    let dense = materials.id("foliage_dense").expect("built-in material");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut objects = Vec::with_capacity(count);
    while objects.len() < count {
        let (x, y) = (
            rng.random_range(-side / 2.0..side / 2.0),
            rng.random_range(-side / 2.0..side / 2.0),
        );
        let r = rng.random_range(0.3..1.5);
        if x.hypot(y) < r + 2.0 {
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
