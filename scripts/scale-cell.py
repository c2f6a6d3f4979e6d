#!/usr/bin/env python3
"""Per-cell figures of a bake for the "Scale" table (issue 27): one cell's pack
bytes and bake CPU, with every far-field group of its chain amortised over the
group's cells, and the player's figures from `player compare --json`.

    scripts/scale-cell.py OUT CELL COMPARE.json
"""
import glob
import json
import sys

out, cell, compare = sys.argv[1], int(sys.argv[2]), sys.argv[3]
cells, groups = {}, {}
for f in glob.glob(f"{out}/jobs/*.json"):
    r = json.load(open(f))
    for c in r.get("cells", []):
        cells[c["cell"]] = c
    for g in r.get("groups", []):
        groups[g["cell"]] = g
c = cells[cell]
rep = c["report"]
row = {
    "cell_bytes": c["bytes"],
    "cell_ms": rep["total_ms"],
    "far_objects": rep["far_objects"],
    "levels": 0,
}
amortised_bytes, amortised_ms = float(c["bytes"]), rep["total_ms"]
g = rep.get("far_group")
per_level = []
while g is not None:
    gr = groups[g]
    n = max(gr["report"]["far_objects"], 1)  # a group's record: its cell count
    amortised_bytes += gr["bytes"] / n
    amortised_ms += gr["report"]["total_ms"] / n
    per_level.append((g, n, gr["bytes"], round(gr["report"]["total_ms"]), gr["report"].get("impostors", 0), gr["report"].get("sv_objects", 0)))
    row["levels"] += 1
    g = gr["report"].get("far_group")
row["amortised_bytes"] = round(amortised_bytes)
row["amortised_ms"] = round(amortised_ms)
cmp = json.load(open(compare))
for k in ("mean_triangles", "mean_draw_calls", "object_psnr_y_db", "mean_psnr_y", "mean_object_ssim"):
    row[k] = round(cmp[k], 3)
row["chain (group, cells, bytes, ms, impostors, sv)"] = per_level
print(json.dumps(row))
