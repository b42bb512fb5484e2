#!/usr/bin/env bash
# The built-in adapters' program (`vio run … --estimator openvins-tracks | openvins-images`,
# scenarios/catalog/estimators/): runs OpenVINS on an exported ASL folder and writes what the
# adapter contract asks for into OUT: `estimate.tum` (TUM, the IMU's pose, IMU clock),
# `timing.csv` (`t_ns,seconds` per frame fed) and `covariance.txt` (per pose, the state and its
# covariance in the harness's order, for `vio nees`).
#
#   run_adapter.sh tracks|images DATASET OUT SUITE
#
# tracks: ov_feature_driver on `features.csv` (OpenVINS's TrackSIM: our tracks, its filter);
# images: ov_image_driver on `mav0/cam<i>/data/*.png` (its own KLT front end and filter).
# The Kalibr files are laid out as OpenVINS reads them (OpenCV YAML) and estimator_config.yaml
# is filled in with the export's pixel σ (`vio_pixel_sigma_px` of cam0) and the suite's camera
# count. Build the drivers first: `bash tools/peer/openvins/build.sh` (OV_DRIVER_DIR: where).
set -euo pipefail
[ $# -eq 4 ] || { echo "usage: run_adapter.sh tracks|images DATASET OUT SUITE" >&2; exit 2; }
mode=$1 dataset=$2 out=$3 suite=$4
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
drivers=${OV_DRIVER_DIR:-$root/target/peer/openvins/build-driver}
case "$mode" in
  tracks) driver=$drivers/ov_feature_driver ;;
  images) driver=$drivers/ov_image_driver ;;
  *) echo "run_adapter.sh: mode $mode: expected tracks or images" >&2; exit 2 ;;
esac
[ -x "$driver" ] || { echo "run_adapter.sh: no $driver: run tools/peer/openvins/build.sh first" >&2; exit 2; }
case "$suite" in
  stereo_imu) cameras=2 ;;
  mono_imu) cameras=1 ;;
  *) echo "run_adapter.sh: suite $suite: OpenVINS needs an IMU (stereo_imu, mono_imu)" >&2; exit 2 ;;
esac
# The pixel σ the estimator is told (PIXEL_SIGMA overrides it; compare.sh sets it).
sigma=${PIXEL_SIGMA:-$(sed -n 's/^  vio_pixel_sigma_px: *\([0-9.eE+-]*\).*/\1/p' "$dataset/camchain-imucam.yaml" | head -n1)}
sigma=${sigma:-1}
ov=$out/openvins
mkdir -p "$ov"
# OpenCV's YAML reader wants the %YAML line, block sequences indented under their key, and the
# IMU intrinsics keys Kalibr writes only for its scale-misalignment models (identity here).
indent_sequences() { sed 's/^\( *\)- /\1  - /'; }
{ echo "%YAML:1.0"; indent_sequences <"$dataset/camchain-imucam.yaml"; } >"$ov/kalibr_imucam_chain.yaml"
{
  echo "%YAML:1.0"
  cat "$dataset/imu.yaml"
  for m in Tw R_IMUtoGYRO Ta R_IMUtoACC; do
    printf '  %s:\n  - [1.0, 0.0, 0.0]\n  - [0.0, 1.0, 0.0]\n  - [0.0, 0.0, 1.0]\n' "$m"
  done
  printf '  Tg:\n  - [0.0, 0.0, 0.0]\n  - [0.0, 0.0, 0.0]\n  - [0.0, 0.0, 0.0]\n'
} | indent_sequences >"$ov/kalibr_imu_chain.yaml"
sed -e "s/@PIXEL_SIGMA@/$sigma/" -e "s/@CAMERAS@/$cameras/" "$here/estimator_config.yaml" >"$ov/estimator_config.yaml"
echo "run_adapter.sh: $mode, $cameras camera(s), pixel sigma $sigma px"
exec "$driver" "$ov/estimator_config.yaml" "$dataset" "$out/estimate.tum" "$out/timing.csv" "$out/covariance.txt"
