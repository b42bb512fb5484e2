#!/usr/bin/env bash
# Scores this project's estimator and OpenVINS on identical exported measurements.
#
#   bash tools/peer/openvins/compare.sh SCENARIO SEED [DURATION_S]
#
# 1. `vio export SCENARIO --seed SEED` writes the IMU log, the feature tracks (realistic ids: a
#    track lost and found again is a new id) and the ground truth as an ASL folder, with the rig as
#    Kalibr files;
# 2. `vio euroc` runs our estimator on that folder's tracks, with the scenario's settings;
# 3. `run_adapter.sh tracks` (the built-in adapter `openvins-tracks`; build.sh builds its
#    `ov_feature_driver`) runs OpenVINS on the same tracks and IMU samples, with
#    estimator_config.yaml beside this script (the pixel σ: PIXEL_SIGMA, default 1);
#    its log ($run/openvins.log) ends with its timing and its final camera-IMU time offset;
# 4. `vio eval` scores both against the same ground truth with SE(3) alignment (evo's `-a`) on
#    the frames both produced — or, when OpenVINS's time offset has wandered so far that fewer
#    than 90 % of its poses meet a frame of ours, each on its own poses from OpenVINS's first on
#    against the export's 200 Hz ground truth (the result line and the CSV's `scored_on` say
#    which).
# Prints one line and appends it, as CSV, to $OUT_ROOT/results.csv (header written once).
# Both runs are single-threaded and deterministic: the same command prints the same figures
# (timings aside).
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: compare.sh SCENARIO SEED [DURATION_S]" >&2; exit 2; }
scenario=$1 seed=$2 duration=${3:-}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
work=${OPENVINS_WORK:-$root/target/peer/openvins}
out_root=${OUT_ROOT:-$work/runs}
driver=${OV_DRIVER:-$work/build-driver/ov_feature_driver}
vio=${VIO:-$root/target/release/vio}
sigma=${PIXEL_SIGMA:-1}
[ -x "$driver" ] || { echo "compare.sh: no $driver: run tools/peer/openvins/build.sh first" >&2; exit 2; }
[ -x "$vio" ] || (cd "$root" && cargo build --release --locked -p scenarios --bin vio >&2)

settings=$scenario
[ -f "$settings" ] || settings=$root/scenarios/catalog/$scenario.toml
[ -f "$settings" ] || { echo "compare.sh: no scenario file $scenario or $settings" >&2; exit 2; }
name=$(basename "$settings" .toml)
suite=$(sed -n 's/^suite *= *"\([a-z_]*\)".*/\1/p' "$settings" | head -n1)
case "$suite" in
  stereo_imu | mono_imu) ;;
  *) echo "compare.sh: $name is a $suite scenario; OpenVINS needs an IMU and cameras (stereo_imu, mono_imu)" >&2; exit 2 ;;
esac

run=$out_root/$name-s$seed${duration:+-${duration}s}
rm -rf "$run"
mkdir -p "$run/ov"
dur_args=()
[ -n "$duration" ] && dur_args=(--duration "$duration")

"$vio" export "$settings" --seed "$seed" "${dur_args[@]}" --out "$run/export" >"$run/export.log"

"$vio" euroc "$run/export" --suite "$suite" --features "$run/export/features.csv" --settings "$settings" \
  --pixel-sigma "$sigma" --out "$run/ours" >"$run/ours.log" 2>&1
# OpenVINS on the same tracks, as the built-in adapter `openvins-tracks` runs it.
PIXEL_SIGMA=$sigma OV_DRIVER_DIR=$(dirname "$driver") bash "$here/run_adapter.sh" tracks "$run/export" "$run/ov" "$suite" \
  >"$run/openvins.log" 2>&1 || { tail -n 20 "$run/openvins.log" >&2; exit 1; }
mv "$run/ov/estimate.tum" "$run/openvins.tum"
mv "$run/ov/timing.csv" "$run/openvins_timing.csv"

"$vio" eval --align se3 --gt "$run/ours/groundtruth.tum" --est "$run/ours/estimate.tum" --common-with "$run/openvins.tum" \
  >"$run/eval.txt"
# The first ATE table is ours, the second OpenVINS's, both on the common frames.
read -r ours_ate ov_ate < <(awk '/^ATE trans/ {printf "%s ", $5} END {print ""}' "$run/eval.txt")
read -r ours_rot ov_rot < <(awk '/^ATE rot/ {printf "%s ", $5} END {print ""}' "$run/eval.txt")
common=$(sed -n 's/^common frames: \([0-9]*\) of.*/\1/p' "$run/eval.txt")
# OpenVINS stamps each pose at the frame time plus its estimated time offset: when that offset
# wanders by more than the association window (10 ms), most of its poses match no frame of ours
# and a comparison on common frames would cover only the rest. Then each estimator is scored
# instead against the export's 200 Hz ground truth (association within 3 ms), on its poses from
# OpenVINS's first on, and the result line says so.
scored_on=common_frames
ov_poses=$(sed -n 's/^common frames: .* and \([0-9]*\) (.*/\1/p' "$run/eval.txt")
ov_offset=$(sed -n 's/.*final time offset \(-*[0-9.]*\) ms.*/\1/p' "$run/openvins.log")
if [ -n "$ov_poses" ] && [ "$ov_poses" -gt 0 ] && [ $((10 * common)) -lt $((9 * ov_poses)) ]; then
  echo "compare.sh: only $common of OpenVINS's $ov_poses poses are common (its final time offset ${ov_offset:-?} ms): both scored against the export's 200 Hz ground truth instead" >&2
  # Ours from OpenVINS's first pose on (1 ms early, for the stamp's rounding).
  first=$(awk '!/^#/ && NF {printf "%.9f", $1 - 0.001; exit}' "$run/openvins.tum")
  awk -v t0="$first" '!/^#/ && NF && $1 >= t0' "$run/ours/estimate.tum" >"$run/ours_from_openvins_start.tum"
  gt200=$run/export/mav0/state_groundtruth_estimate0/data.csv
  score() { "$vio" eval --align se3 --gt "$gt200" --est "$1" --t-max-diff 0.003 | awk '/^ATE (trans|rot)/ {printf "%s ", $5}'; }
  read -r ours_ate ours_rot < <(score "$run/ours_from_openvins_start.tum"; echo)
  read -r ov_ate ov_rot < <(score "$run/openvins.tum"; echo)
  scored_on=ground_truth_200hz
fi
ours_ms=$(python3 -c "import json,sys; print('%.3f' % json.load(open(sys.argv[1]))['timing_ms']['backend']['median'])" "$run/ours/report.json")
ov_ms=$(sed -n 's/.*after initialization: median \([0-9.]*\) ms.*/\1/p' "$run/openvins.log")

scoring="$common common frames"
[ "$scored_on" = common_frames ] || scoring="scored against the 200 Hz ground truth ($common common frames)"
printf '%s seed %s: %s; ATE ours %.4f m %.3f deg, OpenVINS %.4f m %.3f deg; per frame ours %s ms, OpenVINS %s ms\n' \
  "$name" "$seed" "$scoring" "$ours_ate" "$ours_rot" "$ov_ate" "$ov_rot" "$ours_ms" "$ov_ms"
csv=$out_root/results.csv
[ -f "$csv" ] || echo "scenario,seed,duration_s,common_frames,ours_ate_m,ours_rot_deg,openvins_ate_m,openvins_rot_deg,ours_backend_ms_median,openvins_ms_median,scored_on" >"$csv"
echo "$name,$seed,${duration:-full},$common,$ours_ate,$ours_rot,$ov_ate,$ov_rot,$ours_ms,$ov_ms,$scored_on" >>"$csv"
