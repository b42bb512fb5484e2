#!/usr/bin/env python3
"""Builds scenarios/catalog/data/euroc_V1_01_easy_excerpt/ from the real EuRoC V1_01 excerpt.

Usage: python3 tools/make_euroc_real_excerpt.py SRC_MAV0 OUT_DIR [PAIRS]

SRC_MAV0 is an ASL `mav0` folder of EuRoC V1_01_easy holding the first stereo pairs, the whole
IMU log and the ground truth (the team's copy: ../shared/data/euroc_v1_01_micro/mav0). The first
PAIRS stereo pairs (default 20) are re-encoded as optimized PNG (lossless: the pixels are
unchanged, only the deflate settings differ); `data.csv` files keep those rows; the IMU log, the
ground truth, `body.yaml` and every `sensor.yaml` are copied byte for byte. Needs Pillow.
"""
import shutil
import sys
from pathlib import Path

from PIL import Image


def main() -> None:
    src = Path(sys.argv[1])
    out = Path(sys.argv[2]) / "mav0"
    pairs = int(sys.argv[3]) if len(sys.argv) > 3 else 20
    if out.exists():
        shutil.rmtree(out)
    for cam in ("cam0", "cam1"):
        (out / cam / "data").mkdir(parents=True)
        shutil.copyfile(src / cam / "sensor.yaml", out / cam / "sensor.yaml")
        lines = (src / cam / "data.csv").read_bytes().splitlines(keepends=True)
        header, rows = lines[0], lines[1 : 1 + pairs]
        (out / cam / "data.csv").write_bytes(header + b"".join(rows))
        for row in rows:
            name = row.decode().strip().split(",")[1]
            image = Image.open(src / cam / "data" / name)
            image.load()
            image.save(out / cam / "data" / name, "PNG", optimize=True)
            assert Image.open(out / cam / "data" / name).tobytes() == image.tobytes()
    for folder in ("imu0", "state_groundtruth_estimate0"):
        shutil.copytree(src / folder, out / folder)
    shutil.copyfile(src / "body.yaml", out / "body.yaml")


if __name__ == "__main__":
    main()
