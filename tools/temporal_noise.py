#!/usr/bin/env python3
"""Temporal noise of a camera at rest, as a function of intensity: the curve the renderer's
`[camera.photometric] read_noise` and `electrons_per_level` model (σ² = read² + I / e⁻ per level).

Usage: tools/temporal_noise.py LABEL=GLOB [LABEL=GLOB …]
  e.g. tools/temporal_noise.py real=../shared/data/euroc_v1_01_micro/mav0/cam0/data/*.png \\
                               rendered='/tmp/static/*/cam0.png'

Each GLOB names one camera's frames of a static scene, in time order. Per pixel the frame-to-frame
differences (which remove slow drift) give the variance, `var = E[d²] / 2`, pooled over the
flat pixels (gradient of the mean image under 2 grey levels per pixel, away from edges, where
sub-pixel motion or aliasing would count as noise) of each 16-level intensity bin; differences
beyond ±12 levels (a passing flicker) are left out and counted. Prints σ per bin for every set
and the least-squares fit σ² = a + I / g over the bins from 32 to 216 (saturation excluded).
Needs numpy and Pillow.
"""

import glob
import sys

import numpy as np
from PIL import Image


def curve(pattern):
    files = sorted(glob.glob(pattern))
    if len(files) < 3:
        sys.exit(f"{pattern}: {len(files)} frames, need at least 3")
    a = np.stack([np.asarray(Image.open(f), dtype=np.float64) for f in files])
    mean = a.mean(0)
    gy, gx = np.gradient(mean)
    flat = np.hypot(gx, gy) < 2.0
    d = np.diff(a, axis=0)
    rows = {}
    for lo in range(0, 240, 16):
        k = flat & (mean >= lo) & (mean < lo + 16) & (mean < 235)
        if k.sum() < 300:
            continue
        dk = d[:, k].ravel()
        kept = dk[np.abs(dk) <= 12]
        rows[lo + 8] = (int(k.sum()), float(np.sqrt(0.5 * (kept**2).mean())), float((np.abs(dk) > 12).mean()))
    return len(files), rows


def fit(rows):
    pts = [(i, s) for i, (_, s, _) in rows.items() if 32 <= i <= 216]
    if len(pts) < 2:
        return None
    i = np.array([p[0] for p in pts], dtype=float)
    s = np.array([p[1] for p in pts])
    (a, b), *_ = np.linalg.lstsq(np.vstack([np.ones_like(i), i]).T, s**2, rcond=None)
    return a, b


def main():
    sets = [arg.split("=", 1) for arg in sys.argv[1:]]
    if not sets or any(len(s) != 2 for s in sets):
        sys.exit(__doc__)
    curves = {label: curve(pattern) for label, pattern in sets}
    bins = sorted({i for _, rows in curves.values() for i in rows})
    print("intensity  " + "  ".join(f"{label:>16}" for label, _ in sets))
    for i in bins:
        cells = []
        for label, _ in sets:
            row = curves[label][1].get(i)
            cells.append(f"{row[1]:8.3f} ({row[0]:6d})" if row else f"{'':>16}")
        print(f"{i:9d}  " + "  ".join(cells))
    for label, (n, rows) in curves.items():
        f = fit(rows)
        if f:
            a, b = f
            print(f"{label}: {n} frames; σ² = {a:.3f} + I / {1 / b:.1f}")


if __name__ == "__main__":
    main()
