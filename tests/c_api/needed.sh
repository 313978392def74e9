#!/usr/bin/env bash
# The shared C library must not need Ceres, glog or matio (readelf -d NEEDED), and
# must export only the hysteron_* functions of include/hysteron/hysteron.h.
# Usage: bash needed.sh <libhysteron_c.so>
set -euo pipefail
lib=$1
needed=$(readelf -d "$lib" | awk '/\(NEEDED\)/ {gsub(/[\[\]]/, "", $5); print $5}')
[ -n "$needed" ] || { echo "needed.sh: readelf found no NEEDED entries in $lib"; exit 1; }
echo "NEEDED of $lib:"; echo "$needed" | sed 's/^/  /'
bad=$(echo "$needed" | grep -Ei 'ceres|glog|gflags|matio|hdf5|gtest|benchmark' || true)
if [ -n "$bad" ]; then
  echo "needed.sh: $lib must not need: $bad"
  exit 1
fi
exported=$(nm -D --defined-only "$lib" | awk 'NF >= 3 {print $3}' | sed 's/@.*//' | sort -u)
other=$(echo "$exported" | grep -v '^hysteron_' || true)
if [ -n "$other" ]; then
  echo "needed.sh: $lib exports symbols other than hysteron_*:"; echo "$other" | head -20
  exit 1
fi
count=$(echo "$exported" | grep -c '^hysteron_')
[ "$count" -ge 30 ] || { echo "needed.sh: only $count hysteron_* functions exported"; exit 1; }
echo "needed.sh: ok ($count functions exported, no Ceres/glog/matio)"
