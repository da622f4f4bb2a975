//! Generated forests for benchmarks and stress tests: many foliage spheres over a square, or
//! as many generated trees and bushes (triangle meshes).

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::mesh::TriMesh;
use super::procedural::{BARK, Plant, grow};
use super::{MaterialId, MaterialTable, Object, Shape, World};

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

/// One place of a forest: where, how large, and its foliage.
struct Spot {
    x: f64,
    y: f64,
    radius: f64,
    foliage: MaterialId,
}

/// Draws `spec.count` spots uniformly over the square (outside the clearing), one in four
/// `foliage_dense`, the rest `foliage_light`, and hands each to `fill` with the draws and the
/// objects so far, to put something there. Same spec, same spots.
fn scatter(
    spec: &ForestSpec,
    mut fill: impl FnMut(&mut ChaCha8Rng, &MaterialTable, Spot, &mut Vec<Object>),
) -> World {
    let materials = MaterialTable::default();
    let light = materials.id("foliage_light").expect("built-in material");
    let dense = materials.id("foliage_dense").expect("built-in material");
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let half = spec.side / 2.0;
    let mut objects = Vec::with_capacity(spec.count);
    let mut placed = 0;
    while placed < spec.count {
        let (x, y) = (rng.random_range(-half..half), rng.random_range(-half..half));
        let radius = rng.random_range(spec.radius.0..spec.radius.1);
        if spec.clearing > 0.0 && x.hypot(y) < radius + spec.clearing {
            continue;
        }
        let foliage = if rng.random_range(0..4) == 0 {
            dense
        } else {
            light
        };
        let spot = Spot {
            x,
            y,
            radius,
            foliage,
        };
        fill(&mut rng, &materials, spot, &mut objects);
        placed += 1;
    }
    World::new(materials, objects)
}

/// The forest of `spec`: spheres resting on the ground, one in four `foliage_dense`, the rest
/// `foliage_light`. Same spec, same forest.
pub fn forest_of(spec: &ForestSpec) -> World {
    scatter(spec, |_, _, s, objects| {
        objects.push(Object {
            name: None,
            shape: Shape::sphere(DVec3::new(s.x, s.y, s.radius), s.radius)
                .expect("positive radius"),
            material: s.foliage,
        })
    })
}

/// The forest of `spec` grown as plants: a generated tree (5–8 m, bark `wood`) where
/// [`forest_of`] puts a sphere of radius above the middle of its range, else a bush as high as
/// that sphere; its leaves of the sphere's foliage; each plant turned by a random yaw. Same
/// spec, same forest.
pub fn plant_forest_of(spec: &ForestSpec) -> World {
    let middle = (spec.radius.0 + spec.radius.1) / 2.0;
    scatter(spec, |rng, materials, s, objects| {
        let wood = materials.id("wood").expect("built-in material");
        let (sin, cos) = rng.random_range(0.0..std::f64::consts::TAU).sin_cos();
        let (plant, height) = if s.radius > middle {
            (Plant::Tree, rng.random_range(5.0..8.0))
        } else {
            (Plant::Bush, 2.0 * s.radius)
        };
        for part in grow(plant, height, rng.random()) {
            let vertices = (part.vertices.iter())
                .map(|v| {
                    let x = s.x + cos * v.x - sin * v.y;
                    DVec3::new(x, s.y + sin * v.x + cos * v.y, v.z)
                })
                .collect();
            let mesh = TriMesh::new(vertices, part.triangles).expect("a generated plant is a mesh");
            let bark = part.material.as_deref() == Some(BARK);
            objects.push(Object {
                name: None,
                shape: Shape::Mesh(std::sync::Arc::new(mesh)),
                material: if bark { wood } else { s.foliage },
            });
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plant_forest_is_seeded_and_closed() {
        let spec = ForestSpec {
            count: 6,
            side: 30.0,
            radius: (0.3, 1.0),
            clearing: 2.0,
            seed: 4,
        };
        let w = plant_forest_of(&spec);
        assert_eq!(
            w.objects(),
            plant_forest_of(&spec).objects(),
            "same seed, same forest"
        );
        assert!(w.objects().len() >= 6, "a part or two per plant");
        for o in w.objects() {
            let Shape::Mesh(m) = &o.shape else {
                panic!("a plant is a mesh")
            };
            assert!(m.is_closed());
            let (lo, hi) = m.aabb();
            assert!(lo.z >= 0.0 && hi.z <= 8.0 && lo.truncate().length() > 0.0);
        }
    }
}
