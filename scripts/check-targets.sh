#!/usr/bin/env bash
# Checks that the library compiles where wgpu runs: macOS (Metal), Windows (DX12 and Vulkan)
# and Linux (Vulkan), each with the GPU path (feature `gpu`), the web (wasm32-unknown-unknown,
# the browser's WebGPU) with the GPU path and CPU-only, and on this machine without default
# features (CPU-only, no GPU crate). `cargo check` only: types and borrows, no linker or
# SDK of the other platforms needed. A target's standard library is installed with
# `rustup target add` when it is missing. One line per check with its time; the compiler's
# messages only where a check fails or warns.
#
# The checks use the release profile: the build scripts and procedural macros they need for
# this machine are then those `cargo test --release` built (scripts/test.sh runs it first).
# The dev profile would compile a second set of them, optimised (`profile.dev.package."*"`).
# On a clean 2-core run the macOS and Windows checks took 344 s in the dev profile one after
# the other, and 81 s in the release profile in one cargo run.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGETS=(aarch64-apple-darwin x86_64-pc-windows-msvc x86_64-unknown-linux-gnu wasm32-unknown-unknown)

installed=$(rustup target list --installed)
for t in "${TARGETS[@]}"; do
  if ! grep -qx "$t" <<<"$installed"; then
    echo "== rustup target add $t"
    rustup target add "$t" >/dev/null 2>&1 || { echo "cannot install the $t standard library" >&2; exit 1; }
  fi
done

log=$(mktemp)
trap 'rm -f "$log"' EXIT
# Runs `cargo check ARGS...` and prints one line with its time, after the compiler's
# messages (one line each) where there are any; the whole output where it failed without.
check() {
  local start=$SECONDS rc=0
  cargo check --release --message-format short "$@" >"$log" 2>&1 || rc=$?
  local messages
  messages=$(grep -E '(^|: )(warning|error)(\[|:)' "$log" | grep -vE '^(warning|error): .*generated [0-9]+ warning|^error: could not compile' || true)
  if [ -n "$messages" ]; then
    echo "$messages"
  elif [ "$rc" != 0 ]; then
    cat "$log"
  fi
  if [ "$rc" != 0 ]; then
    echo "FAIL cargo check --release $* ($((SECONDS - start)) s)"
    return "$rc"
  fi
  echo "ok   cargo check --release $* ($((SECONDS - start)) s)"
}

# The GPU path of every native target in one cargo run: their crates compile side by side.
native=()
for t in "${TARGETS[@]}"; do
  # The web has no command line (feature `cli`): its GPU path without it.
  if [ "$t" = wasm32-unknown-unknown ]; then
    # scripts/test.sh builds it anyway (the viewer, scripts/build-web.sh) and sets this.
    if [ "${CHECK_TARGETS_WEB_BUILT_LATER:-}" = 1 ]; then
      echo "skip cargo check --release --lib --no-default-features --features gpu --target $t" \
        "(scripts/build-web.sh compiles it for the viewer later in this run)"
    else
      check --lib --no-default-features --features gpu --target "$t"
    fi
  elif [ "$t" = x86_64-unknown-linux-gnu ] && [ "${CHECK_TARGETS_HOST_BUILT:-}" = 1 ] &&
    [ "$(rustc -vV | sed -n 's/^host: //p')" = "$t" ]; then
    # scripts/test.sh has just built and tested the library with the default features
    # (`gpu` and `cli`) for this very target.
    echo "skip cargo check --release --lib --features gpu --target $t (cargo test built it in this run)"
  else
    native+=(--target "$t")
  fi
done
check --lib --features gpu "${native[@]}"
check --lib --no-default-features --target wasm32-unknown-unknown
if [ "${CHECK_TARGETS_HOST_BUILT:-}" = 1 ]; then
  # The Python package (scripts/python_test.sh, later in scripts/test.sh) builds the library
  # without default features for this machine.
  echo "skip cargo check --release --lib --no-default-features (the Python package builds it in this run)"
else
  check --lib --no-default-features
fi
