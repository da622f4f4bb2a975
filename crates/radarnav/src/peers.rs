//! The scene and rays of the peers benchmark (DESIGN §11): radarnav exports exactly what it
//! traces, so that Embree (Open3D) and Bullet (pybullet) trace the same rays through the same
//! objects (`bench/peers.py`).
//!
//! A scene directory holds `world.json` (the objects as primitives: spheres, boxes with yaw,
//! vertical cylinders; a wall as one box per segment; triangle meshes as slices of
//! `meshes.vertices.f64` (x, y, z little-endian f64 per vertex) and `meshes.triangles.u32`
//! (three little-endian u32 vertex indices per triangle, counted from the mesh's first
//! vertex)), `rays.csv` (`ox,oy,oz,dx,dy,dz`, unit directions) and `meta.json` (range and how
//! the scene was made).

use std::fs;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::world::forest::{ForestSpec, forest_of};
use crate::world::mesh::TriMesh;
use crate::world::{MaterialTable, Object, Ray, Shape, World};

/// A failure to write or read a scene directory.
#[derive(Debug, Error)]
pub enum SceneError {
    /// An I/O error on a file.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// A file that is not what this module writes.
    #[error("{path}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// One primitive of `world.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Primitive {
    /// `[x, y, z, radius]`.
    Sphere([f64; 4]),
    /// A box rotated about z.
    Box {
        /// Centre.
        center: [f64; 3],
        /// Full size.
        size: [f64; 3],
        /// Yaw, radians.
        yaw: f64,
    },
    /// A vertical cylinder.
    Cylinder {
        /// Centre (half-way up).
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
    /// A triangle mesh: vertices `vertices.0..vertices.0 + vertices.1` of
    /// [`MESH_VERTICES`], triangles `triangles.0..triangles.0 + triangles.1` of
    /// [`MESH_TRIANGLES`].
    Mesh {
        /// First vertex and count.
        vertices: (usize, usize),
        /// First triangle and count.
        triangles: (usize, usize),
    },
}

/// The file of every mesh's vertices in a scene directory.
pub const MESH_VERTICES: &str = "meshes.vertices.f64";
/// The file of every mesh's triangles in a scene directory.
pub const MESH_TRIANGLES: &str = "meshes.triangles.u32";

/// One object of `world.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneObject {
    /// Its primitive.
    #[serde(flatten)]
    pub primitive: Primitive,
    /// Built-in material name.
    pub material: String,
}

/// `meta.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneMeta {
    /// Ray length, metres.
    pub range: f64,
    /// Number of rays.
    pub rays: usize,
    /// Number of objects.
    pub objects: usize,
    /// How the scene was made.
    pub about: String,
}

/// A forest scene as the peers benchmark traces it: `spec`'s spheres, and the rays of
/// [`pose_rays`] over the forest's square.
pub fn forest_scene(
    spec: &ForestSpec,
    poses: usize,
    rays_per_pose: usize,
    height: f64,
) -> (World, Vec<Ray>) {
    let world = forest_of(spec);
    let half = DVec2::splat(spec.side / 2.0);
    let rays = pose_rays(
        &world,
        (-half, half),
        poses,
        rays_per_pose,
        height,
        spec.seed,
    );
    (world, rays)
}

/// Rays from `poses` sensor poses drawn uniformly over the rectangle `area` (outside every
/// object) at `height`, each casting `rays_per_pose` level rays evenly round the circle from
/// a random start bearing. Fewer poses when the free space is hard to find.
pub fn pose_rays(
    world: &World,
    (lo, hi): (DVec2, DVec2),
    poses: usize,
    rays_per_pose: usize,
    height: f64,
    seed: u64,
) -> Vec<Ray> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x05ee_d0f7_a7e5);
    let mut rays = Vec::with_capacity(poses * rays_per_pose);
    let mut placed = 0;
    // A bounded number of tries: a world packed solid has no free pose.
    for _ in 0..poses.saturating_mul(1000) {
        if placed == poses || !(lo.x < hi.x && lo.y < hi.y) {
            break;
        }
        let o = DVec3::new(
            rng.random_range(lo.x..hi.x),
            rng.random_range(lo.y..hi.y),
            height,
        );
        if world.objects_at(o).next().is_some() {
            continue;
        }
        placed += 1;
        let start = rng.random_range(0.0..std::f64::consts::TAU);
        for k in 0..rays_per_pose {
            let a = start + k as f64 * std::f64::consts::TAU / rays_per_pose as f64;
            rays.push(Ray::new(o, DVec3::new(a.cos(), a.sin(), 0.0)));
        }
    }
    rays
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> SceneError + '_ {
    move |cause| SceneError::Io {
        path: path.to_owned(),
        cause,
    }
}

/// Writes `world` and `rays` to `dir` (created if missing). Prisms have no primitive here and
/// are left out (their count is returned); meshes go to the two mesh files.
pub fn write_scene(
    dir: &Path,
    world: &World,
    rays: &[Ray],
    range: f64,
    about: &str,
) -> Result<usize, SceneError> {
    fs::create_dir_all(dir).map_err(io(dir))?;
    let names = world.materials();
    let mut objects = Vec::new();
    let mut skipped = 0;
    let (mut vertices, mut triangles) = (Vec::<u8>::new(), Vec::<u8>::new());
    let (mut nv, mut nt) = (0, 0);
    for o in world.objects() {
        let material = names.get(o.material).name.clone();
        let mut push = |primitive| {
            objects.push(SceneObject {
                primitive,
                material: material.clone(),
            })
        };
        match &o.shape {
            Shape::Sphere { center, radius } => {
                push(Primitive::Sphere([center.x, center.y, center.z, *radius]))
            }
            Shape::Box(b) => push(Primitive::Box {
                center: b.center.to_array(),
                size: (b.half * 2.0).to_array(),
                yaw: b.yaw,
            }),
            Shape::Cylinder {
                center,
                radius,
                half_height,
            } => push(Primitive::Cylinder {
                center: center.to_array(),
                radius: *radius,
                height: half_height * 2.0,
            }),
            Shape::Wall { segments, .. } => {
                for b in segments {
                    push(Primitive::Box {
                        center: b.center.to_array(),
                        size: (b.half * 2.0).to_array(),
                        yaw: b.yaw,
                    });
                }
            }
            Shape::Mesh(m) => {
                for v in m.vertices() {
                    vertices.extend(v.to_array().iter().flat_map(|x| x.to_le_bytes()));
                }
                for t in m.triangles() {
                    triangles.extend(t.iter().flat_map(|i| i.to_le_bytes()));
                }
                let (v, t) = (m.vertices().len(), m.triangles().len());
                push(Primitive::Mesh {
                    vertices: (nv, v),
                    triangles: (nt, t),
                });
                (nv, nt) = (nv + v, nt + t);
            }
            Shape::Prism { .. } => skipped += 1,
        }
    }
    let meshes = [(MESH_VERTICES, &vertices), (MESH_TRIANGLES, &triangles)];
    for (name, bytes) in meshes.into_iter().filter(|_| nt > 0) {
        let path = dir.join(name);
        let part = partial(&path);
        fs::write(&part, bytes).map_err(io(&part))?;
        fs::rename(&part, &path).map_err(io(&path))?;
    }
    let meta = SceneMeta {
        range,
        rays: rays.len(),
        objects: objects.len(),
        about: about.to_owned(),
    };
    write_json(&dir.join("world.json"), &objects)?;
    write_json(&dir.join("meta.json"), &meta)?;
    let path = dir.join("rays.csv");
    let part = partial(&path);
    let mut w = BufWriter::new(fs::File::create(&part).map_err(io(&part))?);
    writeln!(w, "ox,oy,oz,dx,dy,dz").map_err(io(&part))?;
    for r in rays {
        // `{:?}` prints the shortest text that reads back to the same f64.
        writeln!(
            w,
            "{:?},{:?},{:?},{:?},{:?},{:?}",
            r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z
        )
        .map_err(io(&part))?;
    }
    w.flush().map_err(io(&part))?;
    drop(w);
    fs::rename(&part, &path).map_err(io(&path))?;
    Ok(skipped)
}

/// Writes `ranges` (one little-endian f64 per ray, `inf` for no return) to
/// `dir/ranges_<name>.f64`, for the peers script to compare; returns the path.
pub fn write_ranges(dir: &Path, name: &str, ranges: &[f64]) -> Result<PathBuf, SceneError> {
    let path = dir.join(format!("ranges_{name}.f64"));
    let part = partial(&path);
    let bytes: Vec<u8> = ranges.iter().flat_map(|r| r.to_le_bytes()).collect();
    fs::write(&part, bytes).map_err(io(&part))?;
    fs::rename(&part, &path).map_err(io(&path))?;
    Ok(path)
}

/// The temporary name a file is written under until it is complete (DESIGN §12).
fn partial(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_owned();
    name.push(".partial");
    path.with_file_name(name)
}

fn write_json(path: &Path, value: &impl Serialize) -> Result<(), SceneError> {
    let text = serde_json::to_string_pretty(value).expect("plain data serialises");
    let part = partial(path);
    fs::write(&part, text).map_err(io(&part))?;
    fs::rename(&part, path).map_err(io(path))
}

/// Reads a scene directory written by [`write_scene`]: the world, the rays and the range.
pub fn read_scene(dir: &Path) -> Result<(World, Vec<Ray>, f64), SceneError> {
    let bad = |path: &Path, what: String| SceneError::Format {
        path: path.to_owned(),
        what,
    };
    let path = dir.join("meta.json");
    let meta: SceneMeta = serde_json::from_str(&fs::read_to_string(&path).map_err(io(&path))?)
        .map_err(|e| bad(&path, e.to_string()))?;
    if !(meta.range > 0.0 && meta.range.is_finite()) {
        return Err(bad(
            &path,
            format!("range must be > 0, found {}", meta.range),
        ));
    }
    let path = dir.join("world.json");
    let list: Vec<SceneObject> =
        serde_json::from_str(&fs::read_to_string(&path).map_err(io(&path))?)
            .map_err(|e| bad(&path, e.to_string()))?;
    let materials = MaterialTable::default();
    let mut objects = Vec::with_capacity(list.len());
    let meshes = MeshFiles::read(dir, &list)?;
    for (i, o) in list.iter().enumerate() {
        let material = materials.id(&o.material).ok_or_else(|| {
            bad(
                &path,
                format!("object {i}: unknown material `{}`", o.material),
            )
        })?;
        let shape = match o.primitive {
            Primitive::Sphere([x, y, z, r]) => {
                Shape::sphere(DVec3::new(x, y, z), r).map_err(|e| e.to_string())
            }
            Primitive::Box { center, size, yaw } => {
                Shape::cuboid(DVec3::from(center), DVec3::from(size), yaw)
                    .map_err(|e| e.to_string())
            }
            Primitive::Cylinder {
                center,
                radius,
                height,
            } => Shape::cylinder(DVec3::from(center), radius, height).map_err(|e| e.to_string()),
            Primitive::Mesh {
                vertices,
                triangles,
            } => meshes
                .mesh(vertices, triangles)
                .map(|m| Shape::Mesh(std::sync::Arc::new(m))),
        }
        .map_err(|e| bad(&path, format!("object {i}: {e}")))?;
        objects.push(Object {
            name: None,
            shape,
            material,
        });
    }
    let path = dir.join("rays.csv");
    let file = fs::File::open(&path).map_err(io(&path))?;
    let mut rays = Vec::with_capacity(meta.rays);
    for (n, line) in BufReader::new(file).lines().enumerate().skip(1) {
        let line = line.map_err(io(&path))?;
        let v: Vec<f64> = line
            .split(',')
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| bad(&path, format!("line {}: {e}", n + 1)))?;
        let [ox, oy, oz, dx, dy, dz] = v[..] else {
            return Err(bad(&path, format!("line {}: expected 6 numbers", n + 1)));
        };
        let dir = DVec3::new(dx, dy, dz);
        if !(DVec3::new(ox, oy, oz).is_finite() && dir.is_finite() && dir.length() > 1e-9) {
            return Err(bad(&path, format!("line {}: not a ray", n + 1)));
        }
        let origin = DVec3::new(ox, oy, oz);
        // Exported directions are unit already: trace exactly the numbers the peers trace.
        rays.push(if (dir.length() - 1.0).abs() < 1e-12 {
            Ray { origin, dir }
        } else {
            Ray::new(origin, dir)
        });
    }
    Ok((World::new(materials, objects), rays, meta.range))
}

/// The two mesh files of a scene, read when `world.json` names a mesh.
struct MeshFiles {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl MeshFiles {
    fn read(dir: &Path, list: &[SceneObject]) -> Result<Self, SceneError> {
        let mut files = Self {
            vertices: Vec::new(),
            triangles: Vec::new(),
        };
        if !list
            .iter()
            .any(|o| matches!(o.primitive, Primitive::Mesh { .. }))
        {
            return Ok(files);
        }
        let read = |name: &str, unit: usize| -> Result<Vec<u8>, SceneError> {
            let path = dir.join(name);
            let bytes = fs::read(&path).map_err(io(&path))?;
            if bytes.len() % unit != 0 {
                return Err(SceneError::Format {
                    path,
                    what: format!("{} bytes, not whole records of {unit}", bytes.len()),
                });
            }
            Ok(bytes)
        };
        let f64s = |b: &[u8]| f64::from_le_bytes(b.try_into().expect("8 bytes"));
        let u32s = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("4 bytes"));
        files.vertices = read(MESH_VERTICES, 24)?
            .chunks_exact(24)
            .map(|v| DVec3::new(f64s(&v[..8]), f64s(&v[8..16]), f64s(&v[16..])))
            .collect();
        files.triangles = read(MESH_TRIANGLES, 12)?
            .chunks_exact(12)
            .map(|t| [u32s(&t[..4]), u32s(&t[4..8]), u32s(&t[8..])])
            .collect();
        Ok(files)
    }

    /// The mesh of the given slices (its indices count from its first vertex).
    fn mesh(&self, (v0, nv): (usize, usize), (t0, nt): (usize, usize)) -> Result<TriMesh, String> {
        let slice = |start: usize, n: usize, len: usize, what: &str| {
            start
                .checked_add(n)
                .filter(|&end| end <= len)
                .map(|end| start..end)
                .ok_or_else(|| format!("{what} {start}..{start}+{n} beyond the {len} in the file"))
        };
        let vs = slice(v0, nv, self.vertices.len(), "vertices")?;
        let ts = slice(t0, nt, self.triangles.len(), "triangles")?;
        TriMesh::new(self.vertices[vs].to_vec(), self.triangles[ts].to_vec())
            .map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Band;

    #[test]
    fn a_scene_reads_back_to_the_same_world_and_rays() {
        let spec = ForestSpec {
            count: 200,
            side: 40.0,
            radius: (0.3, 1.0),
            clearing: 0.0,
            seed: 3,
        };
        let (world, rays) = forest_scene(&spec, 5, 36, 0.4);
        assert_eq!(rays.len(), 180);
        let dir = std::env::temp_dir().join(format!("radarnav-peers-{}", std::process::id()));
        write_scene(&dir, &world, &rays, 80.0, "test").unwrap();
        let (back, back_rays, range) = read_scene(&dir).unwrap();
        fs::remove_dir_all(&dir).ok();
        assert_eq!(range, 80.0);
        assert_eq!(back.objects(), world.objects());
        assert_eq!(back_rays, rays);
        // No pose starts inside a sphere.
        let mut tracer = crate::sensor::Tracer::default();
        for r in &rays {
            assert!(tracer.trace(&world, r, Band::Laser, 0.0, 80.0).range > 0.0);
        }
    }

    #[test]
    fn a_plant_forest_reads_back_with_its_meshes_and_bad_slices_are_refused() {
        let spec = ForestSpec {
            count: 12,
            side: 30.0,
            radius: (0.3, 1.0),
            clearing: 0.0,
            seed: 2,
        };
        let world = crate::world::forest::plant_forest_of(&spec);
        let rays = pose_rays(
            &world,
            (DVec2::splat(-15.0), DVec2::splat(15.0)),
            4,
            90,
            0.4,
            2,
        );
        let dir = std::env::temp_dir().join(format!("radarnav-peers-mesh-{}", std::process::id()));
        write_scene(&dir, &world, &rays, 40.0, "test").unwrap();
        let (back, back_rays, _) = read_scene(&dir).unwrap();
        assert_eq!(back.objects(), world.objects());
        assert_eq!(back_rays, rays);
        let mut tracer = crate::sensor::Tracer::default();
        for r in &rays {
            assert_eq!(
                tracer.trace(&world, r, Band::Laser, 0.0, 40.0),
                tracer.trace(&back, r, Band::Laser, 0.0, 40.0)
            );
        }
        // A slice past the end of the mesh files names the object.
        let text = fs::read_to_string(dir.join("world.json")).unwrap();
        let list: Vec<SceneObject> = serde_json::from_str(&text).unwrap();
        let mut list = list;
        list[0].primitive = Primitive::Mesh {
            vertices: (0, 3),
            triangles: (1 << 40, 1),
        };
        fs::write(
            dir.join("world.json"),
            serde_json::to_string(&list).unwrap(),
        )
        .unwrap();
        let e = read_scene(&dir).unwrap_err().to_string();
        assert!(e.contains("world.json: object 0: triangles"), "{e}");
        fs::write(dir.join(MESH_TRIANGLES), [0u8; 5]).unwrap();
        let e = read_scene(&dir).unwrap_err().to_string();
        assert!(
            e.contains(MESH_TRIANGLES) && e.contains("whole records"),
            "{e}"
        );
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_files_name_the_file_and_line() {
        let dir = std::env::temp_dir().join(format!("radarnav-peers-bad-{}", std::process::id()));
        write_scene(
            &dir,
            &forest_of(&ForestSpec {
                count: 3,
                side: 10.0,
                radius: (0.3, 0.5),
                clearing: 0.0,
                seed: 1,
            }),
            &[Ray::new(DVec3::ZERO, DVec3::X)],
            10.0,
            "test",
        )
        .unwrap();
        fs::write(dir.join("rays.csv"), "ox,oy,oz,dx,dy,dz\n0,0,0,1,0\n").unwrap();
        let e = read_scene(&dir).unwrap_err().to_string();
        assert!(e.contains("rays.csv: line 2"), "{e}");
        fs::write(
            dir.join("world.json"),
            "[{\"sphere\": [0, 0, 0, 1], \"material\": \"cheese\"}]",
        )
        .unwrap();
        let e = read_scene(&dir).unwrap_err().to_string();
        assert!(e.contains("world.json") && e.contains("cheese"), "{e}");
        fs::remove_dir_all(&dir).ok();
    }
}
