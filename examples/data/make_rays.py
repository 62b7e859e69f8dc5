#!/usr/bin/env python3
"""Writes rays.csv: 313 deterministic rays for `analytic-fog eval`, typical and extreme.

Run from this directory: python3 make_rays.py  (the output is committed; this script
only documents how it was made).
"""
import math

rows = []


def add(o, d, t):
    f = lambda v: "inf" if v == math.inf else ("%.7g" % v)
    rows.append(",".join(f(x) for x in (*o, *d, t)))


# 1. Typical: a camera 2 units above the base height, a grid of directions (elevation
#    -40..40 degrees, 12 azimuths), segments of 10 to 5000 that stop at the ground y = 0.
cam = (0.0, 2.0, 0.0)
for ie, el in enumerate(range(-40, 41, 5)):
    for ia in range(12):
        az = math.radians(30 * ia + 7)
        e = math.radians(el)
        d = (math.cos(e) * math.cos(az), math.sin(e), math.cos(e) * math.sin(az))
        t = [10, 50, 200, 1000, 5000][(ie + ia) % 5]
        if el < 0:
            t = min(t, 2.0 / -d[1])
        add(cam, d, t)
# 2. Sky rays to infinity, and rays looking down or horizontally to infinity (tau = inf).
for el in [90, 60, 30, 10, 3, 1, 0.1]:
    for az in [0, 120, 240]:
        e, a = math.radians(el), math.radians(az)
        add(cam, (math.cos(e) * math.cos(a), math.sin(e), math.cos(e) * math.sin(a)), math.inf)
for dy in [0.0, -1e-30, -1e-7, -0.01, -0.5, -1.0]:
    add(cam, (1.0, dy, 0.0), math.inf)
# 3. Near-horizontal rays, finite and infinite.
for dy in [1e-38, -1e-38, 1e-30, -1e-30, 1e-12, -1e-12, 1e-7, -1e-7, 1e-4, -1e-4]:
    for t in [100.0, 1e6, 1e12, math.inf]:
        add(cam, (0.6, dy, 0.8), t)
# 4. Far cameras: high above, far below, and far away horizontally.
for oy, dy, t in [(1e4, -1.0, 1e4), (1e4, -1.0, 9999.0), (1e4, -0.3, math.inf),
                  (1e4, 1.0, math.inf), (1e4, 0.0, 1e6), (-1e3, 1.0, 1e3),
                  (-1e3, 1.0, math.inf), (-1e3, -1.0, 10.0), (-1e3, 0.0, 100.0),
                  (-1e3, 0.01, 1e5), (1e3, -0.001, 1e6), (500.0, -0.2, 2500.0),
                  (200.0, -1.0, 200.0)]:
    add((0.0, oy, 0.0), (0.0, dy, 1.0) if dy not in (1.0, -1.0) else (0.0, dy, 0.0), t)
for ox in [1e6, -1e7, 3e8]:
    add((ox, 5.0, ox), (0.0, 0.1, 1.0), 1e3)
    add((ox, 5.0, ox), (1.0, -0.05, 0.0), 100.0)
# 5. Degenerate and extreme lengths: t = 0, tiny, huge; non-unit, tiny and huge
#    directions (same segments, so the same results); a zero direction.
for t in [0.0, 1e-6, 1e12, 3e38]:
    add(cam, (0.0, 0.3, 1.0), t)
    add(cam, (0.0, -0.3, 1.0), min(t, 6.6))
for s in [1e-20, 1e-6, 2.0, 1e6, 1e20]:
    add(cam, (0.0, 0.2 * s, s), 100.0 / s)
    add(cam, (s, -0.1 * s, 0.0), 10.0 / s)
add(cam, (0.0, 0.0, 0.0), 100.0)
# 6. Toward and away from the sun of valley.json, (0.3, 0.4, -0.87).
for sgn in [1, -1]:
    add(cam, (0.3 * sgn, 0.4 * sgn, -0.87 * sgn), 500.0 if sgn > 0 else 5.0)
    add(cam, (0.3 * sgn, 0.4 * sgn, -0.87 * sgn), math.inf if sgn > 0 else 4.99)

with open("rays.csv", "w") as f:
    f.write("ox,oy,oz,dx,dy,dz,t\n")
    f.write("\n".join(rows) + "\n")
