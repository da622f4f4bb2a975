#!/usr/bin/env python3
"""radarnav beside Embree (Open3D RaycastingScene) and Bullet (pybullet rayTestBatch).

radarnav exports a scene and its rays (`radarnav bench --export`); this script traces exactly
those rays with Embree and Bullet, interleaved with radarnav's own timing of the same rays
(`radarnav bench --rays`), one thread each, and prints rays per CPU-second (medians) side by
side, with the range differences against radarnav's exact ranges.

    python3 -m venv target/peers && target/peers/bin/pip install -r bench/requirements.txt
    target/peers/bin/python bench/peers.py               # the 10 000-sphere forest
    target/peers/bin/python bench/peers.py --scaling     # 1k/10k/100k, constant density and area
    target/release/radarnav bench foliage-wall --export target/fw && \
      target/peers/bin/python bench/peers.py --scene target/fw    # any scenario's world
    target/peers/bin/python bench/peers.py --plants      # 1 M triangles: generated trees and bushes

Open3D needs libusb-1.0 (Debian: `apt-get install libusb-1.0-0`). Embree sees the spheres as
triangle meshes (`--sphere-resolution`, Open3D's create_sphere); Bullet and radarnav as exact
spheres. CPU time is `time.process_time()` for the peers (Open3D and Bullet are told to use
one thread) and the thread's CPU clock inside radarnav.
"""

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def radarnav(binary, *args):
    out = subprocess.run([binary, *args], check=True, capture_output=True, text=True)
    return out.stdout


def load_scene(scene):
    world = json.loads((scene / "world.json").read_text())
    meta = json.loads((scene / "meta.json").read_text())
    rays = np.loadtxt(scene / "rays.csv", delimiter=",", skiprows=1, ndmin=2)
    if any("mesh" in obj for obj in world):
        vertices = np.fromfile(scene / "meshes.vertices.f64", dtype="<f8").reshape(-1, 3)
        triangles = np.fromfile(scene / "meshes.triangles.u32", dtype="<u4").reshape(-1, 3)
        for obj in world:
            if "mesh" in obj:
                (v0, nv), (t0, nt) = obj["mesh"]["vertices"], obj["mesh"]["triangles"]
                obj["mesh"] = (vertices[v0:v0 + nv], triangles[t0:t0 + nt])
    return world, meta, rays



def box_mesh(center, size, yaw):
    import open3d as o3d

    mesh = o3d.geometry.TriangleMesh.create_box(*size)
    mesh.translate(-np.asarray(size) / 2.0)
    mesh.rotate(mesh.get_rotation_matrix_from_xyz((0.0, 0.0, yaw)), center=(0, 0, 0))
    mesh.translate(center)
    return mesh


def embree_scene(world, resolution):
    """One triangle mesh per object: spheres tessellated by Open3D, boxes, cylinders."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene(nthreads=1)
    for obj in world:
        if "mesh" in obj:
            vertices, triangles = obj["mesh"]
            scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)),
                                o3d.core.Tensor(triangles.astype(np.uint32)))
            continue
        if "sphere" in obj:
            x, y, z, r = obj["sphere"]
            mesh = o3d.geometry.TriangleMesh.create_sphere(r, resolution=resolution)
            mesh.translate((x, y, z))
        elif "box" in obj:
            b = obj["box"]
            mesh = box_mesh(b["center"], b["size"], b["yaw"])
        else:
            c = obj["cylinder"]
            mesh = o3d.geometry.TriangleMesh.create_cylinder(c["radius"], c["height"], resolution=64)
            mesh.translate(c["center"])
        scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
    return scene


def embree_trace(scene, rays, t_max):
    import open3d as o3d

    tensor = o3d.core.Tensor(rays.astype(np.float32))
    t0 = time.process_time()
    hits = scene.cast_rays(tensor, nthreads=1)["t_hit"].numpy().astype(np.float64)
    cpu = time.process_time() - t0
    hits[hits > t_max] = np.inf
    return hits, cpu


def bullet_scene(world):
    import pybullet as p

    client = p.connect(p.DIRECT)
    shapes = {}
    for obj in world:
        if "mesh" in obj:
            vertices, triangles = obj["mesh"]
            s = p.createCollisionShape(p.GEOM_MESH, vertices=vertices.tolist(),
                                       indices=triangles.reshape(-1).tolist(), physicsClientId=client)
            p.createMultiBody(0, s, physicsClientId=client)
        elif "sphere" in obj:
            x, y, z, r = obj["sphere"]
            key = ("sphere", r)
            if key not in shapes:
                shapes[key] = p.createCollisionShape(p.GEOM_SPHERE, radius=r, physicsClientId=client)
            p.createMultiBody(0, shapes[key], basePosition=(x, y, z), physicsClientId=client)
        elif "box" in obj:
            b = obj["box"]
            s = p.createCollisionShape(p.GEOM_BOX, halfExtents=[v / 2 for v in b["size"]], physicsClientId=client)
            orn = p.getQuaternionFromEuler((0, 0, b["yaw"]))
            p.createMultiBody(0, s, basePosition=b["center"], baseOrientation=orn, physicsClientId=client)
        else:
            c = obj["cylinder"]
            s = p.createCollisionShape(p.GEOM_CYLINDER, radius=c["radius"], height=c["height"], physicsClientId=client)
            p.createMultiBody(0, s, basePosition=c["center"], physicsClientId=client)
    return client


def bullet_trace(client, rays, t_max):
    import pybullet as p

    starts = rays[:, :3]
    ends = starts + rays[:, 3:] * t_max
    out = np.full(len(rays), np.inf)
    batch = p.MAX_RAY_INTERSECTION_BATCH_SIZE if hasattr(p, "MAX_RAY_INTERSECTION_BATCH_SIZE") else 16384
    t0 = time.process_time()
    for k in range(0, len(rays), batch):
        res = p.rayTestBatch(starts[k:k + batch].tolist(), ends[k:k + batch].tolist(), numThreads=1, physicsClientId=client)
        for i, hit in enumerate(res):
            if hit[0] >= 0:
                out[k + i] = hit[2] * t_max
    return out, time.process_time() - t0


def differences(ours, theirs):
    both = np.isfinite(ours) & np.isfinite(theirs)
    disagree = int(np.sum(np.isfinite(ours) != np.isfinite(theirs)))
    d = np.abs(ours[both] - theirs[both])
    return {
        "median_abs_m": float(np.median(d)) if d.size else float("nan"),
        "p99_abs_m": float(np.percentile(d, 99)) if d.size else float("nan"),
        "hit_disagreements": disagree,
    }


def measure(binary, scene, repeats, resolution, bullet=True):
    world, meta, rays = load_scene(scene)
    t_max = meta["range"]
    embree = embree_scene(world, resolution)
    client = bullet_scene(world) if bullet else None
    rates = {"radarnav laser": [], "radarnav radar": [], "embree": [], "bullet": []}
    # Embree builds its BVH on the first cast, Bullet its broadphase pairs: not timed.
    embree_trace(embree, rays[:64], t_max)
    if bullet:
        bullet_trace(client, rays[:64], t_max)
    for _ in range(repeats):
        # Interleaved, so that the machine's load falls on every engine alike.
        ours = json.loads(radarnav(binary, "bench", "--rays", str(scene), "--repeats", "1", "--json"))
        rates["radarnav laser"].append(ours["laser_rays_per_cpu_s"])
        rates["radarnav radar"].append(ours["radar_rays_per_cpu_s"])
        e_hits, cpu = embree_trace(embree, rays, t_max)
        rates["embree"].append(len(rays) / cpu)
        if bullet:
            b_hits, cpu = bullet_trace(client, rays, t_max)
            rates["bullet"].append(len(rays) / cpu)
    laser = np.fromfile(scene / "ranges_laser.f64", dtype="<f8")
    diffs = {"embree": differences(laser, e_hits)}
    if bullet:
        diffs["bullet"] = differences(laser, b_hits)
    medians = {k: statistics.median(v) for k, v in rates.items() if v}
    return meta, medians, diffs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--radarnav", default=str(ROOT / "target/release/radarnav"), help="radarnav binary")
    ap.add_argument("--out", default=str(ROOT / "target/peers"), help="scene directories go here")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sphere-resolution", type=int, default=10,
                    help="Open3D create_sphere resolution (10: 1.3 cm median range error)")
    ap.add_argument("--scaling", action="store_true", help="1k/10k/100k spheres, constant density and fixed area")
    ap.add_argument("--scene", help="a scene exported by `radarnav bench [SCENARIO] --export DIR` instead of the forest")
    ap.add_argument("--plants", type=int, nargs="?", const=1300, metavar="N",
                    help="a forest of N generated trees and bushes (default 1300: about 1 M triangles) instead of spheres")
    ap.add_argument("--no-bullet", action="store_true", help="leave Bullet out")
    args = ap.parse_args()
    if not Path(args.radarnav).exists():
        sys.exit(f"{args.radarnav}: build it first (cargo build --release -p radarnav-cli)")
    out = Path(args.out)
    forest = ["--radius", "0.3,1.0", "--poses", "200", "--range", "80"]

    def scene(name, n, side, *extra):
        d = out / name
        radarnav(args.radarnav, "bench", "--export", str(d), "--forest", str(n), "--side", str(side), *forest, *extra)
        return d

    if not args.scaling:
        if args.scene:
            d = Path(args.scene)
        elif args.plants:
            d = scene(f"plants-{args.plants}", args.plants, 200, "--plants")
        else:
            d = scene("forest-10k", 10000, 200)
        meta, med, diffs = measure(args.radarnav, d, args.repeats, args.sphere_resolution, bullet=not args.no_bullet)
        print(meta["about"])
        print(f"rays per CPU-second, one thread, median of {args.repeats} interleaved runs:")
        print("| engine | M rays / CPU-s | range vs radarnav (median, p99) | hit/miss disagreements |")
        print("|---|---|---|---|")
        for k, v in sorted(med.items(), key=lambda kv: -kv[1]):
            d = diffs.get(k)
            extra = f"{d['median_abs_m'] * 100:.2f} cm, {d['p99_abs_m'] * 100:.2f} cm | {d['hit_disagreements']}" if d else "exact (reference) | -"
            if k == "radarnav radar":
                extra = "through foliage (no peer) | -"
            print(f"| {k} | {v / 1e6:.2f} | {extra} |")
        return
    print(f"µs per ray, one thread, median of {args.repeats} interleaved runs (Embree: spheres at resolution {args.sphere_resolution})")
    print("| spheres | layout | radarnav laser | radarnav radar | Embree |")
    print("|---|---|---|---|---|")
    for layout, sides in [("constant density", {1000: 63.2, 10000: 200, 100000: 632.5}),
                          ("fixed 200 m area", {1000: 200, 10000: 200, 100000: 200})]:
        for n, side in sides.items():
            d = scene(f"scale-{n}-{int(side)}", n, side)
            _, med, _ = measure(args.radarnav, d, args.repeats, args.sphere_resolution, bullet=False)
            us = {k: 1e6 / v for k, v in med.items()}
            print(f"| {n} | {layout} ({side:g} m) | {us['radarnav laser']:.3f} | {us['radarnav radar']:.3f} | {us['embree']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
