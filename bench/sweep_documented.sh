#!/usr/bin/env bash
# The documented set of plant variants (docs/plant.md, "Plant variants"; issue 11 item 4):
# gpi-pid, mpi-openloop and mpi-pwm on the nominal rig and on the 11 variants of
# `--set documented`, on all cores. Writes the table, the HTML page and the JSON document
# into OUT_DIR (default out/sweep) and prints the text table and the wall time.
# Usage: bash bench/sweep_documented.sh [BUILD_DIR] [OUT_DIR] [extra hysteron sweep options]
# Exit status: hysteron sweep's (0, or 2 if a run failed).
set -euo pipefail
BUILD=${1:-build}
OUT=${2:-out/sweep}
shift $(( $# > 2 ? 2 : $# ))
mkdir -p "$OUT"
echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with uncommitted changes)'), $(nproc) cores, $(date -u '+%Y-%m-%d %H:%M UTC')"
start=$(date +%s.%N)
set +e
"$BUILD/hysteron" sweep gpi-pid mpi-openloop mpi-pwm --set documented \
  --out "$OUT/sweep.csv" --report "$OUT/sweep.html" "$@" | tee "$OUT/sweep.txt"
rc=${PIPESTATUS[0]}
set -e
end=$(date +%s.%N)
echo "wall time of the whole command: $(echo "$end - $start" | bc) s (exit $rc)"
exit "$rc"
