#!/usr/bin/env python3
"""Three 1 M-triangle scenes from single mesh files, for the peers benchmark (`--scene`).

    python3 bench/mesh_scenes.py target/mesh-scenes
    target/release/radarnav bench target/mesh-scenes/rocks.toml --export target/mesh-scenes/rocks
    target/peers/bin/python bench/peers.py --scene target/mesh-scenes/rocks --no-bullet

- `rock.toml`: one closed, lumpy rock of 998 000 triangles (8 m across) in a 40 m hall.
- `rocks.toml`: 1 050 closed rocks of 960 triangles (0.3-1 m) over a 100 m field, all in one
  OBJ file of one part, as a whole scene exported from an editor comes.
- `soup.toml`: 1 000 000 loose leaves (open triangles of 4 cm) filling 30 x 30 x 3 m of a
  50 m hall: the robot's poses lie inside the mesh's bounds.

Needs numpy only; each file is written once (about 40 MB of OBJ each).
"""

import sys
from pathlib import Path

import numpy as np


def write_obj(path, vertices, faces):
    with open(path, "w") as out:
        out.write("".join("v %.6f %.6f %.6f\n" % tuple(p) for p in vertices))
        out.write("".join("f %d %d %d\n" % tuple(t) for t in faces + 1))


def uv_sphere(stacks, slices):
    """A closed unit UV sphere wound outward: poles as fans."""
    v = [[0.0, 0.0, 1.0]]
    for i in range(1, stacks):
        th = np.pi * i / stacks
        for j in range(slices):
            ph = 2 * np.pi * j / slices
            v.append([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    v.append([0.0, 0.0, -1.0])
    ring = lambda i, j: 1 + i * slices + (j % slices)
    f = [(0, ring(0, j), ring(0, j + 1)) for j in range(slices)]
    for i in range(stacks - 2):
        for j in range(slices):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            f += [(a, c, b), (b, c, d)]
    last = len(v) - 1
    f += [(last, ring(stacks - 2, j + 1), ring(stacks - 2, j)) for j in range(slices)]
    return np.array(v), np.array(f)


def hall(side):
    s = side + 0.1
    return ('[[object]]\nname = "hall"\nmaterial = "concrete"\n'
            f'wall = {{ points = [[-0.1, -0.1], [{s}, -0.1], [{s}, {s}], [-0.1, {s}], [-0.1, -0.1]], '
            'thickness = 0.2, height = 3.0 }\n')


def scenario(description, side, mesh):
    return (f'description = "{description}"\n\n[sim]\ndt = 0.05\nduration = 10.0\nseed = 1\n\n'
            + hall(side) + '\n[[object]]\nname = "mesh"\n' + mesh)


def main(out):
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    # One lumpy rock.
    v, f = uv_sphere(500, 1000)
    th = np.arccos(np.clip(v[:, 2], -1, 1))
    ph = np.arctan2(v[:, 1], v[:, 0])
    r = 4.0 * (1 + 0.05 * np.sin(7 * th) * np.cos(9 * ph) + 0.02 * np.sin(23 * ph + 3 * th))
    write_obj(out / "rock.obj", v * r[:, None] + [0, 0, 4.0], f)
    (out / "rock.toml").write_text(scenario("a 1 M-triangle rock in a 40 m hall", 40,
        'material = "concrete"\nmesh = { file = "rock.obj", center = [20.0, 20.0] }\n'))
    # Rocks over a field, one file.
    v0, f0 = uv_sphere(16, 32)
    vs, fs = [], []
    for k, (x, y) in enumerate(rng.uniform(0, 100, (1050, 2))):
        size = rng.uniform(0.3, 1.0)
        bump = 1 + 0.045 * rng.standard_normal((len(v0), 1))
        vs.append(v0 * bump * size + [x, y, 0.8 * size])
        fs.append(f0 + k * len(v0))
    write_obj(out / "rocks.obj", np.vstack(vs), np.vstack(fs))
    (out / "rocks.toml").write_text(scenario("1 050 rocks in one mesh file over a 100 m field", 100,
        'material = "concrete"\nmesh = { file = "rocks.obj" }\n'))
    # Loose leaves.
    n = 1_000_000
    c = rng.uniform([0, 0, 0], [30, 30, 3], (n, 3))
    e1, e2 = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    e1 *= 0.04 / np.linalg.norm(e1, axis=1)[:, None]
    e2 *= 0.04 / np.linalg.norm(e2, axis=1)[:, None]
    write_obj(out / "soup.obj", np.stack([c, c + e1, c + e2], 1).reshape(-1, 3),
              np.arange(3 * n).reshape(-1, 3))
    (out / "soup.toml").write_text(scenario("1 M loose leaves in a 50 m hall", 50,
        'material = "wood"\nmesh = { file = "soup.obj", center = [10.0, 10.0] }\n'))
    print(f"wrote rock, rocks and soup scenarios to {out}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
