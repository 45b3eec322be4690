#!/usr/bin/env bash
# Runs the whole g1tess test suite. Installs what the tests need when it is missing:
# Mesa's lavapipe Vulkan driver (GPU tests run on it when no other Vulkan device exists).
# The Python tests (scripts/python_test.sh) install theirs into a cached virtual environment.
# With CI=true a missing GPU adapter fails the GPU tests instead of skipping them.
# After the cargo tests, scripts/check-targets.sh checks that the library compiles for macOS
# and Windows (their standard libraries installed with rustup when missing) and without the
# GPU path. Last, scripts/test-browser.sh tests the WebGPU viewer (web/) in headless Chromium
# (installing Debian's chromium and npm's playwright-core when missing).
set -euo pipefail
cd "$(dirname "$0")/.."

need_vulkan() {
  # ldconfig is in /sbin, which a user's PATH may lack.
  ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 ||
    ! PATH="$PATH:/sbin:/usr/sbin" ldconfig -p | grep -q libvulkan.so.1
}
if need_vulkan; then
  echo "== installing mesa-vulkan-drivers (lavapipe) and libvulkan1"
  if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
fi

# Vulkan loaders warn without a runtime dir.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/g1tess-xdg-$(id -u)"
  mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
fi

# The Python environments of the Blender and Python tests are downloads (network, not
# CPU): set them up in the background while cargo builds and tests.
mkdir -p .cache
scripts/blender_test.sh --setup-only >.cache/blender-setup.log 2>&1 &
blender_setup=$!
scripts/python_test.sh --setup-only >.cache/python-setup.log 2>&1 &
python_setup=$!
# The browser tests' tools too: Chromium and playwright-core are downloads, wasm-bindgen-cli
# a compile of a few minutes (niced below the tests, which leave cores idle at times).
(
  if [ ! -x /usr/bin/chromium ]; then
    if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq && $SUDO apt-get install -y -qq chromium >/dev/null
  fi
  [ -d tests/browser/node_modules/playwright-core ] ||
    (cd tests/browser && npm ci --no-audit --no-fund)
  nice -n 10 scripts/build-web.sh --tools-only
) >.cache/web-setup.log 2>&1 &
web_setup=$!
# Waits for a background set-up, shows what it printed, and fails when it failed.
setup_done() { # PID LOG
  local rc=0
  wait "$1" || rc=$?
  cat "$2"
  [ "$rc" = 0 ] || { echo "set-up failed (exit $rc), see above" >&2; exit 1; }
}

# Each step's wall time and the CPU time its processes used (bash's `times`), for the
# 25-minute CI budget.
step_start=$SECONDS
step_name=""
step_times=$(mktemp)
trap 'rm -f "$step_times"' EXIT
step() { # NAME (the next step; none at the end)
  if [ -n "$step_name" ]; then
    # `times` in this shell, not in a subshell: its second line is the children's CPU.
    times >"$step_times"
    echo "-- $step_name: $((SECONDS - step_start)) s wall (CPU so far, user and system:" \
      "$(tail -1 "$step_times"))"
  fi
  step_name=${1:-}
  step_start=$SECONDS
  [ -z "$step_name" ] || echo "== $step_name"
}

step "cargo test --release"
cargo test --release 2>&1

step "cargo test --lib in the dev profile (debug assertions and overflow checks)"
# What a program that embeds the library runs in its own debug builds: arithmetic that
# would wrap, and the debug_asserts (a stitched store's slots, for one), panic here.
cargo test --lib 2>&1

step "other platforms and CPU-only: scripts/check-targets.sh"
# What this run compiles anyway is not checked twice: the web's GPU build (the browser
# step, scripts/build-web.sh), this machine's with the default features (cargo test above)
# and without them (the Python package).
CHECK_TARGETS_WEB_BUILT_LATER=1 CHECK_TARGETS_HOST_BUILT=1 scripts/check-targets.sh

step "blender add-on integration test"
setup_done "$blender_setup" .cache/blender-setup.log
# The binary cargo test built above (the heavy crates are compiled once per run).
G1TESS_BIN=target/release/g1tess scripts/blender_test.sh

step "python package, gmsh and dask tests"
setup_done "$python_setup" .cache/python-setup.log
G1TESS_BIN=target/release/g1tess scripts/python_test.sh

step "browser tests: the WebGPU viewer in headless Chromium"
setup_done "$web_setup" .cache/web-setup.log
G1TESS_BIN=target/release/g1tess scripts/test-browser.sh
step
echo "== all tests passed in $SECONDS s"
