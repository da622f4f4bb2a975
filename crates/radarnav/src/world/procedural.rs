//! Seeded trees and bushes as closed meshes (DESIGN §2 `mesh`, issue: detailed foliage): a
//! trunk and branches of tapered prisms (`bark`) under a crown of leaf clusters (`leaves`),
//! each cluster a lumpy subdivided icosahedron. Every piece is closed, and overlapping pieces
//! make one volume (the mesh intervals follow the winding number), so a crown is entered and
//! left like a sphere but has an irregular, gappy outline a radar can find thin parts in.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::mesh::MeshPart;

/// What to grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plant {
    /// A trunk, a few branches and a crown.
    Tree,
    /// Leaf clusters resting on the ground.
    Bush,
}

impl Plant {
    /// By name: `tree` or `bush`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "tree" => Some(Self::Tree),
            "bush" => Some(Self::Bush),
            _ => None,
        }
    }

    /// Default height, m.
    pub fn default_height(self) -> f64 {
        match self {
            Self::Tree => 5.0,
            Self::Bush => 1.2,
        }
    }
}

/// Part names the generator gives its faces.
pub const BARK: &str = "bark";
/// See [`BARK`].
pub const LEAVES: &str = "leaves";

/// A closed mesh being assembled from closed pieces.
#[derive(Default)]
struct Builder {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    fn into_part(self, name: &str) -> MeshPart {
        MeshPart {
            material: Some(name.to_owned()),
            // A lobe that would dip into the ground rests on it instead.
            vertices: self
                .vertices
                .into_iter()
                .map(|v| DVec3::new(v.x, v.y, v.z.max(0.0)))
                .collect(),
            triangles: self.triangles,
        }
    }

    /// A lumpy ball: an icosahedron subdivided once, each vertex at `radius` times
    /// a smooth seeded factor in about [1 − lump, 1 + lump], wound outward.
    fn cluster(&mut self, rng: &mut ChaCha8Rng, center: DVec3, radius: DVec3, lump: f64) {
        // 80 faces: lumpy enough for a leaf cluster, cheap for the rays.
        let (dirs, faces) = icosphere(1);
        // A few random low-frequency waves over the sphere: smooth lumps.
        let waves: Vec<(DVec3, f64, f64)> = (0..4)
            .map(|_| {
                let k = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * 3.0;
                (
                    k,
                    rng.random_range(0.0..std::f64::consts::TAU),
                    rng.random_range(0.3..1.0),
                )
            })
            .collect();
        let norm: f64 = waves.iter().map(|w| w.2).sum();
        let base = self.vertices.len() as u32;
        self.vertices.extend(dirs.iter().map(|&d| {
            let bump: f64 = waves
                .iter()
                .map(|(k, ph, a)| a * (k.dot(d) + ph).cos())
                .sum();
            center + d * radius * (1.0 + lump * bump / norm)
        }));
        self.triangles
            .extend(faces.iter().map(|f| f.map(|i| i + base)));
    }

    /// A closed tapered prism of `sides` sides from `a` (radius `ra`) to `b` (radius `rb`).
    fn limb(&mut self, a: DVec3, b: DVec3, ra: f64, rb: f64, sides: u32) {
        let axis = (b - a).normalize();
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let base = self.vertices.len() as u32;
        for (c, r) in [(a, ra), (b, rb)] {
            for i in 0..sides {
                let t = std::f64::consts::TAU * f64::from(i) / f64::from(sides);
                self.vertices.push(c + (u * t.cos() + v * t.sin()) * r);
            }
        }
        self.vertices.push(a);
        self.vertices.push(b);
        let (ca, cb) = (base + 2 * sides, base + 2 * sides + 1);
        for i in 0..sides {
            let j = (i + 1) % sides;
            let (a0, a1, b0, b1) = (base + i, base + j, base + sides + i, base + sides + j);
            self.triangles.push([a0, a1, b1]);
            self.triangles.push([a0, b1, b0]);
            self.triangles.push([ca, a1, a0]);
            self.triangles.push([cb, b0, b1]);
        }
    }
}

/// The unit icosahedron subdivided `level` times: directions and outward faces.
fn icosphere(level: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<DVec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) / 2.0).normalize());
                (v.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut v),
                midpoint(b, c, &mut v),
                midpoint(c, a, &mut v),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}

/// A seeded plant of `height` metres standing at the origin on the ground (z up): its `bark`
/// part (a tree only) and its `leaves` part, each a union of closed pieces.
pub fn grow(plant: Plant, height: f64, seed: u64) -> Vec<MeshPart> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut leaves = Builder::default();
    match plant {
        Plant::Bush => {
            // A squat core from near the ground up, with lobes over a flattened dome as wide
            // as the bush is high: dense at the bottom, irregular at the rim.
            let r = height / 2.0;
            let core = DVec3::new(0.8, 0.8, 0.62) * r;
            leaves.cluster(&mut rng, DVec3::Z * (core.z * 1.15), core, 0.15);
            let n = rng.random_range(5..=8);
            for _ in 0..n {
                let a = rng.random_range(0.0..std::f64::consts::TAU);
                let d = rng.random_range(0.25..0.6) * r;
                let cr = rng.random_range(0.4..0.6) * r;
                let z = rng.random_range(0.75 * cr..(2.0 * r - cr).max(cr));
                let c = DVec3::new(d * a.cos(), d * a.sin(), z);
                let squash = DVec3::new(1.0, 1.0, rng.random_range(0.75..1.0));
                leaves.cluster(&mut rng, c, squash * cr, 0.25);
            }
            vec![leaves.into_part(LEAVES)]
        }
        Plant::Tree => {
            let mut bark = Builder::default();
            let trunk_top = height * rng.random_range(0.55..0.7);
            let r0 = height * 0.035;
            bark.limb(DVec3::ZERO, DVec3::Z * trunk_top, r0, r0 * 0.6, 10);
            // The crown: clusters round branch tips spread over an ellipsoid above the
            // trunk's fork.
            let crown_r = height * rng.random_range(0.22..0.3);
            let crown_c = DVec3::Z * (height - crown_r);
            let n = rng.random_range(7..=11);
            for k in 0..n {
                let a = std::f64::consts::TAU * (k as f64 + rng.random_range(0.0..0.6)) / n as f64;
                let out = rng.random_range(0.35..0.8) * crown_r;
                let up = rng.random_range(-0.5..0.6) * crown_r;
                let tip = crown_c + DVec3::new(out * a.cos(), out * a.sin(), up);
                let fork = DVec3::Z * rng.random_range(trunk_top * 0.8..trunk_top);
                bark.limb(fork, tip, r0 * 0.35, r0 * 0.15, 6);
                let cr = rng.random_range(0.35..0.55) * crown_r;
                leaves.cluster(&mut rng, tip, DVec3::splat(cr), 0.3);
            }
            vec![bark.into_part(BARK), leaves.into_part(LEAVES)]
        }
    }
}

/// `parts` as Wavefront OBJ text (one `usemtl` group per part, for an MTL named `mtl`).
pub fn to_obj(parts: &[MeshPart], mtl: &str) -> String {
    use std::fmt::Write as _;
    let mut s = format!("# radarnav procedural mesh\nmtllib {mtl}\n");
    let mut base = 1;
    for p in parts {
        for v in &p.vertices {
            let _ = writeln!(s, "v {} {} {}", v.x, v.y, v.z);
        }
        if let Some(m) = &p.material {
            let _ = writeln!(s, "usemtl {m}");
        }
        for t in &p.triangles {
            let _ = writeln!(s, "f {} {} {}", t[0] + base, t[1] + base, t[2] + base);
        }
        base += p.vertices.len() as u32;
    }
    s
}

/// Writes `parts` to `path` as OBJ with its MTL beside it (same stem, `.mtl`), each file
/// whole or not at all; `mesh = { file = … }` reads them back as the same parts.
pub fn write_obj(path: &std::path::Path, parts: &[MeshPart]) -> std::io::Result<()> {
    let mtl = path.with_extension("mtl");
    let mtl_name = mtl
        .file_name()
        .map_or_else(|| "plant.mtl".into(), |n| n.to_string_lossy().into_owned());
    crate::output::write_whole(&mtl, to_mtl(parts).as_bytes())?;
    crate::output::write_whole(path, to_obj(parts, &mtl_name).as_bytes())
}

/// The MTL text naming `parts`' materials (colours for viewers: brown bark, green leaves).
pub fn to_mtl(parts: &[MeshPart]) -> String {
    parts
        .iter()
        .filter_map(|p| p.material.as_deref())
        .map(|m| {
            let kd = if m == BARK {
                "0.40 0.26 0.13"
            } else {
                "0.20 0.50 0.15"
            };
            format!("newmtl {m}\nKd {kd}\n")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Ray;
    use crate::world::mesh::TriMesh;

    fn mesh(p: &MeshPart) -> TriMesh {
        TriMesh::new(p.vertices.clone(), p.triangles.clone()).expect("mesh")
    }

    #[test]
    fn plants_are_closed_seeded_and_as_tall_as_asked() {
        for plant in [Plant::Tree, Plant::Bush] {
            let h = plant.default_height();
            let a = grow(plant, h, 3);
            assert_eq!(a, grow(plant, h, 3), "same seed, same plant");
            assert_ne!(a, grow(plant, h, 4), "another seed, another plant");
            let mut top = 0.0f64;
            for p in &a {
                let m = mesh(p);
                assert!(
                    m.is_closed(),
                    "{plant:?} {:?}: {}",
                    p.material,
                    m.why_open()
                );
                top = top.max(m.aabb().1.z);
                assert!(m.aabb().0.z > -1e-9, "{plant:?} below the ground");
            }
            assert!((top - h).abs() < 0.35 * h, "{plant:?}: top {top} for {h}");
        }
    }

    #[test]
    fn a_crown_is_a_volume_a_level_ray_enters_and_leaves() {
        let parts = grow(Plant::Tree, 5.0, 1);
        let leaves = mesh(
            parts
                .iter()
                .find(|p| p.material.as_deref() == Some(LEAVES))
                .unwrap(),
        );
        let (lo, hi) = leaves.aabb();
        let z = (lo.z + hi.z) / 2.0;
        let mut through = 0;
        for k in 0..40 {
            let y = lo.y + (hi.y - lo.y) * (k as f64 + 0.5) / 40.0;
            let ray = Ray::new(DVec3::new(lo.x - 5.0, y, z), DVec3::X);
            let mut iv = Vec::new();
            leaves.ray_intervals(&ray, &mut iv);
            for w in iv.windows(2) {
                assert!(w[0].1 < w[1].0);
            }
            through += usize::from(!iv.is_empty());
        }
        assert!(through > 20, "{through} of 40 rays met the crown");
    }

    #[test]
    fn obj_text_reads_back_as_the_same_parts() {
        let parts = grow(Plant::Tree, 4.0, 9);
        let dir = std::env::temp_dir().join(format!("radarnav-grow-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("t.obj"), to_obj(&parts, "t.mtl")).unwrap();
        std::fs::write(dir.join("t.mtl"), to_mtl(&parts)).unwrap();
        let place = crate::scenario::mesh_file::Placement {
            up: crate::scenario::mesh_file::Up::Z,
            scale: 1.0,
            yaw: 0.0,
            center: DVec3::ZERO,
        };
        let back = crate::scenario::mesh_file::load(&dir.join("t.obj"), &place).unwrap();
        assert_eq!(back.len(), 2);
        // The reader numbers vertices its own way: compare the triangles' corners, which
        // `{}` (the shortest text that reads back to the same f64) keeps bit for bit.
        let corners = |p: &MeshPart| -> Vec<[DVec3; 3]> {
            p.triangles
                .iter()
                .map(|t| t.map(|i| p.vertices[i as usize]))
                .collect()
        };
        for (a, b) in parts.iter().zip(&back) {
            assert_eq!(a.material, b.material);
            assert_eq!(corners(a), corners(b));
        }
    }
}
