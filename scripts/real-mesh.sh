#!/usr/bin/env bash
# Issue 29's figures on a user's mesh, as one prepared run (what BENCHMARKS.md's "Real
# meshes" sections report), and the mesh they are measured on:
#
#   scripts/real-mesh.sh make SCAN.obj OUT.obj   # each triangle split into 4, twice; no normals
#   scripts/real-mesh.sh measure MESH [BINARY]   # default BINARY: target/release/g1tess
#
# `make` keeps the scan's vertices and faces (polygons fanned into triangles), adds each
# edge's midpoint once (so the split mesh stays watertight where the scan is) and writes
# positions alone ("%.6g"), so that the normals are estimated on loading. From the ogre of
# common-3d-test-models (124,008 triangles) it makes the 2 M-triangle mesh of
# BENCHMARKS.md (69,188,827 bytes, sha256 da2473ed...).
#
# `measure` prints the machine, its load and the mesh's sha256, then runs
# `bench MESH --end-to-end --tess-level 8 --stats-level 1 --json --no-gpu` (its JSON goes
# to real-mesh-bench.json in the working directory; the rows the issue names are printed),
# then `tessellate MESH --backend cpu --scheme flat --level 1 -o TEMP.ply -q` five times,
# each after `wc -w MESH`, and prints each pair's seconds and their ratio (the target: at
# most 3). GNU `wc -w` runs at different speeds by locale (coreutils 9.1 takes about 1.5
# times as long under LC_ALL=C as under C.UTF-8), so it runs under both where both exist
# and the faster is the baseline: the ratio is never flattered by a slow `wc`. About a
# minute on 2 cores for the 2 M-triangle mesh. Both need python3.
set -euo pipefail
export LC_ALL=C # `time` and awk read and write decimal points

command -v python3 >/dev/null || { echo "real-mesh.sh: python3 is needed" >&2; exit 2; }

make_mesh() {
  python3 - "$1" "$2" <<'EOF'
import os, sys
vs, fs = [], []
for line in open(sys.argv[1], encoding='utf-8', errors='replace'):
    p = line.split()
    if not p:
        continue
    if p[0] == 'v':
        vs.append(tuple(float(x) for x in p[1:4]))
    elif p[0] == 'f':
        idx = [int(q.split('/')[0]) for q in p[1:]]
        idx = [i - 1 if i > 0 else len(vs) + i for i in idx]
        for k in range(1, len(idx) - 1):
            fs.append((idx[0], idx[k], idx[k + 1]))
for _ in range(2):
    mid = {}
    def m(a, b):
        k = (a, b) if a < b else (b, a)
        if k not in mid:
            pa, pb = vs[a], vs[b]
            vs.append(tuple((pa[i] + pb[i]) / 2 for i in range(3)))
            mid[k] = len(vs) - 1
        return mid[k]
    nf = []
    for a, b, c in fs:
        ab, bc, ca = m(a, b), m(b, c), m(c, a)
        nf += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    fs = nf
tmp = sys.argv[2] + '.part'
with open(tmp, 'w') as o:
    o.write(''.join('v %.6g %.6g %.6g\n' % v for v in vs))
    o.write(''.join('f %d %d %d\n' % (a + 1, b + 1, c + 1) for a, b, c in fs))
os.replace(tmp, sys.argv[2])
print(f'{sys.argv[2]}: {len(vs)} vertices, {len(fs)} triangles', file=sys.stderr)
EOF
}

measure() {
  local mesh="$1" bin="${2:-target/release/g1tess}"
  [ -f "$mesh" ] || { echo "real-mesh.sh: $mesh: no such file" >&2; exit 2; }
  command -v "$bin" >/dev/null ||
    { echo "real-mesh.sh: $bin: no such program (cargo build --release)" >&2; exit 2; }
  local out
  out=$(mktemp -d)
  # shellcheck disable=SC2064 # `out` is expanded now: it is local to this function.
  trap "rm -rf '$out'" EXIT
  # The Vulkan loader complains without a runtime folder (the bench asks for no GPU).
  if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
    export XDG_RUNTIME_DIR="$out/xdg"
    mkdir -m 700 "$XDG_RUNTIME_DIR"
  fi
  local model
  model=$(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | cut -d: -f2- | sed 's/^ *//' || true)
  echo "== $(date -u +%Y-%m-%dT%H:%M:%SZ) $(uname -srm); $(nproc) threads; ${model:-unknown CPU}"
  echo "== load average: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
  echo "== $(sha256sum "$mesh")"
  "$bin" bench "$mesh" --end-to-end --tess-level 8 --stats-level 1 --json --no-gpu \
    >real-mesh-bench.json
  python3 - real-mesh-bench.json <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
for r in d['rows']:
    if r['step'] in ('stats', 'tessellate_setup_eval', 'tessellate_setup', 'tessellate_eval'):
        level = r['level'] if r['level'] is not None else ''
        rate = r['samples_per_s'] or 0.0
        print(f"{r['step']:24} {level!s:>3} {r['seconds']:8.3f} s {rate / 1e6:8.1f} M/s")
EOF
  TIMEFORMAT=%R
  # Locales `wc -w` runs under: C, and C.UTF-8 where the system has it.
  local locales=(C)
  if locale -a 2>/dev/null | grep -qix 'c\.utf-\?8'; then locales+=(C.UTF-8); fi
  echo "== flat level 1 against wc -w (seconds; wc -w under ${locales[*]}, the faster counts)"
  for _ in 1 2 3 4 5; do
    local w f l t
    w=
    for l in "${locales[@]}"; do
      t=$({ time LC_ALL=$l wc -w "$mesh" >/dev/null; } 2>&1)
      if [ -z "$w" ] || awk -v a="$t" -v b="$w" 'BEGIN { exit !(a < b) }'; then w=$t; fi
    done
    f=$({ time "$bin" tessellate "$mesh" --backend cpu --scheme flat --level 1 \
      -o "$out/flat.ply" -q 2>"$out/err"; } 2>&1) ||
      { echo "real-mesh.sh: tessellate failed:" >&2; cat "$out/err" >&2; exit 1; }
    echo "wc -w $w  flat $f  ratio $(awk -v a="$f" -v b="$w" \
      'BEGIN { if (b > 0) printf "%.2f", a / b; else printf "-" }')"
  done
}

case "${1:-}" in
  make) [ $# -eq 3 ] || { echo "usage: $0 make SCAN.obj OUT.obj" >&2; exit 2; }; make_mesh "$2" "$3" ;;
  measure)
    [ $# -eq 2 ] || [ $# -eq 3 ] || { echo "usage: $0 measure MESH [BINARY]" >&2; exit 2; }
    measure "$2" "${3:-}" ;;
  *) echo "usage: $0 make SCAN.obj OUT.obj | $0 measure MESH [BINARY]" >&2; exit 2 ;;
esac
