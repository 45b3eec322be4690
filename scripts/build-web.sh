#!/usr/bin/env bash
# Builds the WebGPU viewer: web/ (Rust, wasm32) into web/pkg/ (wasm + JS glue), ready to be
# served as static files with web/index.html. Needs rustup and cargo; installs the wasm32
# target and wasm-bindgen-cli (the version web/Cargo.toml pins) when missing.
#
#   scripts/build-web.sh [--tools-only]   (--tools-only: install those two and stop)
set -euo pipefail
cd "$(dirname "$0")/.."

BINDGEN_VERSION=0.2.130 # = the wasm-bindgen pinned in web/Cargo.toml

if ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
    rustup target add wasm32-unknown-unknown
fi
if [ "$(wasm-bindgen --version 2>/dev/null | awk '{print $2}')" != "$BINDGEN_VERSION" ]; then
    # An unoptimised build (--debug): it compiles in about 2 CPU minutes, where the
    # optimised one takes about 7 minutes on two cores, and its output is byte for byte
    # the optimised build's (compared on the viewer's wasm), in 6 s instead of 1. A clean
    # test run (scripts/test.sh) installs it, so its compile counts there.
    cargo install wasm-bindgen-cli --version "$BINDGEN_VERSION" --debug
fi
[ "${1:-}" = --tools-only ] && exit 0

# One target directory with the root package: the library's dependencies build once.
target_dir="${CARGO_TARGET_DIR:-$PWD/target}"
cargo build --release --target wasm32-unknown-unknown \
    --manifest-path web/Cargo.toml --target-dir "$target_dir"
wasm="$target_dir/wasm32-unknown-unknown/release/g1tess_web.wasm"
wasm-bindgen --target web --no-typescript --out-dir web/pkg "$wasm"

out=web/pkg/g1tess_web_bg.wasm
echo "built $out: $(wc -c <"$out") bytes, $(gzip -9 -c "$out" | wc -c) gzipped"
