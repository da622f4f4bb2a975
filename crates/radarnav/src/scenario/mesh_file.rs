//! Mesh files for `mesh = { file = … }` objects (DESIGN §2): Wavefront OBJ (with its MTL
//! for part names) and glTF 2.0 (`.gltf` with `.bin` files or base64 buffers, or `.glb`),
//! read with `tobj` and `gltf`, placed in the world (up axis, scale, yaw, centre) and split
//! into parts by the material names the file gives its faces.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use base64::Engine as _;

use crate::world::mesh::MAX_TRIANGLES;
use gltf::mesh::Mode;

/// Deepest glTF node hierarchy read.
const MAX_NODE_DEPTH: usize = 256;
use glam::{DMat4, DVec3};

/// Largest mesh file (and each `.bin` or `.mtl` beside it) read, bytes (DESIGN §12).
pub const MAX_MESH_FILE_BYTES: u64 = (crate::limits::MESH_FILE.max as u64) << 20;

/// The up axis a file was modelled with; radarnav's is z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Up {
    /// z up (radarnav, Gazebo, most robotics models).
    Z,
    /// y up (glTF by its specification; Blender's OBJ export by default).
    Y,
}

/// Where a mesh goes: file coordinates are turned to z up, scaled, turned by `yaw` about the
/// vertical and moved so that the file's origin lands on `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The file's up axis.
    pub up: Up,
    /// Scale factor.
    pub scale: f64,
    /// Rotation about z, radians.
    pub yaw: f64,
    /// Where the file's origin goes, m.
    pub center: DVec3,
}

impl Placement {
    /// `parts` (file coordinates) in the world; parts without triangles are dropped.
    pub fn place(&self, parts: Vec<MeshPart>) -> Vec<MeshPart> {
        parts
            .into_iter()
            .filter(|p| !p.triangles.is_empty())
            .map(|mut p| {
                p.vertices.iter_mut().for_each(|v| *v = self.apply(*v));
                p
            })
            .collect()
    }

    fn apply(&self, p: DVec3) -> DVec3 {
        let p = match self.up {
            Up::Z => p,
            Up::Y => DVec3::new(p.x, -p.z, p.y),
        } * self.scale;
        let (s, c) = self.yaw.sin_cos();
        DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + self.center
    }
}

pub use crate::world::mesh::MeshPart;

/// Reads `path` (OBJ by the extension `.obj`, glTF by `.gltf` or `.glb`) and places it; one
/// part per material name, in the order first met. Errors are sentences naming the file.
pub fn load(path: &Path, placement: &Placement) -> Result<Vec<MeshPart>, String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let parts = match ext.as_str() {
        "obj" => obj(path)?,
        "gltf" | "glb" => gltf_parts(path)?,
        _ => {
            return Err(format!(
                "{}: unknown mesh format `.{ext}`; known: .obj, .gltf, .glb",
                path.display()
            ));
        }
    };
    let parts = placement.place(parts);
    if parts.is_empty() {
        return Err(format!(
            "{}: no triangles in the file (points and lines are not surfaces)",
            path.display()
        ));
    }
    Ok(parts)
}

/// The bytes of a regular file of at most [`MAX_MESH_FILE_BYTES`].
fn read_bytes(path: &Path) -> Result<Vec<u8>, String> {
    let fail = |e: std::io::Error| format!("{}: {e}", path.display());
    let meta = std::fs::metadata(path).map_err(fail)?;
    if !meta.is_file() {
        return Err(format!("{}: not a regular file", path.display()));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(fail)?
        .take(MAX_MESH_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(fail)?;
    if bytes.len() as u64 > MAX_MESH_FILE_BYTES {
        return Err(format!(
            "{}: larger than the limit of {} MiB",
            path.display(),
            MAX_MESH_FILE_BYTES >> 20
        ));
    }
    Ok(bytes)
}

/// Parts grouped by material name, first met first.
fn group(parts: impl IntoIterator<Item = MeshPart>) -> Vec<MeshPart> {
    let mut out: Vec<MeshPart> = Vec::new();
    let mut by_name: BTreeMap<Option<String>, usize> = BTreeMap::new();
    for p in parts {
        let k = *by_name.entry(p.material.clone()).or_insert_with(|| {
            out.push(MeshPart {
                material: p.material.clone(),
                ..MeshPart::default()
            });
            out.len() - 1
        });
        let dst = &mut out[k];
        let base = dst.vertices.len() as u32;
        dst.vertices.extend(p.vertices);
        dst.triangles
            .extend(p.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

fn obj(path: &Path) -> Result<Vec<MeshPart>, String> {
    let bytes = read_bytes(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let options = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let mtl = |p: &Path| -> tobj::MTLLoadResult {
        let bytes = read_bytes(&dir.join(p)).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        tobj::load_mtl_buf(&mut &bytes[..])
    };
    let (models, materials) = tobj::load_obj_buf(&mut &bytes[..], &options, mtl)
        .map_err(|e| format!("{}: not a readable OBJ file: {e}", path.display()))?;
    // Without its MTL file the faces' material names are unknown: one part.
    let names: Vec<String> = materials
        .map(|m| m.into_iter().map(|m| m.name).collect())
        .unwrap_or_default();
    let parts = models.into_iter().map(|m| {
        let mesh = m.mesh;
        MeshPart {
            material: mesh.material_id.and_then(|i| names.get(i).cloned()),
            vertices: mesh
                .positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect(),
            triangles: mesh
                .indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
        }
    });
    Ok(group(parts))
}

/// The data of one glTF buffer: the GLB's binary chunk, a base64 data URI or a file beside
/// the glTF file.
fn buffer_data(
    path: &Path,
    buffer: &gltf::Buffer<'_>,
    blob: &mut Option<Vec<u8>>,
) -> Result<Vec<u8>, String> {
    match buffer.source() {
        gltf::buffer::Source::Bin => blob
            .take()
            .ok_or_else(|| format!("{}: buffer without the GLB binary chunk", path.display())),
        gltf::buffer::Source::Uri(uri) => {
            if let Some(data) = uri.strip_prefix("data:") {
                let (_, b64) = data.split_once(";base64,").ok_or_else(|| {
                    format!("{}: a data URI buffer that is not base64", path.display())
                })?;
                return base64::engine::general_purpose::STANDARD
                    .decode(b64)
                    .map_err(|e| format!("{}: a base64 buffer: {e}", path.display()));
            }
            if uri.contains("://") {
                return Err(format!(
                    "{}: buffer `{uri}` is not a file beside it (no downloads)",
                    path.display()
                ));
            }
            let file: PathBuf = path.parent().unwrap_or(Path::new("")).join(uri);
            read_bytes(&file)
        }
    }
}

fn gltf_parts(path: &Path) -> Result<Vec<MeshPart>, String> {
    let bytes = read_bytes(path)?;
    let gltf::Gltf { document, mut blob } = gltf::Gltf::from_slice(&bytes).map_err(|e| {
        // glTF 1.0 (2015) has another layout; say so rather than where its JSON differs.
        let v1 = serde_json::from_slice::<serde_json::Value>(&bytes)
            .ok()
            .and_then(|j| j["asset"]["version"].as_str().map(|v| v.starts_with('1')))
            .unwrap_or(false);
        if v1 {
            format!(
                "{}: glTF 1.0 is not read; convert it to glTF 2.0 (e.g. Blender's importer and exporter)",
                path.display()
            )
        } else {
            format!("{}: not a readable glTF file: {e}", path.display())
        }
    })?;
    let buffers = document
        .buffers()
        .map(|b| buffer_data(path, &b, &mut blob))
        .collect::<Result<Vec<_>, _>>()?;
    // Each buffer file is bounded; so is their sum.
    let total: u64 = buffers.iter().map(|b| b.len() as u64).sum();
    if total > MAX_MESH_FILE_BYTES {
        return Err(format!(
            "{}: its buffers hold more than the limit of {} MiB",
            path.display(),
            MAX_MESH_FILE_BYTES >> 20
        ));
    }
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| format!("{}: no scene", path.display()))?;
    let mut parts = Vec::new();
    let (mut vertices_total, mut triangles_total) = (0usize, 0usize);
    let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> =
        scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    let mut visited = 0usize;
    while let Some((node, parent, depth)) = stack.pop() {
        // A node that is its own ancestor would be visited for ever: refuse deep trees.
        visited += 1;
        if depth > MAX_NODE_DEPTH || visited > 1_000_000 {
            return Err(format!(
                "{}: its nodes nest deeper than {MAX_NODE_DEPTH} levels or number over a million (a node that is its own child?)",
                path.display()
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
        let Some(mesh) = node.mesh() else {
            continue;
        };
        for prim in mesh.primitives() {
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue; // points and lines are not surfaces
            }
            // Nodes may instance one mesh many times: bound what the file expands to before
            // reading it, not only its size on disk.
            let vertex_count = prim
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count());
            let index_count = prim.indices().map_or(vertex_count, |a| a.count());
            let triangles = match mode {
                Mode::Triangles => index_count / 3,
                _ => index_count.saturating_sub(2),
            };
            (vertices_total, triangles_total) =
                (vertices_total + vertex_count, triangles_total + triangles);
            if triangles_total > MAX_TRIANGLES || vertices_total > 3 * MAX_TRIANGLES {
                return Err(format!(
                    "{}: its scene holds more than the limit of {MAX_TRIANGLES} triangles",
                    path.display()
                ));
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let Some(positions) = reader.read_positions() else {
                continue;
            };
            let vertices: Vec<DVec3> = positions
                .map(|p| world.transform_point3(DVec3::new(p[0].into(), p[1].into(), p[2].into())))
                .collect();
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..vertices.len() as u32).collect(),
            };
            // A mirroring transform turns the winding inside out; keep it outward.
            let mirrored = world.determinant() < 0.0;
            let wound = |t: [u32; 3]| if mirrored { [t[0], t[2], t[1]] } else { t };
            let triangles: Vec<[u32; 3]> = match mode {
                Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                    .map(|k| {
                        let (a, b, c) = (indices[k], indices[k + 1], indices[k + 2]);
                        // Every other triangle of a strip runs the other way round.
                        wound(if k % 2 == 0 { [a, b, c] } else { [b, a, c] })
                    })
                    .collect(),
                Mode::TriangleFan => (1..indices.len().saturating_sub(1))
                    .map(|k| wound([indices[0], indices[k], indices[k + 1]]))
                    .collect(),
                _ => indices
                    .chunks_exact(3)
                    .map(|c| wound([c[0], c[1], c[2]]))
                    .collect(),
            };
            parts.push(MeshPart {
                material: prim.material().name().map(str::to_owned),
                vertices,
                triangles,
            });
        }
    }
    Ok(group(parts))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("radarnav-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir.join(name)
    }

    const CUBE_OBJ: &str = "mtllib cube.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
usemtl bark
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
usemtl leaves
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
";

    fn placed() -> Placement {
        Placement {
            up: Up::Z,
            scale: 2.0,
            yaw: std::f64::consts::FRAC_PI_2,
            center: DVec3::new(10.0, 0.0, 0.0),
        }
    }

    #[test]
    fn an_obj_is_placed_and_split_by_its_material_names() {
        let obj = tmp("cube.obj");
        std::fs::write(&obj, CUBE_OBJ).expect("write");
        std::fs::write(
            tmp("cube.mtl"),
            "newmtl bark\nKd 1 0 0\nnewmtl leaves\nKd 0 1 0\n",
        )
        .expect("write");
        let parts = load(&obj, &placed()).expect("loads");
        let names: Vec<_> = parts.iter().map(|p| p.material.as_deref()).collect();
        assert_eq!(names, [Some("bark"), Some("leaves")]);
        assert!(parts.iter().all(|p| p.triangles.len() == 6));
        // (1, 1, 1) scaled by 2 and turned 90° left: (-2, 2, 2), then moved by (10, 0, 0).
        let all: Vec<DVec3> = parts.iter().flat_map(|p| p.vertices.clone()).collect();
        assert!(
            all.iter()
                .any(|v| (*v - DVec3::new(8.0, 2.0, 2.0)).length() < 1e-12)
        );
        // The two parts make one closed cube.
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for p in &parts {
            let base = v.len() as u32;
            v.extend_from_slice(&p.vertices);
            t.extend(p.triangles.iter().map(|x| x.map(|i| i + base)));
        }
        let m = crate::world::mesh::TriMesh::new(v, t).expect("mesh");
        assert!(m.is_closed());
        assert!(m.contains(DVec3::new(9.0, 1.0, 1.0)));
        // Without its MTL the same file is one unnamed part.
        std::fs::remove_file(tmp("cube.mtl")).expect("remove");
        let parts = load(&obj, &placed()).expect("loads");
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0].material, None);
    }

    /// A glTF file with its buffer as base64, y up, one node moved and scaled: read as the
    /// same cube in radarnav's z-up frame.
    #[test]
    fn a_gltf_with_a_base64_buffer_and_node_transforms_is_read_z_up() {
        // A unit triangle pair (a square) in the x-y plane of the file (y up: a wall).
        let pos: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
        let mut bin: Vec<u8> = pos.iter().flat_map(|f| f.to_le_bytes()).collect();
        bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[5,0,0],"scale":[2,2,2]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
            "materials":[{{"name":"glass"}}],
            "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
            bin.len()
        );
        let file = tmp("square.gltf");
        std::fs::write(&file, &json).expect("write");
        let place = Placement {
            up: Up::Y,
            scale: 1.0,
            yaw: 0.0,
            center: DVec3::ZERO,
        };
        let parts = load(&file, &place).expect("loads");
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0].material.as_deref(), Some("glass"));
        assert_eq!(parts[0].triangles.len(), 2);
        // File (1, 1, 0) → node (7, 2, 0) → z up (7, 0, 2).
        assert!(
            parts[0]
                .vertices
                .iter()
                .any(|v| (*v - DVec3::new(7.0, 0.0, 2.0)).length() < 1e-6),
            "{:?}",
            parts[0].vertices
        );
        // The same as a binary GLB: the buffer in its BIN chunk.
        let json = json.replace(
            &format!(r#""uri":"data:application/octet-stream;base64,{b64}""#),
            r#""byteOffset":0"#,
        );
        let json = json.replace(r#","byteOffset":0}],"bufferViews""#, r#"}],"bufferViews""#);
        let pad = |mut v: Vec<u8>, with: u8| {
            while !v.len().is_multiple_of(4) {
                v.push(with);
            }
            v
        };
        let (j, b) = (pad(json.into_bytes(), b' '), pad(bin.clone(), 0));
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(((12 + 8 + j.len() + 8 + b.len()) as u32).to_le_bytes());
        glb.extend((j.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(&j);
        glb.extend((b.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(&b);
        let file = tmp("square.glb");
        std::fs::write(&file, glb).expect("write");
        assert_eq!(load(&file, &place).expect("a GLB loads"), parts);
    }

    /// A unit square in the file's x-y plane as triangles (mode 4), a strip (5) or a fan (6):
    /// the same two triangles, wound alike (both normals along +z, y up → -y after placing).
    #[test]
    fn gltf_strips_and_fans_give_the_triangles_of_a_list() {
        let square = |mode: u32, idx: &[u16]| {
            let pos: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
            let mut bin: Vec<u8> = pos.iter().flat_map(|f| f.to_le_bytes()).collect();
            bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
            let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
            let json = format!(
                r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
                "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],
                "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{b64}"}}],
                "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":{}}}],
                "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                             {{"bufferView":1,"componentType":5123,"count":{},"type":"SCALAR"}}]}}"#,
                bin.len(),
                2 * idx.len(),
                idx.len()
            );
            let file = tmp(&format!("mode{mode}.gltf"));
            std::fs::write(&file, json).expect("write");
            let place = Placement {
                up: Up::Z,
                scale: 1.0,
                yaw: 0.0,
                center: DVec3::ZERO,
            };
            let parts = load(&file, &place).expect("loads");
            let p = &parts[0];
            p.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| p.vertices[i as usize]);
                    (b - a).cross(c - a)
                })
                .collect::<Vec<DVec3>>()
        };
        let list = square(4, &[0, 1, 2, 0, 2, 3]);
        for normals in [
            list.clone(),
            square(5, &[0, 1, 3, 2]),
            square(6, &[0, 1, 2, 3]),
        ] {
            assert_eq!(normals.len(), 2);
            for n in normals {
                assert_eq!(n, DVec3::new(0.0, 0.0, 1.0), "wound like the list");
            }
        }
    }

    /// Nodes that instance one small mesh thousands of times are refused before they are
    /// read: 5 001 nodes × 1 000 triangles from a 12 kB buffer.
    #[test]
    fn a_gltf_that_instances_past_the_triangle_limit_is_refused() {
        let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        bin.extend((0..3000u32).flat_map(|i| (i % 3).to_le_bytes()));
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
        let nodes: Vec<String> = (0..5001).map(|_| r#"{"mesh":0}"#.to_owned()).collect();
        let roots: Vec<String> = (0..5001).map(|i| i.to_string()).collect();
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[{}]}}],"nodes":[{}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12000}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5125,"count":3000,"type":"SCALAR"}}]}}"#,
            roots.join(","),
            nodes.join(","),
            bin.len()
        );
        let file = tmp("bomb.gltf");
        std::fs::write(&file, json).expect("write");
        let e = load(&file, &placed()).expect_err("too many triangles");
        assert!(
            e.contains("more than the limit of 5000000 triangles"),
            "{e}"
        );
    }

    #[test]
    fn bad_files_are_refused_with_their_name() {
        let p = placed();
        let missing = tmp("missing.obj");
        let e = load(&missing, &p).expect_err("missing");
        assert!(e.contains("missing.obj"), "{e}");
        let e = load(Path::new("tree.stl"), &p).expect_err("format");
        assert!(e.contains("unknown mesh format"), "{e}");
        let truncated = tmp("truncated.glb");
        std::fs::write(&truncated, b"glTF\x02\x00\x00\x00").expect("write");
        let e = load(&truncated, &p).expect_err("truncated");
        assert!(e.contains("not a readable glTF"), "{e}");
        let garbage = tmp("garbage.obj");
        std::fs::write(&garbage, "f 1 2 3\n").expect("write");
        let e = load(&garbage, &p).expect_err("no vertices");
        assert!(e.contains("garbage.obj"), "{e}");
        let dir = tmp("folder.obj");
        std::fs::create_dir_all(&dir).expect("dir");
        let e = load(&dir, &p).expect_err("not a file");
        assert!(e.contains("not a regular file"), "{e}");
    }
}
