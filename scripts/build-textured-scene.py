#!/usr/bin/env python3
"""Assemble hexbake's textured example scene (issue 18 item 2) as one glTF 2.0 file.

    scripts/build-textured-scene.py SRC DEST

SRC holds the textured models of Debian's assimp-testmodels converted to glTF 2.0 by
the assimp CLI (scripts/build-textured-scene.sh does both steps):

    truck/CesiumMilkTruck.gltf   (+ .bin, CesiumMilkTruck.png)   milk truck, 2 meshes, wheels reused
    duck/duck.gltf               (+ .bin, duckCM.tga)            Collada duck, one texture
    spider/spider.gltf           (+ .bin, *.jpg)                 OBJ spider, five textures
    box/BoxTextured.gltf         (+ .bin, CesiumLogoFlat.png)    glTF sample box

DEST/textured-plaza.gltf places copies of them on a 240 x 200 plaza (seeded, so the
file is byte-identical on every run): each placement is a node with translation,
rotation about y and uniform scale whose children are copies of the model's node
tree; the copies share the model's meshes, so a mesh used by many nodes stays one
model in hexbake. Buffers and images are copied next to the scene (the duck's TGA
is converted to PNG, which glTF requires), with their URIs rewritten. Only Python's
standard library is used.
"""

import json
import math
import os
import random
import shutil
import struct
import sys
import zlib

# (folder, file, target height in scene units, count)
MODELS = [
    ("truck", "CesiumMilkTruck.gltf", 6.0, 10),
    ("duck", "duck.gltf", 4.0, 14),
    ("spider", "spider.gltf", 2.5, 12),
    ("box", "BoxTextured.gltf", 3.0, 14),
]
GROUND = (240.0, 200.0)
MARGIN = 12.0
SEED = 18


def mat_mul(a, b):
    """4x4 column-major product a * b (lists of 16)."""
    out = [0.0] * 16
    for c in range(4):
        for r in range(4):
            out[c * 4 + r] = sum(a[k * 4 + r] * b[c * 4 + k] for k in range(4))
    return out


def node_matrix(node):
    if "matrix" in node:
        return list(node["matrix"])
    t = node.get("translation", [0.0, 0.0, 0.0])
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    s = node.get("scale", [1.0, 1.0, 1.0])
    r = [
        1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
        2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
        2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y),
    ]
    return [
        r[0] * s[0], r[1] * s[0], r[2] * s[0], 0.0,
        r[3] * s[1], r[4] * s[1], r[5] * s[1], 0.0,
        r[6] * s[2], r[7] * s[2], r[8] * s[2], 0.0,
        t[0], t[1], t[2], 1.0,
    ]


def transform(m, p):
    return [m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r] for r in range(3)]


def bounds(doc):
    """World bounds of the default scene from the POSITION accessors' min/max."""
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    identity = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0]
    scene = doc["scenes"][doc.get("scene", 0)]
    stack = [(n, identity) for n in scene["nodes"]]
    while stack:
        n, parent = stack.pop()
        node = doc["nodes"][n]
        world = mat_mul(parent, node_matrix(node))
        if "mesh" in node:
            for prim in doc["meshes"][node["mesh"]]["primitives"]:
                acc = doc["accessors"][prim["attributes"]["POSITION"]]
                a, b = acc["min"], acc["max"]
                for k in range(8):
                    corner = [a[i] if (k >> i) & 1 == 0 else b[i] for i in range(3)]
                    w = transform(world, corner)
                    lo = [min(u, v) for u, v in zip(lo, w)]
                    hi = [max(u, v) for u, v in zip(hi, w)]
        stack.extend((c, world) for c in node.get("children", []))
    return lo, hi


def tga_to_png(src, dst):
    """An uncompressed 24/32-bit TGA as an RGBA PNG (zlib from the standard library)."""
    data = open(src, "rb").read()
    id_len, cmap_type, img_type = data[0], data[1], data[2]
    width, height = struct.unpack("<HH", data[12:16])
    bpp, desc = data[16], data[17]
    if cmap_type != 0 or img_type != 2 or bpp not in (24, 32):
        sys.exit(f"build-textured-scene: {src}: only uncompressed true-colour TGA is read")
    px = data[18 + id_len:]
    step = bpp // 8
    rows = []
    for y in range(height):
        # Origin bottom-left unless bit 5 of the descriptor is set.
        sy = y if desc & 0x20 else height - 1 - y
        row = bytearray([0])
        for x in range(width):
            o = (sy * width + x) * step
            b, g, r = px[o], px[o + 1], px[o + 2]
            row += bytes([r, g, b, 255])
        rows.append(bytes(row))
    raw = b"".join(rows)

    def chunk(kind, body):
        c = kind + body
        return struct.pack(">I", len(body)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    open(dst, "wb").write(png)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dest = sys.argv[1], sys.argv[2]
    os.makedirs(dest, exist_ok=True)
    out = {
        "asset": {"version": "2.0", "generator": "hexbake scripts/build-textured-scene.py"},
        "scene": 0,
        "scenes": [{"name": "textured-plaza", "nodes": []}],
        "nodes": [],
        "meshes": [],
        "materials": [],
        "textures": [],
        "images": [],
        "samplers": [],
        "buffers": [],
        "bufferViews": [],
        "accessors": [],
    }
    rng = random.Random(SEED)
    placed = []  # (x, z, radius)
    for folder, name, height, count in MODELS:
        doc = json.load(open(os.path.join(src, folder, name)))
        base = {k: len(out[k]) for k in out if isinstance(out[k], list)}
        # Buffers and images: copy next to the scene under a per-model prefix.
        for b in doc.get("buffers", []):
            b = dict(b)
            fname = f"{folder}-{os.path.basename(b['uri'])}"
            shutil.copyfile(os.path.join(src, folder, b["uri"]), os.path.join(dest, fname))
            b["uri"] = fname
            out["buffers"].append(b)
        for im in doc.get("images", []):
            im = dict(im)
            uri = im["uri"].replace("\\", "/")
            uri = uri[2:] if uri.startswith("./") else uri
            stem, ext = os.path.splitext(os.path.basename(uri))
            if ext.lower() == ".tga":
                fname = f"{folder}-{stem}.png"
                tga_to_png(os.path.join(src, folder, uri), os.path.join(dest, fname))
            else:
                fname = f"{folder}-{stem}{ext}"
                shutil.copyfile(os.path.join(src, folder, uri), os.path.join(dest, fname))
            im["uri"] = fname
            im.pop("mimeType", None)
            out["images"].append(im)
        for v in doc.get("bufferViews", []):
            v = dict(v, buffer=v["buffer"] + base["buffers"])
            out["bufferViews"].append(v)
        for a in doc.get("accessors", []):
            a = dict(a)
            if "bufferView" in a:
                a["bufferView"] += base["bufferViews"]
            out["accessors"].append(a)
        out["samplers"].extend(doc.get("samplers", []))
        for t in doc.get("textures", []):
            t = dict(t)
            if "source" in t:
                t["source"] += base["images"]
            if "sampler" in t:
                t["sampler"] += base["samplers"]
            out["textures"].append(t)
        for m in doc.get("materials", []):
            m = json.loads(json.dumps(m))
            m.pop("extensions", None)  # assimp's pbrSpecularGlossiness copy
            pbr = m.get("pbrMetallicRoughness", {})
            if "baseColorTexture" in pbr:
                pbr["baseColorTexture"]["index"] += base["textures"]
            for k in ("normalTexture", "occlusionTexture", "emissiveTexture"):
                m.pop(k, None)
            out["materials"].append(m)
        for mesh in doc.get("meshes", []):
            mesh = json.loads(json.dumps(mesh))
            for p in mesh["primitives"]:
                # hexbake recomputes smooth normals; the spider's have zero vectors.
                p["attributes"].pop("NORMAL", None)
                p["attributes"] = {k: v + base["accessors"] for k, v in p["attributes"].items()}
                if "indices" in p:
                    p["indices"] += base["accessors"]
                if "material" in p:
                    p["material"] += base["materials"]
                p.pop("extensions", None)
            out["meshes"].append(mesh)
        # Normalise: base on y = 0, centred, `height` tall.
        lo, hi = bounds(doc)
        scale = height / (hi[1] - lo[1])
        radius = 0.5 * scale * math.hypot(hi[0] - lo[0], hi[2] - lo[2])
        roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
        for k in range(count):
            for _ in range(1000):
                x = rng.uniform(MARGIN, GROUND[0] - MARGIN)
                z = rng.uniform(MARGIN, GROUND[1] - MARGIN)
                if all(math.hypot(x - px, z - pz) > radius + pr + 2.0 for px, pz, pr in placed):
                    break
            placed.append((x, z, radius))
            yaw = rng.uniform(0.0, 2.0 * math.pi)
            # The placement node: T(x, 0, z) · R_y(yaw) · S(scale) · T(-centre).
            inner = len(out["nodes"])
            out["nodes"].append({
                "name": f"{folder}-{k}-normalise",
                "translation": [-(lo[0] + hi[0]) / 2 * scale, -lo[1] * scale, -(lo[2] + hi[2]) / 2 * scale],
                "scale": [scale] * 3,
                "children": [],
            })
            outer = len(out["nodes"])
            out["nodes"].append({
                "name": f"{folder}-{k}",
                "translation": [round(x, 4), 0.0, round(z, 4)],
                "rotation": [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)],
                "children": [inner],
            })
            out["scenes"][0]["nodes"].append(outer)
            # Copy the model's node tree; meshes are shared by index.
            def copy(n):
                node = json.loads(json.dumps(doc["nodes"][n]))
                children = node.pop("children", [])
                for key in ("camera", "skin", "weights", "extensions"):
                    node.pop(key, None)
                if "mesh" in node:
                    node["mesh"] += base["meshes"]
                idx = len(out["nodes"])
                out["nodes"].append(node)
                kids = [copy(c) for c in children]
                if kids:
                    out["nodes"][idx]["children"] = kids
                return idx
            out["nodes"][inner]["children"] = [copy(r) for r in roots]
    out = {k: v for k, v in out.items() if v != []}
    with open(os.path.join(dest, "textured-plaza.gltf"), "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
        f.write("\n")
    print(f"build-textured-scene: wrote {os.path.join(dest, 'textured-plaza.gltf')} "
          f"({sum(c for *_, c in MODELS)} placements of {len(MODELS)} models)")


if __name__ == "__main__":
    main()
