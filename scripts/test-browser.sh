#!/usr/bin/env bash
# The WebGPU viewer (web/) tested in headless Chromium (tests/browser/, node's test runner
# with npm's playwright-core): Chromium runs WebGPU on its built-in SwiftShader, and the
# page is checked against the g1tess CLI (counts, GLB read-back, `g1tess render`).
# Provides what the tests need when it is missing: the CLI (cargo build --release, unless
# G1TESS_BIN names one), web/pkg (scripts/build-web.sh, also when web/src or the library is
# newer), tests/browser/node_modules (npm ci, from the lock file), Debian's chromium and
# Mesa's lavapipe (apt-get; `g1tess render` draws on Vulkan). Never `playwright install`.
# With CI=true a missing browser or WebGPU adapter fails the tests; otherwise they skip.
set -euo pipefail
cd "$(dirname "$0")/.."

WHAT="browser tests"
# shellcheck source=scripts/venv.sh
. scripts/venv.sh

if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
apt_install() {
  echo "== installing $* (apt-get)"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq && $SUDO apt-get install -y -qq "$@" >/dev/null
}

command -v node >/dev/null || unavailable "node not found"
node -e 'process.exit(+process.versions.node.split(".")[0] >= 20 ? 0 : 1)' ||
  unavailable "node $(node --version) is older than 20 (playwright-core needs 20)"

if [ ! -x "${CHROMIUM:-/usr/bin/chromium}" ]; then
  apt_install chromium || unavailable "apt-get could not install chromium"
fi
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
  apt_install mesa-vulkan-drivers libvulkan1 || unavailable "apt-get could not install lavapipe"
fi
# Vulkan loaders warn without a runtime dir.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  export XDG_RUNTIME_DIR="${TMPDIR:-/tmp}/g1tess-xdg-$(id -u)"
  mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
fi

if [ ! -d tests/browser/node_modules/playwright-core ]; then
  echo "== npm ci (tests/browser: playwright-core)"
  (cd tests/browser && npm ci --no-audit --no-fund) || unavailable "npm ci failed in tests/browser"
fi

test_binary "the g1tess binary the page is compared with"

# web/pkg is rebuilt when missing or older than any source of the wasm.
wasm=$(ls web/pkg/*.wasm 2>/dev/null | head -n 1 || true)
if [ -z "$wasm" ] ||
  [ -n "$(find web/src web/Cargo.toml src shaders Cargo.toml -newer "$wasm" -print -quit)" ]; then
  echo "== scripts/build-web.sh (web/pkg missing or older than its sources)"
  scripts/build-web.sh
fi

echo "== node --test tests/browser/ (Chromium $("${CHROMIUM:-/usr/bin/chromium}" --version 2>/dev/null | grep -o '[0-9][0-9.]*' | head -n 1))"
G1TESS_BIN="$BIN" node --test --test-concurrency=1 tests/browser/
