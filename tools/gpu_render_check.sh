#!/bin/bash
# The rendered pipeline on a machine with a GPU (book: Benchmarks → On a GPU).
#
#   bash tools/gpu_render_check.sh [VIO [BASELINE_VIO]]
#
# Runs `vio run room_figure8_rendered_stereo_imu` (60 s) with the GL backend (EGL) and with
# Vulkan, on all cores and pinned to two (`taskset -c 0,1`), prints each run's wall time and
# rendering line, and checks determinism: every run of one backend must give the same
# `estimate.tum` bytes, whatever the core count. With BASELINE_VIO (another build) each run is
# repeated with it, alternating, and its estimates must match too. Needs an EGL and a Vulkan
# loader and the vendor's driver (on NVIDIA: libegl1 libvulkan1, and where the driver's
# manifests are not found, VK_DRIVER_FILES and __EGL_VENDOR_LIBRARY_FILENAMES pointing at them).
# Writes under ${OUT_ROOT:-/tmp/vio-gpu-check}; exit 1 when a run fails or bytes differ.
set -u
VIO=${1:-target/release/vio}
BASE=${2:-}
ROOT=${OUT_ROOT:-/tmp/vio-gpu-check}
mkdir -p "$ROOT"
SCENARIO=scenarios/catalog/room_figure8_rendered_stereo_imu.toml
cp "$SCENARIO" "$ROOT/fig8_gl.toml"
sed 's/^\[camera.render\]$/[camera.render]\nbackend = "vulkan"/' "$SCENARIO" > "$ROOT/fig8_vulkan.toml"
status=0
run() { # build label, binary, backend, cores ("all" or "2")
  local label=$1 bin=$2 backend=$3 cores=$4 out="$ROOT/$1_$3_$4"
  local pin=()
  [ "$cores" = 2 ] && pin=(taskset -c 0,1)
  local t0 t1
  t0=$(date +%s.%N)
  if ! "${pin[@]}" "$bin" run "$ROOT/fig8_$backend.toml" --out "$out" > "$out.log" 2>&1; then
    echo "$label $backend $cores cores: FAILED (see $out.log)"; status=1; return
  fi
  t1=$(date +%s.%N)
  printf '%-8s %-7s %3s cores  %6.2f s  %s\n' "$label" "$backend" "$cores" \
    "$(awk "BEGIN{print $t1 - $t0}")" "$(grep '^rendering' "$out.log" | sed 's/.*max: //')"
  local first="$ROOT/first_$backend.tum"
  if [ ! -f "$first" ]; then cp "$out/estimate.tum" "$first"
  elif ! cmp -s "$first" "$out/estimate.tum"; then
    echo "  estimate.tum differs from the first $backend run"; status=1
  fi
}
rm -f "$ROOT"/first_*.tum
nvidia-smi -L 2>/dev/null; echo "$(nproc) cores"
for cores in all 2; do
  for backend in vulkan gl; do
    [ -n "$BASE" ] && run baseline "$BASE" $backend $cores
    run build "$VIO" $backend $cores
  done
done
[ $status = 0 ] && echo "every backend deterministic across runs and core counts"
exit $status
