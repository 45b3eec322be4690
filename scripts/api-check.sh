#!/usr/bin/env bash
# The public API's size and documentation: builds the reference documentation with rustdoc
# warnings as errors, with and without default features, and prints the number of public
# items (structs, enums, unions, traits, functions, type aliases, constants, statics and
# macros that have a page of their own; methods and fields are not counted).
# Usage: scripts/api-check.sh [MAX]   (fails when the count is over MAX, default 150)
set -euo pipefail
cd "$(dirname "$0")/.."
max="${1:-150}"
export RUSTDOCFLAGS="-D warnings"
doc=target/api-check
rm -rf "$doc/doc" # pages of earlier builds would be counted too
for features in "--no-default-features" ""; do
  echo "== cargo doc --no-deps --lib $features"
  # shellcheck disable=SC2086
  cargo doc --quiet --no-deps --lib --target-dir "$doc" $features
done
# Pages of their own only: rustdoc also leaves redirect pages at the private paths of
# re-exported items.
count=$(find "$doc/doc/g1tess" -name '*.html' |
  grep -E '/(struct|enum|union|trait|fn|type|constant|static|macro)\.[^/]+\.html$' |
  xargs grep -L 'http-equiv="refresh"' | wc -l)
echo "public items: $count (at most $max)"
[ "$count" -le "$max" ]
