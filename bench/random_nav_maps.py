#!/usr/bin/env python3
"""Random navigation trial maps: Bug scenarios nobody tuned the navigation to.

Writes N scenario files, each a walled room (14-20 x 9-14 m) with 6-18 obstacles of one kind
(in turn: crates, bushes, mixed, walls, pillars, light foliage), a start near the west wall
and a goal near the east wall, a `radar_thesis` and a `hokuyo_utm30lx`, and a Bug1 mission
(`radarnav nav-suite` runs both algorithms, both sensors, both poses). Obstacles keep 0.15 m
apart and clear of the start and goal by their size plus 1.5 m. Map i is drawn from seed
BASE + i, so a batch is the same on every machine:

    python3 bench/random_nav_maps.py target/maps-300 12 300
    cargo run --release -p radarnav-cli -- nav-suite target/maps-300 --out target/nav-300

The README's navigation section quotes the batches drawn from seeds 100, 300 and 500.
Standard library only.
"""

import argparse
import math
import os
import random

KINDS = ["crates", "bushes", "mixed", "walls", "pillars", "light"]


def piece(rnd, kind, x, y, w, h):
    """One obstacle of `kind` at (x, y): (footprint centre, footprint radius, material, shape)
    or None when it would leave the room."""
    if kind == "crates":
        sx, sy = rnd.uniform(0.5, 2.0), rnd.uniform(0.5, 2.0)
        shape = (
            f"box = {{ center = [{x:.3f}, {y:.3f}], size = [{sx:.2f}, {sy:.2f}, 1.0], "
            f"yaw_deg = {rnd.uniform(0, 90):.1f} }}"
        )
        return (x, y), math.hypot(sx, sy) / 2, rnd.choice(["wood", "metal", "concrete"]), shape
    if kind in ("bushes", "light"):
        r = rnd.uniform(0.4, 1.1)
        shape = f"sphere = {{ center = [{x:.3f}, {y:.3f}], radius = {r:.3f} }}"
        light = kind == "light" or rnd.random() < 0.3
        return (x, y), r, "foliage_light" if light else "foliage_dense", shape
    if kind == "pillars":
        r = rnd.uniform(0.15, 0.6)
        shape = f"cylinder = {{ center = [{x:.3f}, {y:.3f}], radius = {r:.3f}, height = 2.0 }}"
        return (x, y), r, rnd.choice(["metal", "concrete"]), shape
    # A free-standing wall piece from (x, y).
    length, a = rnd.uniform(1.5, 5.0), rnd.uniform(0, math.pi)
    x2, y2 = x + length * math.cos(a), y + length * math.sin(a)
    if not (0.5 < x2 < w - 0.5 and 0.5 < y2 < h - 0.5):
        return None
    shape = (
        f"wall = {{ points = [[{x:.3f}, {y:.3f}], [{x2:.3f}, {y2:.3f}]], "
        "thickness = 0.2, height = 2.0 }"
    )
    return ((x + x2) / 2, (y + y2) / 2), length / 2, "concrete", shape


def scenario(seed, kind):
    """The TOML text of the map drawn from `seed`."""
    rnd = random.Random(seed)
    w, h = rnd.uniform(14, 20), rnd.uniform(9, 14)
    start = (2.0, h / 2 + rnd.uniform(-1, 1))
    goal = (w - 2.0, h / 2 + rnd.uniform(-1, 1))
    lines = [
        f"# Random navigation trial map ({kind}), seed {seed}: bench/random_nav_maps.py",
        f'description = "random {kind}, seed {seed}"',
        "",
        "[sim]",
        "dt = 0.05",
        "duration = 600.0",
        "seed = 1",
        "",
        "[[object]]",
        'name = "room"',
        'material = "concrete"',
        f"wall = {{ points = [[-0.1, -0.1], [{w + 0.1:.2f}, -0.1], [{w + 0.1:.2f}, {h + 0.1:.2f}], "
        f"[-0.1, {h + 0.1:.2f}], [-0.1, -0.1]], thickness = 0.2, height = 2.5 }}",
        "",
    ]
    placed = []
    count, tries = rnd.randint(6, 18), 0
    while len(placed) < count and tries < 2000:
        tries += 1
        x, y = rnd.uniform(3.5, w - 3.5), rnd.uniform(0.8, h - 0.8)
        k = kind if kind != "mixed" else rnd.choice(["crates", "bushes", "walls", "pillars"])
        p = piece(rnd, k, x, y, w, h)
        if p is None:
            continue
        centre, r, material, shape = p
        if min(math.dist(centre, start), math.dist(centre, goal)) < r + 1.5:
            continue
        if any(math.dist(centre, c) < r + rr + 0.15 for c, rr in placed):
            continue
        placed.append((centre, r))
        lines += ["[[object]]", f'name = "o{len(placed)}"', f'material = "{material}"', shape, ""]
    lines += [
        "[[robot]]",
        'name = "p3at"',
        'vehicle = "p3at"',
        f"start = {{ x = {start[0]:.2f}, y = {start[1]:.2f}, yaw_deg = 0 }}",
        "",
        "[[robot.sensor]]",
        'name = "radar"',
        'preset = "radar_thesis"',
        "mount = { x = 0.0, y = 0.0, z = 0.4 }",
        "",
        "[[robot.sensor]]",
        'name = "laser"',
        'preset = "hokuyo_utm30lx"',
        "mount = { x = 0.1, y = 0.0, z = 0.4 }",
        "",
        "[mission]",
        'type = "bug1"',
        f"goal = [{goal[0]:.2f}, {goal[1]:.2f}]",
        "",
    ]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="directory to write the .toml files to")
    ap.add_argument("count", type=int, help="number of maps (1-1000)")
    ap.add_argument("base", type=int, help="seed of the first map; map i uses base + i")
    args = ap.parse_args()
    if not 1 <= args.count <= 1000:
        ap.error(f"count {args.count} is outside 1-1000")
    os.makedirs(args.out, exist_ok=True)
    for i in range(args.count):
        seed, kind = args.base + i, KINDS[i % len(KINDS)]
        path = os.path.join(args.out, f"r{seed}-{kind}.toml")
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(scenario(seed, kind))
        os.replace(tmp, path)
    print(f"wrote {args.count} maps to {args.out}")


if __name__ == "__main__":
    main()
