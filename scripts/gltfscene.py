"""Helpers shared by hexbake's example-scene builders (scripts/build-textured-scene.py,
the textured plaza of issue 18, and scripts/build-terrain-scene.py, the terrain of
issue 29): glTF node transforms and bounds, a TGA-to-PNG converter, and merging the
assimp-converted models into one glTF document. Only Python's standard library.
"""

import json
import math
import os
import shutil
import struct
import sys
import zlib


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


def tga_to_png(src, dst, who):
    """An uncompressed 24/32-bit TGA as an RGBA PNG (zlib from the standard library)."""
    data = open(src, "rb").read()
    id_len, cmap_type, img_type = data[0], data[1], data[2]
    width, height = struct.unpack("<HH", data[12:16])
    bpp, desc = data[16], data[17]
    if cmap_type != 0 or img_type != 2 or bpp not in (24, 32):
        sys.exit(f"{who}: {src}: only uncompressed true-colour TGA is read")
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


def new_document(name, generator):
    """An empty glTF 2.0 document with one scene, `name`."""
    return {
        "asset": {"version": "2.0", "generator": generator},
        "scene": 0,
        "scenes": [{"name": name, "nodes": []}],
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


def append_model(out, src, dest, folder, name, who):
    """Appends the model SRC/FOLDER/NAME (a glTF 2.0 file of the assimp CLI) to `out`:
    buffers and images copied next to the scene in DEST under a per-model prefix (a
    TGA converted to PNG, which glTF requires), indices shifted. Returns the model's
    document and `base`, the lengths of `out`'s arrays before it (for
    [`place_model`])."""
    doc = json.load(open(os.path.join(src, folder, name)))
    base = {k: len(out[k]) for k in out if isinstance(out[k], list)}
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
            tga_to_png(os.path.join(src, folder, uri), os.path.join(dest, fname), who)
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
    return doc, base


def place_model(out, doc, base, label, translation, yaw, scale, lo, hi):
    """Places a copy of model `doc` (appended with `base`) at `translation`: a node
    `label` with translation and rotation `yaw` about y, over a node that scales
    uniformly by `scale` and puts the model's bounds `lo`..`hi` centred in x and z
    with their base on y = 0; its children are copies of the model's node tree,
    which share the model's meshes (one model in hexbake)."""
    inner = len(out["nodes"])
    out["nodes"].append({
        "name": f"{label}-normalise",
        "translation": [-(lo[0] + hi[0]) / 2 * scale, -lo[1] * scale, -(lo[2] + hi[2]) / 2 * scale],
        "scale": [scale] * 3,
        "children": [],
    })
    outer = len(out["nodes"])
    out["nodes"].append({
        "name": label,
        "translation": translation,
        "rotation": [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)],
        "children": [inner],
    })
    out["scenes"][0]["nodes"].append(outer)

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

    roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
    out["nodes"][inner]["children"] = [copy(r) for r in roots]


def write_document(out, path):
    """Writes `out` (empty arrays left out) as indented, key-sorted JSON."""
    out = {k: v for k, v in out.items() if v != []}
    with open(path, "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
        f.write("\n")
