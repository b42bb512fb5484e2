#!/usr/bin/env bash
# Reproduces the book's table ("Against OpenVINS"): compare.sh over seeds 1-5 of the default
# scenario and of the V2_02 replay, and seeds 1-3 of the three motions in motions/, then prints
# the results as a Markdown table with the better of each pair in bold. ~15 min on 2 cores.
#
#   bash tools/peer/openvins/build.sh && bash tools/peer/openvins/table.sh
#
# Results go to $OUT_ROOT (default target/peer/openvins/runs); results.csv is started afresh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
export OUT_ROOT=${OUT_ROOT:-$root/target/peer/openvins/runs}
mkdir -p "$OUT_ROOT"
rm -f "$OUT_ROOT/results.csv"
for s in 1 2 3 4 5; do bash "$here/compare.sh" room_figure8_stereo_imu "$s"; done
for s in 1 2 3 4 5; do bash "$here/compare.sh" room_replay_v2_02_stereo_imu "$s"; done
for m in fast_lissajous_stereo_imu wide_circle_stereo_imu long_fast_figure8_stereo_imu; do
  for s in 1 2 3; do bash "$here/compare.sh" "$here/motions/$m.toml" "$s"; done
done
python3 - "$OUT_ROOT/results.csv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
bold = lambda text, win: f"**{text}**" if win else text
print("| Scenario | Seed | Common frames | Ours ATE m / ° | OpenVINS ATE m / ° | Ours ms/frame | OpenVINS ms/frame |")
print("|---|---|---|---|---|---|---|")
for r in rows:
    o, v = float(r["ours_ate_m"]), float(r["openvins_ate_m"])
    orot, vrot = float(r["ours_rot_deg"]), float(r["openvins_rot_deg"])
    print(f"| {r['scenario']} | {r['seed']} | {r['common_frames']} | {bold(f'{o:.4f}', o <= v)} / "
          f"{bold(f'{orot:.3f}', orot <= vrot)} | {bold(f'{v:.4f}', v < o)} / {bold(f'{vrot:.3f}', vrot < orot)} | "
          f"{float(r['ours_backend_ms_median']):.1f} | {float(r['openvins_ms_median']):.1f} |")
speed = [float(r["openvins_ms_median"]) / float(r["ours_backend_ms_median"]) for r in rows]
pos = sum(float(r["ours_ate_m"]) <= float(r["openvins_ate_m"]) for r in rows)
rot = sum(float(r["ours_rot_deg"]) <= float(r["openvins_rot_deg"]) for r in rows)
print(f"\nours ahead in position on {pos} of {len(rows)}, in rotation on {rot}; "
      f"back end {min(speed):.1f}-{max(speed):.1f}x faster per frame (median {statistics.median(speed):.1f}x)")
PY
