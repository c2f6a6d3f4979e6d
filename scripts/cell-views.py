#!/usr/bin/env python3
"""Writes a camera path of 16 views around one cell's centre (issue 27's per-cell
comparison): eyes on two circles of radius r/2 and r, at three heights between the
cell's eye heights, looking every way (horizontal).

    scripts/cell-views.py X Z RADIUS MIN_EYE MAX_EYE NOTE > manifests/paths/NAME.ron
"""
import math
import sys

cx, cz, radius, lo, hi = (float(a) for a in sys.argv[1:6])
note = sys.argv[6]
heights = [lo + (hi - lo) * f for f in (0.125, 0.5, 0.875)]
rows = []
for k in range(16):
    r = radius / 2 if k % 2 == 0 else radius
    a = 2 * math.pi * k / 16
    d = a + math.pi * 0.75
    rows.append(
        f"        (({cx + r * math.cos(a):.3f}, {heights[k % 3]:.2f}, {cz + r * math.sin(a):.3f}), "
        f"({math.cos(d):.6f}, 0.0, {math.sin(d):.6f})),"
    )
print(f"""// {note}
// 16 views within {radius:g} units of the cell centre ({cx:g}, {cz:g}), written by
// scripts/cell-views.py: the per-cell comparison of issue 27 (`player compare`).
(
    eye_height: {heights[1]:.2f},
    fov_y_deg: 60.0,
    resolution: (512, 512),
    max_speed: 30.0,
    max_turn_deg_per_s: 45.0,
    frame_rate: 5.0,
    views: [
{chr(10).join(rows)}
    ],
)""")
