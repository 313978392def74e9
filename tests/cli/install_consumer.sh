#!/usr/bin/env bash
# Packaging: install hysteron into a temporary prefix, then configure, build and
# run a consumer project that uses find_package(hysteron) (tests/consumer).
set -euo pipefail
cli="$1"; src="$2"
build_dir="$(dirname "$cli")"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
cmake --install "$build_dir" --prefix "$tmp/prefix" --component Unspecified > "$tmp/install.log" 2>&1 || { cat "$tmp/install.log"; exit 1; }
find "$tmp/prefix" -name hysteronConfigVersion.cmake | grep -q . || { echo "no version file installed"; exit 1; }
cmake -S "$src/tests/consumer" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release > "$tmp/cfg.log" 2>&1 || { cat "$tmp/cfg.log"; exit 1; }
cmake --build "$tmp/build" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
"$tmp/build/consumer"
