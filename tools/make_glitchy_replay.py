#!/usr/bin/env python3
"""Writes scenarios/catalog/data/euroc_V2_02_medium_20s_glitchy.txt from the clean catalog cut
(euroc_V2_02_medium_20s.txt): the faults a motion-capture log shows in the wild, placed at
fixed, seeded positions so the file is reproducible.

- irregular stamps: each sample kept with probability 0.7 (spacing 10 ms to several tens of ms),
  plus 20 extra samples 30 µs after a kept one (pose interpolated);
- a 0.8 s gap: no samples in [8.0, 8.8) s after the first stamp;
- a 5 mm / 3° glitch on the first sample after the gap;
- a 180° attitude glitch (about the body z axis) on one sample near 12 s;
- a Latin-1 comment line (not UTF-8).

Usage: python3 tools/make_glitchy_replay.py (from the repository root).
"""
import math
import random

SRC = "scenarios/catalog/data/euroc_V2_02_medium_20s.txt"
DST = "scenarios/catalog/data/euroc_V2_02_medium_20s_glitchy.txt"


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def main():
    rows = [list(map(float, l.split())) for l in open(SRC) if l.strip() and not l.startswith("#")]
    t0 = rows[0][0]
    rng = random.Random(13)
    out = []
    for i, r in enumerate(rows):
        rel = r[0] - t0
        if 8.0 <= rel < 8.8:
            continue
        if i not in (0, len(rows) - 1) and rng.random() > 0.7:
            continue
        out.append(list(r))
        if i + 1 < len(rows) and len(out) % 40 == 7 and not 7.9 <= rel < 8.8:
            n = rows[i + 1]
            x = 30e-6 / (n[0] - r[0])
            extra = [r[k] + (n[k] - r[k]) * x for k in range(8)]
            norm = math.sqrt(sum(v * v for v in extra[4:8]))
            extra[4:8] = [v / norm for v in extra[4:8]]
            out.append(extra)
    after_gap = next(k for k, r in enumerate(out) if r[0] - t0 >= 8.8)
    g = out[after_gap]
    g[1] += 0.005
    half = math.radians(3.0) / 2
    g[4:8] = qmul(tuple(g[4:8]), (math.sin(half), 0.0, 0.0, math.cos(half)))
    flip = next(k for k, r in enumerate(out) if r[0] - t0 >= 12.0)
    out[flip][4:8] = qmul(tuple(out[flip][4:8]), (0.0, 0.0, 1.0, 0.0))
    with open(DST, "wb") as f:
        f.write(b"# timestamp(s) tx ty tz qx qy qz qw\n")
        f.write("# Vicon room log, exported by the caf\u00e9 PC\n".encode("latin-1"))
        for r in out:
            f.write(("%.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n" % tuple(r)).encode())
    print(f"{DST}: {len(out)} samples; 5 mm / 3 deg glitch at line {after_gap + 3}, 180 deg glitch at line {flip + 3}")


if __name__ == "__main__":
    main()
