#!/usr/bin/env bash
# Long fuzzing campaign: the in-process reader fuzzers of tests/fuzz.rs (OBJ, .pn, PLY, STL,
# glTF, built-in specs, soups) and the glTF buffer URI mutator of tests/hardening_readers.rs
# (traversal, absolute paths, devices, FIFOs, links out of the folder, huge byteLength) with
# many more cases, and optionally more command lines.
#
#   scripts/fuzz.sh [EXECUTIONS] [CLI_CASES] [OUTPUT_PATH_CASES]
#
# EXECUTIONS (default 1000000) is split over the reader tests in the proportions of the
# normal suite (OBJ 30 %, .pn 20 %, PLY 10 %, STL 8 %, glTF 7 %, specs 15 %, soups 10 %),
# plus 1 % more for glTF URIs; CLI_CASES (default 1000) command lines are spawned.
# OUTPUT_PATH_CASES (default 500) runs of the writing commands (tessellate to each format,
# export-net, export-msh) take hostile output paths (tests/hardening_cli.rs): names with
# newlines, escape sequences, bidi overrides or a byte that is not UTF-8, names of 1 to 400
# bytes, symlinks to a file, a directory or nothing, directories, a path below a file.
# Prints the executions per second. A failure prints the minimal failing input.
set -euo pipefail
cd "$(dirname "$0")/.."
total=${1:-1000000}
cli=${2:-1000}
paths=${3:-500}
cargo test --release --no-run --quiet --test suite
run() { # TEST CASES VAR (TEST in tests/fuzz.rs, or MODULE::TEST)
    local start end name="$1"
    [[ $name == *::* ]] || name="fuzz::$name"
    start=$(date +%s.%N)
    env "$3=$2" cargo test --release --quiet --test suite -- --exact "$name" >/dev/null
    end=$(date +%s.%N)
    awk -v t="$1" -v n="$2" -v s="$start" -v e="$end" \
        'BEGIN { d = e - s; printf "%-15s %9d cases %8.1f s %9.0f /s\n", t, n, d, n / d }'
}
start=$(date +%s.%N)
run obj_mutants $((total * 3000 / 10000)) PROPTEST_CASES
run pn_mutants $((total * 2000 / 10000)) PROPTEST_CASES
run ply_mutants $((total * 1000 / 10000)) PROPTEST_CASES
run stl_mutants $((total * 800 / 10000)) PROPTEST_CASES
run gltf_mutants $((total * 700 / 10000)) PROPTEST_CASES
run spec_strings $((total * 1500 / 10000)) PROPTEST_CASES
run soups $((total * 1000 / 10000)) PROPTEST_CASES
run hardening_readers::gltf_uri_mutants $((total * 100 / 10000)) PROPTEST_CASES
end=$(date +%s.%N)
awk -v n="$((total + total * 100 / 10000))" -v s="$start" -v e="$end" \
    'BEGIN { d = e - s; printf "readers: %d executions in %.1f s: %.0f /s\n", n, d, n / d }'
run command_lines "$cli" FUZZ_CLI_CASES
start=$(date +%s.%N)
FUZZ_OUTPUT_CASES="$paths" cargo test --release --quiet --test suite -- --exact \
    hardening_cli::output_path_mutants >/dev/null
end=$(date +%s.%N)
awk -v n="$paths" -v s="$start" -v e="$end" \
    'BEGIN { d = e - s; printf "%-15s %9d cases %8.1f s %9.0f /s\n", "output_paths", n, d, n / d }'
