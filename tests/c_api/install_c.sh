#!/usr/bin/env bash
# Install hysteron into a temporary prefix; then (1) compile a C99 program with plain gcc
# against the installed header and shared library, (2) the same through pkg-config
# (hysteron_c.pc), shared and static, (3) build it with CMake through find_package(hysteron)
# and hysteron::c / hysteron::c_static; run them all.
# Usage: bash install_c.sh <build-dir> <tests/c_api dir>
set -euo pipefail
build_dir=$1; dir=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
cmake --install "$build_dir" --prefix "$tmp/prefix" > "$tmp/install.log" 2>&1 || { cat "$tmp/install.log"; exit 1; }
inc="$tmp/prefix/include"; lib=$(dirname "$(find "$tmp/prefix" -name 'libhysteron_c.so' | head -1)")
[ -f "$inc/hysteron/hysteron.h" ] || { echo "install_c: hysteron.h not installed"; exit 1; }
[ -f "$lib/libhysteron_c.a" ] || { echo "install_c: libhysteron_c.a not installed"; exit 1; }
gcc -std=c99 -pedantic -Wall -Wextra -Werror "$dir/consumer/main.c" -I"$inc" -L"$lib" -lhysteron_c -lm \
    -Wl,-rpath,"$lib" -o "$tmp/plain"
"$tmp/plain"
# pkg-config: the installed hysteron_c.pc, found in the prefix (relocatable), names the version of
# the library and links the same program, shared and (with only the .a files) static.
pc=$(find "$tmp/prefix" -name hysteron_c.pc | head -1)
[ -n "$pc" ] || { echo "install_c: hysteron_c.pc not installed"; exit 1; }
export PKG_CONFIG_PATH="$(dirname "$pc")"
version=$(sed -n 's/^project(hysteron VERSION \([0-9.]*\).*/\1/p' "$dir/../../CMakeLists.txt")
[ "$(pkg-config --modversion hysteron_c)" = "$version" ] \
  || { echo "install_c: pkg-config says version $(pkg-config --modversion hysteron_c), CMake $version"; exit 1; }
# shellcheck disable=SC2046  # word splitting of pkg-config's flags is wanted
gcc -std=c99 -pedantic -Wall -Wextra -Werror "$dir/consumer/main.c" $(pkg-config --cflags --libs hysteron_c) -lm \
    -Wl,-rpath,"$lib" -o "$tmp/pc_shared"
readelf -d "$tmp/pc_shared" | grep -q 'NEEDED.*libhysteron_c\.so' || { echo "install_c: pc_shared not linked to the .so"; exit 1; }
"$tmp/pc_shared"
cp -a "$tmp/prefix" "$tmp/static_prefix"
find "$tmp/static_prefix" -name 'libhysteron_c.so*' -delete
export PKG_CONFIG_PATH="$(dirname "$(find "$tmp/static_prefix" -name hysteron_c.pc | head -1)")"
gcc -std=c99 -pedantic -Wall -Wextra -Werror -DHYSTERON_C_STATIC -c "$dir/consumer/main.c" \
    $(pkg-config --cflags hysteron_c) -o "$tmp/main.o"
# shellcheck disable=SC2046
gcc "$tmp/main.o" $(pkg-config --static --libs hysteron_c) -o "$tmp/pc_static"
if readelf -d "$tmp/pc_static" | grep -q 'NEEDED.*libhysteron'; then echo "install_c: pc_static needs a hysteron .so"; exit 1; fi
"$tmp/pc_static"
unset PKG_CONFIG_PATH
cmake -S "$dir/consumer" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release \
    > "$tmp/cfg.log" 2>&1 || { cat "$tmp/cfg.log"; exit 1; }
cmake --build "$tmp/build" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
"$tmp/build/consumer_shared" "$dir/gpi.json"
"$tmp/build/consumer_static" "$dir/gpi.json"
# a component that does not exist is named, with the list of those that do
mkdir -p "$tmp/bogus"
cat > "$tmp/bogus/CMakeLists.txt" <<'CM'
cmake_minimum_required(VERSION 3.20)
project(bogus LANGUAGES C)
find_package(hysteron REQUIRED COMPONENTS c_static)
CM
if cmake -S "$tmp/bogus" -B "$tmp/bogus/b" -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/bogus.log" 2>&1; then
  echo "install_c: find_package(hysteron COMPONENTS c_static) configured"; exit 1
fi
tr -s ' \n' ' ' < "$tmp/bogus.log" \
  | grep -q "unknown component(s) c_static: hysteron's components are core io identify rig report c" \
  || { echo "install_c: no message naming the unknown component:"; cat "$tmp/bogus.log"; exit 1; }
echo "install_c: ok"
