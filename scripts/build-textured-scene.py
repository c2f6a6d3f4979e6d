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
standard library is used (and scripts/gltfscene.py, shared with the terrain scene).
"""

import math
import os
import random
import sys

from gltfscene import append_model, bounds, new_document, place_model, write_document

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
WHO = "build-textured-scene"


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dest = sys.argv[1], sys.argv[2]
    os.makedirs(dest, exist_ok=True)
    out = new_document("textured-plaza", "hexbake scripts/build-textured-scene.py")
    rng = random.Random(SEED)
    placed = []  # (x, z, radius)
    for folder, name, height, count in MODELS:
        doc, base = append_model(out, src, dest, folder, name, WHO)
        # Normalise: base on y = 0, centred, `height` tall.
        lo, hi = bounds(doc)
        scale = height / (hi[1] - lo[1])
        radius = 0.5 * scale * math.hypot(hi[0] - lo[0], hi[2] - lo[2])
        for k in range(count):
            for _ in range(1000):
                x = rng.uniform(MARGIN, GROUND[0] - MARGIN)
                z = rng.uniform(MARGIN, GROUND[1] - MARGIN)
                if all(math.hypot(x - px, z - pz) > radius + pr + 2.0 for px, pz, pr in placed):
                    break
            placed.append((x, z, radius))
            yaw = rng.uniform(0.0, 2.0 * math.pi)
            # The placement node: T(x, 0, z) · R_y(yaw) · S(scale) · T(-centre).
            place_model(out, doc, base, f"{folder}-{k}", [round(x, 4), 0.0, round(z, 4)], yaw, scale, lo, hi)
    write_document(out, os.path.join(dest, "textured-plaza.gltf"))
    print(f"build-textured-scene: wrote {os.path.join(dest, 'textured-plaza.gltf')} "
          f"({sum(c for *_, c in MODELS)} placements of {len(MODELS)} models)")


if __name__ == "__main__":
    main()
