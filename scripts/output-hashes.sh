#!/usr/bin/env bash
# Prints the sha256 of a fixed set of g1tess outputs, one "HASH  NAME" line each, sorted by
# name: `stats --json` of the test meshes under every scheme (with and without
# --repair-folds), `tessellate` to OBJ, PLY, GLB and STL (uniform and --tolerance-rel),
# `export-msh` at orders 1-5 and `export-net`. A refactor keeps every line the same:
#   scripts/output-hashes.sh > before.txt   (old binary)
#   scripts/output-hashes.sh > after.txt && diff before.txt after.txt
# Usage: scripts/output-hashes.sh [BINARY]   (default target/release/g1tess)
set -euo pipefail
cd "$(dirname "$0")/.."
bin="${1:-target/release/g1tess}"
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
data=tests/data
meshes=(spot suzanne fandisk)
schemes=(g1 phong nagata nagata-guarded nlsa pn pn-normals flat)
run() { # NAME CMD...: the command's standard output, hashed under NAME
  local name="$1"; shift
  "$bin" "$@" >"$out/$name" 2>/dev/null || echo "exit $?" >>"$out/$name"
}
for m in "${meshes[@]}"; do
  extra=(); [ "$m" = fandisk ] && extra=(--crease-angle 30)
  for s in "${schemes[@]}"; do
    run "stats-$m-$s.json" stats "$data/$m.obj" "${extra[@]}" --scheme "$s" --backend cpu --json
    run "stats-$m-$s-repair.json" stats "$data/$m.obj" "${extra[@]}" --scheme "$s" --backend cpu --json --repair-folds
  done
  for f in obj ply glb stl; do
    "$bin" tessellate "$data/$m.obj" "${extra[@]}" --backend cpu --level 5 -q -o "$out/tess-$m-l5.$f"
    "$bin" tessellate "$data/$m.obj" "${extra[@]}" --backend cpu --tolerance-rel 1e-3 -q -o "$out/tess-$m-rel.$f"
  done
  for o in 1 2 3 4 5; do
    "$bin" export-msh "$data/$m.obj" "${extra[@]}" --order "$o" -q -o "$out/msh-$m-o$o.msh"
  done
  "$bin" export-net "$data/$m.obj" "${extra[@]}" -q -o "$out/net-$m.json"
done
# The bunny (70k triangles): statistics and a uniform PLY.
run stats-bunny-g1.json stats "$data/stanford-bunny.obj" --backend cpu --json
run stats-bunny-g1-repair.json stats "$data/stanford-bunny.obj" --backend cpu --json --repair-folds
"$bin" tessellate "$data/stanford-bunny.obj" --backend cpu --level 4 -q -o "$out/tess-bunny-l4.ply"
(cd "$out" && sha256sum -- * | sort -k2)
