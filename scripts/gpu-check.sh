#!/usr/bin/env bash
# GPU check for a machine with a real GPU (runs on lavapipe too, slowly): builds the
# release binary, prints the Vulkan adapter, then `g1tess bench --gpu-check` rows for
# device-resident evaluation (no readback), evaluation read back as f32, one frame of the
# device-resident tessellator (GpuTessellator), and the GPU statistics path, each as a fraction of the device's memory bandwidth measured in the same
# run by a device-side buffer copy. At most 5 minutes (a timeout stops it).
#
#   scripts/gpu-check.sh                  # bunny, G1, levels 16 and 32, f32
#   scripts/gpu-check.sh --levels 8       # any `bench` option is passed on (e.g. --json)
#
# The target on a data-centre GPU is device-resident G1 at >= 40 % of the copy bandwidth
# (the `tessellator_frame` rows: GpuTessellator, buffers kept between frames).
set -euo pipefail
cd "$(dirname "$0")/.."

# The Vulkan loader complains without a runtime folder.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/g1tess-xdg-$(id -u)"
  mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
fi

BIN="${G1TESS_BIN:-target/release/g1tess}"
if [ -z "${G1TESS_BIN:-}" ]; then
  echo "== cargo build --release" >&2
  cargo build --release --quiet
fi

LEVELS=(--levels 16,32)
for arg in "$@"; do
  case "$arg" in --levels|--levels=*) LEVELS=() ;; esac
done

echo "== $(date -u +%Y-%m-%dT%H:%M:%SZ) $(uname -srm)" >&2  # stdout is the report (JSON with --json)
exec timeout 300 "$BIN" bench --gpu-check --bandwidth-mib 256 "${LEVELS[@]}" "$@"
