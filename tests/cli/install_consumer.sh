#!/usr/bin/env bash
# Packaging: install hysteron into a temporary prefix, then configure, build and
# run a consumer project (tests/consumer) once per layer with
# find_package(hysteron COMPONENTS <layer>), and once with every layer.
# Then check that hysteron::core links with nothing but the C++ standard library:
# its imported target has no link dependency, and a program links against
# libhysteron_core.a alone with a bare g++ command line.
set -euo pipefail
cli="$1"; src="$2"
build_dir="$(dirname "$cli")"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
cmake --install "$build_dir" --prefix "$tmp/prefix" --component Unspecified > "$tmp/install.log" 2>&1 || { cat "$tmp/install.log"; exit 1; }
find "$tmp/prefix" -name hysteronConfigVersion.cmake | grep -q . || { echo "no version file installed"; exit 1; }
for c in core io identify rig report hysteron; do
  cmake -S "$src/tests/consumer" -B "$tmp/build-$c" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release \
    -DHYSTERON_COMPONENT=$c > "$tmp/cfg-$c.log" 2>&1 || { echo "configure failed for component $c"; cat "$tmp/cfg-$c.log"; exit 1; }
  cmake --build "$tmp/build-$c" > "$tmp/build-$c.log" 2>&1 || { echo "build failed for component $c"; cat "$tmp/build-$c.log"; exit 1; }
  "$tmp/build-$c/consumer"
done
# find_package(hysteron COMPONENTS core) must not need Ceres, fmt, json or matio.
if grep -qiE 'ceres|matio|fmt|nlohmann' "$tmp/cfg-core.log"; then
  echo "find_package(hysteron COMPONENTS core) looked for a dependency:"; cat "$tmp/cfg-core.log"; exit 1
fi
targets="$(find "$tmp/prefix" -name 'hysteronTargets.cmake')"
core_block="$(awk '/add_library\(hysteron::core /,/^\)/' "$targets"; awk '/set_target_properties\(hysteron::core /,/^\)/' "$targets")"
if grep -q INTERFACE_LINK_LIBRARIES <<<"$core_block"; then
  echo "hysteron::core has link dependencies:"; echo "$core_block"; exit 1
fi
lib="$(find "$tmp/prefix" -name libhysteron_core.a | head -1)"
[ -n "$lib" ] || { echo "libhysteron_core.a not installed"; exit 1; }
g++ -std=c++20 -O1 -I"$tmp/prefix/include" "$src/tests/consumer/main_core.cpp" "$lib" -o "$tmp/core_alone"
"$tmp/core_alone"
echo "core links alone: ok"
