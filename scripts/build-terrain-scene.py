#!/usr/bin/env python3
"""Assemble hexbake's second textured example (issue 29 item 5) as one glTF 2.0 file:
a textured terrain, an L-shaped building block that spans more than ten cells, and
textured models standing on the terrain.

    scripts/build-terrain-scene.py SRC DEST       the scene: DEST/terrain.gltf
    scripts/build-terrain-scene.py --walk FILE    the walk: manifests/paths/terrain-walk.ron

SRC holds what scripts/build-terrain-scene.sh prepares from Debian's packages:
the four models of the textured plaza converted by scripts/convert-textured-models.sh
(truck/, duck/, spider/, box/), textures/CWALL02.jpg (assimp-testmodels' concrete
wall) and textures/terrain-grasslight-512.jpg (glmark2-data's grass).

The scene (seeded and computed, so the file is byte-identical on every run):

- **terrain**: one mesh, a heightfield over the whole 300 x 240 ground ([`height`],
  between about 0.25 and 2.55), 2.5-unit quads, the grass texture repeated every
  8 units. Its first node. hexbake splits it into one chunk per cell.
- **building**: one mesh, an L of two 12-unit deep arms (x 40..266 at z 173, and
  x 260 from z 67 to 179), 5-unit bays with pilasters, its walls' feet following
  the terrain 0.8 below it, a flat roof 11 above the arm's highest ground; the
  concrete wall texture. It spans more than ten cells of manifests/terrain.ron's
  30-unit grid.
- **objects**: copies of the milk truck, duck, spider and box, each on the terrain
  (its base at the lowest terrain height under its footprint), away from the
  building, the walk and each other.

`--walk FILE` writes the camera path: views (eye, direction) along [WALK] sampled
as format::path samples a walk (turn in place at 45 deg/s, then walk at 12 units/s,
5 frames a second), the eye [EYE_ABOVE_GROUND] above the terrain under it, so the
eye follows the ground. Only Python's standard library is used (and
scripts/gltfscene.py, shared with the plaza).
"""

import math
import os
import random
import shutil
import struct
import sys

from gltfscene import append_model, bounds, new_document, place_model, write_document

WHO = "build-terrain-scene"
GROUND = (300.0, 240.0)
TERRAIN_STEP = 2.5
GRASS_PERIOD = 8.0
# The building: arms as (axis, fixed coordinate, from, to) of their centre lines.
DEPTH = 12.0
BAY = 5.0
ARMS = [("x", 173.0, 25.0, 266.0), ("z", 260.0, 45.0, 179.0)]
STOREYS_ABOVE_GROUND = 11.0
WALL_TEXTURE_SIZE = (8.0, 8.0 * 446.0 / 800.0)  # CWALL02.jpg is 800 x 446
# (folder, file, target height in scene units, count)
MODELS = [
    ("truck", "CesiumMilkTruck.gltf", 6.0, 8),
    ("duck", "duck.gltf", 4.0, 10),
    ("spider", "spider.gltf", 2.5, 10),
    ("box", "BoxTextured.gltf", 3.0, 10),
]
MARGIN = 15.0
SEED = 29
# The walk: waypoints on the ground, the eye this far above the terrain.
WALK = [(20.0, 30.0), (120.0, 110.0), (232.0, 100.0), (236.0, 30.0), (284.0, 45.0),
        (284.0, 205.0), (150.0, 214.0)]
EYE_ABOVE_GROUND = 2.2
WALK_SPEED = 12.0
WALK_TURN_DEG_PER_S = 45.0
WALK_FRAME_RATE = 5.0


def height(x, z):
    """The terrain's height at (x, z): rolling hills and a ripple."""
    return (1.4 + 0.95 * math.sin(x / 23.0 + 0.7) * math.cos(z / 19.0 - 0.3)
            + 0.2 * math.sin(x / 6.1 + z / 8.3))


def terrain_height(x, z):
    """The height of the terrain *mesh* at (x, z): the heights of its quad's corners
    interpolated on the quad's triangle (the mesh is what is drawn)."""
    nx, nz = terrain_quads()
    fi = min(max(x / TERRAIN_STEP, 0.0), nx - 1e-6)
    fj = min(max(z / TERRAIN_STEP, 0.0), nz - 1e-6)
    i, j = int(fi), int(fj)
    u, v = fi - i, fj - j
    h = lambda a, b: height(a * TERRAIN_STEP, b * TERRAIN_STEP)
    # Triangles (a, c, b) and (b, c, d) of quad a = (i, j), b = (i+1, j), c = (i, j+1).
    if u + v <= 1.0:
        return h(i, j) + u * (h(i + 1, j) - h(i, j)) + v * (h(i, j + 1) - h(i, j))
    return (h(i + 1, j + 1) + (1.0 - u) * (h(i, j + 1) - h(i + 1, j + 1))
            + (1.0 - v) * (h(i + 1, j) - h(i + 1, j + 1)))


def terrain_quads():
    return round(GROUND[0] / TERRAIN_STEP), round(GROUND[1] / TERRAIN_STEP)


class MeshWriter:
    """Triangle meshes with POSITION and TEXCOORD_0 into one binary buffer."""

    def __init__(self, out, uri):
        self.out, self.uri, self.data = out, uri, bytearray()
        self.buffer = len(out["buffers"])
        out["buffers"].append({"uri": uri, "byteLength": 0})

    def _view(self, payload, target):
        while len(self.data) % 4:
            self.data.append(0)
        view = len(self.out["bufferViews"])
        self.out["bufferViews"].append({"buffer": self.buffer, "byteOffset": len(self.data),
                                        "byteLength": len(payload), "target": target})
        self.data += payload
        return view

    def _accessor(self, view, component, count, kind, lo=None, hi=None):
        acc = {"bufferView": view, "componentType": component, "count": count, "type": kind}
        if lo is not None:
            acc["min"], acc["max"] = lo, hi
        self.out["accessors"].append(acc)
        return len(self.out["accessors"]) - 1

    def mesh(self, name, positions, uvs, triangles, material):
        f32 = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]
        positions = [[f32(c) for c in p] for p in positions]
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        pos = self._accessor(self._view(b"".join(struct.pack("<3f", *p) for p in positions), 34962),
                             5126, len(positions), "VEC3", lo, hi)
        uv = self._accessor(self._view(b"".join(struct.pack("<2f", *t) for t in uvs), 34962),
                            5126, len(uvs), "VEC2")
        idx = self._accessor(self._view(b"".join(struct.pack("<3I", *t) for t in triangles), 34963),
                             5125, 3 * len(triangles), "SCALAR")
        self.out["meshes"].append({"name": name, "primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx,
            "material": material, "mode": 4}]})
        return len(self.out["meshes"]) - 1

    def finish(self, dest):
        self.out["buffers"][self.buffer]["byteLength"] = len(self.data)
        open(os.path.join(dest, self.uri), "wb").write(self.data)


def textured_material(out, dest, src_image, name):
    """A material whose base colour is `src_image` copied into DEST, repeated."""
    fname = os.path.basename(src_image)
    shutil.copyfile(src_image, os.path.join(dest, fname))
    out["images"].append({"uri": fname})
    out["samplers"].append({"wrapS": 10497, "wrapT": 10497})
    out["textures"].append({"source": len(out["images"]) - 1, "sampler": len(out["samplers"]) - 1})
    out["materials"].append({"name": name, "pbrMetallicRoughness": {
        "baseColorTexture": {"index": len(out["textures"]) - 1},
        "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    return len(out["materials"]) - 1


def terrain_mesh():
    nx, nz = terrain_quads()
    positions, uvs, triangles = [], [], []
    for j in range(nz + 1):
        for i in range(nx + 1):
            x, z = i * TERRAIN_STEP, j * TERRAIN_STEP
            positions.append([x, height(x, z), z])
            uvs.append([x / GRASS_PERIOD, z / GRASS_PERIOD])
    for j in range(nz):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c = a + 1, a + nx + 1
            # Counter-clockwise seen from above (normal +y).
            triangles += [[a, c, b], [b, c, c + 1]]
    return positions, uvs, triangles


def building_mesh():
    """The L of [ARMS]: each arm a block of 5-unit bays, pilasters every other bay."""
    positions, uvs, triangles = [], [], []
    tw, th = WALL_TEXTURE_SIZE

    def quad(corners, quad_uvs, outward):
        """A quad facing `outward`: wound counter-clockwise seen from that side."""
        p, q, r = corners[0], corners[1], corners[2]
        e1 = [q[i] - p[i] for i in range(3)]
        e2 = [r[i] - p[i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        if sum(a * b for a, b in zip(n, outward)) < 0.0:
            corners, quad_uvs = corners[::-1], quad_uvs[::-1]
        k = len(positions)
        positions.extend(corners)
        uvs.extend(quad_uvs)
        triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]])

    for axis, fixed, s0, s1 in ARMS:
        # World point and direction of (along, across, y): `along` on the arm's axis.
        world = (lambda s, t, y: [s, y, fixed + t]) if axis == "x" else (lambda s, t, y: [fixed + t, y, s])
        vec = (lambda s, t: [s, 0.0, t]) if axis == "x" else (lambda s, t: [t, 0.0, s])
        ground = lambda s, t: terrain_height(*((s, fixed + t) if axis == "x" else (fixed + t, s)))
        half = DEPTH / 2.0
        bays = max(1, round((s1 - s0) / BAY))
        stops = [s0 + (s1 - s0) * k / bays for k in range(bays + 1)]
        samples = [ground(s, t) for s in stops for t in (-half - 1.0, 0.0, half + 1.0)]
        roof = max(samples) + STOREYS_ABOVE_GROUND
        foot = lambda s, t: min(ground(s, t + d) for d in (-1.0, 0.0, 1.0)) - 0.8

        def wall(a, b, t, bottom_a, bottom_b, top, outward):
            """The wall from `a` to `b` along the arm at `t` across it."""
            quad([world(a, t, bottom_a), world(b, t, bottom_b), world(b, t, top), world(a, t, top)],
                 [[a / tw, (top - bottom_a) / th], [b / tw, (top - bottom_b) / th], [b / tw, 0.0], [a / tw, 0.0]],
                 outward)

        def end(s, t0, t1, bottom0, bottom1, top, outward):
            """The wall across the arm at `s` from `t0` to `t1`."""
            quad([world(s, t0, bottom0), world(s, t1, bottom1), world(s, t1, top), world(s, t0, top)],
                 [[t0 / tw, (top - bottom0) / th], [t1 / tw, (top - bottom1) / th], [t1 / tw, 0.0], [t0 / tw, 0.0]],
                 outward)

        def lid(a, b, t0, t1, y):
            quad([world(a, t0, y), world(b, t0, y), world(b, t1, y), world(a, t1, y)],
                 [[a / tw, t0 / tw], [b / tw, t0 / tw], [b / tw, t1 / tw], [a / tw, t1 / tw]], [0.0, 1.0, 0.0])

        for k in range(bays):
            a, b = stops[k], stops[k + 1]
            for t, sign in ((half, 1.0), (-half, -1.0)):
                wall(a, b, t, foot(a, t), foot(b, t), roof, vec(0.0, sign))
            lid(a, b, -half, half, roof)
        end(s0, -half, half, foot(s0, -half), foot(s0, half), roof, vec(-1.0, 0.0))
        end(s1, -half, half, foot(s1, -half), foot(s1, half), roof, vec(1.0, 0.0))
        # Pilasters: 1 wide, 0.6 proud of each long wall, every other bay stop.
        for k in range(0, bays + 1, 2):
            s = stops[k]
            lo_s, hi_s = s - 0.5, s + 0.5
            top = roof + 0.4
            for t, sign in ((half, 1.0), (-half, -1.0)):
                out_t = t + sign * 0.6
                f = foot(s, out_t)
                wall(lo_s, hi_s, out_t, f, f, top, vec(0.0, sign))
                end(lo_s, t, out_t, f, f, top, vec(-1.0, 0.0))
                end(hi_s, t, out_t, f, f, top, vec(1.0, 0.0))
                lid(lo_s, hi_s, min(t, out_t), max(t, out_t), top)
    return positions, uvs, triangles


def building_footprints(margin):
    """The arms' footprints grown by `margin`, as (x0, z0, x1, z1)."""
    out = []
    for axis, fixed, s0, s1 in ARMS:
        h = DEPTH / 2.0 + 0.6 + margin
        if axis == "x":
            out.append((s0 - margin, fixed - h, s1 + margin, fixed + h))
        else:
            out.append((fixed - h, s0 - margin, fixed + h, s1 + margin))
    return out


def distance_to_walk(x, z):
    best = math.inf
    for (ax, az), (bx, bz) in zip(WALK, WALK[1:]):
        dx, dz = bx - ax, bz - az
        t = max(0.0, min(1.0, ((x - ax) * dx + (z - az) * dz) / (dx * dx + dz * dz)))
        best = min(best, math.hypot(x - ax - t * dx, z - az - t * dz))
    return best


def walk_views():
    """The walk's frames as format::path samples waypoints: at each waypoint a turn
    in place towards the next segment, then the segment walked looking along it."""
    pieces = []  # (duration, kind, data)
    heading = None
    for (ax, az), (bx, bz) in zip(WALK, WALK[1:]):
        target = math.atan2(bz - az, bx - ax)
        if heading is not None:
            delta = target - heading
            while delta > math.pi:
                delta -= 2 * math.pi
            while delta < -math.pi:
                delta += 2 * math.pi
            if abs(delta) > 1e-6:
                pieces.append((abs(delta) / math.radians(WALK_TURN_DEG_PER_S), "turn", (ax, az, heading, heading + delta)))
        pieces.append((math.hypot(bx - ax, bz - az) / WALK_SPEED, "walk", (ax, az, bx, bz, target)))
        heading = target
    total = sum(p[0] for p in pieces)
    views = []
    frames = int(math.floor(total * WALK_FRAME_RATE + 1e-9)) + 1
    for f in range(frames):
        t = f / WALK_FRAME_RATE
        for duration, kind, data in pieces:
            if t <= duration or (duration, kind, data) == pieces[-1]:
                u = min(t / duration, 1.0) if duration > 0 else 1.0
                if kind == "turn":
                    x, z, h0, h1 = data
                    h = h0 + u * (h1 - h0)
                else:
                    ax, az, bx, bz, h = data
                    x, z = ax + u * (bx - ax), az + u * (bz - az)
                break
            t -= duration
        y = terrain_height(x, z) + EYE_ABOVE_GROUND
        views.append(((x, y, z), (math.cos(h), 0.0, math.sin(h))))
    return views


def write_walk(path):
    views = walk_views()
    ys = [v[0][1] for v in views]
    lines = [
        "// A walk across manifests/terrain.ron's terrain (issue 29 item 5), written by",
        "//   scripts/build-terrain-scene.py --walk manifests/paths/terrain-walk.ron",
        f"// {len(WALK)} waypoints walked at {WALK_SPEED:g} units/s, turns at {WALK_TURN_DEG_PER_S:g} deg/s, "
        f"{WALK_FRAME_RATE:g} frames/s,",
        f"// given as views: the eye {EYE_ABOVE_GROUND:g} above the terrain mesh under it "
        f"(y {min(ys):.2f} to {max(ys):.2f}), looking along the walk.",
        "// Waypoints: " + ", ".join(f"({x:g}, {z:g})" for x, z in WALK),
        "(",
        "    eye_height: %g," % EYE_ABOVE_GROUND,
        "    fov_y_deg: 60.0,",
        "    resolution: (256, 256),",
        f"    max_speed: {WALK_SPEED:.1f},",
        f"    max_turn_deg_per_s: {WALK_TURN_DEG_PER_S:.1f},",
        f"    frame_rate: {WALK_FRAME_RATE:.1f},",
        "    views: [",
    ]
    for (x, y, z), (dx, dy, dz) in views:
        lines.append(f"        (({x:.4f}, {y:.4f}, {z:.4f}), ({dx:.6f}, {dy:.1f}, {dz:.6f})),")
    lines += ["    ],", ")", ""]
    open(path, "w").write("\n".join(lines))
    print(f"{WHO}: wrote {path} ({len(views)} views)")


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--walk":
        write_walk(sys.argv[2])
        return
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dest = sys.argv[1], sys.argv[2]
    os.makedirs(dest, exist_ok=True)
    out = new_document("terrain", "hexbake scripts/build-terrain-scene.py")
    writer = MeshWriter(out, "terrain-scene.bin")
    grass = textured_material(out, dest, os.path.join(src, "textures", "terrain-grasslight-512.jpg"), "grass")
    wall = textured_material(out, dest, os.path.join(src, "textures", "CWALL02.jpg"), "concrete")
    for name, (positions, uvs, triangles), material in (
        ("terrain", terrain_mesh(), grass),
        ("building", building_mesh(), wall),
    ):
        mesh = writer.mesh(name, positions, uvs, triangles, material)
        out["nodes"].append({"name": name, "mesh": mesh})
        out["scenes"][0]["nodes"].append(len(out["nodes"]) - 1)
    writer.finish(dest)

    rng = random.Random(SEED)
    keep_out = building_footprints(3.0)
    placed = []  # (x, z, radius)
    for folder, name, height_units, count in MODELS:
        doc, base = append_model(out, src, dest, folder, name, WHO)
        lo, hi = bounds(doc)
        scale = height_units / (hi[1] - lo[1])
        radius = 0.5 * scale * math.hypot(hi[0] - lo[0], hi[2] - lo[2])
        for k in range(count):
            for _ in range(10000):
                x = rng.uniform(MARGIN, GROUND[0] - MARGIN)
                z = rng.uniform(MARGIN, GROUND[1] - MARGIN)
                if (all(math.hypot(x - px, z - pz) > radius + pr + 2.0 for px, pz, pr in placed)
                        and distance_to_walk(x, z) > radius + 3.0
                        and not any(x0 - radius < x < x1 + radius and z0 - radius < z < z1 + radius
                                    for x0, z0, x1, z1 in keep_out)):
                    break
            else:
                sys.exit(f"{WHO}: no room for {folder} {k}")
            placed.append((x, z, radius))
            yaw = rng.uniform(0.0, 2.0 * math.pi)
            # On the terrain: the lowest height under the footprint, so no part floats.
            y = min(terrain_height(x + radius * dx, z + radius * dz)
                    for dx, dz in ((0, 0), (1, 0), (-1, 0), (0, 1), (0, -1), (0.7, 0.7),
                                   (-0.7, 0.7), (0.7, -0.7), (-0.7, -0.7)))
            place_model(out, doc, base, f"{folder}-{k}", [round(x, 4), round(y, 4), round(z, 4)],
                        yaw, scale, lo, hi)
    write_document(out, os.path.join(dest, "terrain.gltf"))
    print(f"{WHO}: wrote {os.path.join(dest, 'terrain.gltf')} (terrain, building, "
          f"{sum(c for *_, c in MODELS)} placements of {len(MODELS)} models)")


if __name__ == "__main__":
    main()
