#!/usr/bin/env bash
# hysteron's CLI (simulate + invert) against a numpy GPI forward alone on 1,000,000 samples,
# via CSV and via .mat (issue 13, item 8; targets: 20x via CSV, 100x via .mat).
#
#   bench/numpy_compare.sh [HYSTERON_BINARY] [REPEATS] [NAIVE_REPEATS]   # build/hysteron, 5, 3
#
# The numpy side (three forwards: a Python loop over samples, a parallel-prefix scan, a loop over
# monotone runs; np.loadtxt / scipy.io.loadmat in, join of repr / scipy.io.savemat out) is
# bench/numpy_compare.py, run with /usr/bin/python3 (Debian numpy and scipy). Inputs (about
# 40 MB) are written to a temporary directory and removed at the end. Prints medians side by
# side, the numpy stage times, and the ratios as a Markdown table.
set -euo pipefail
BIN=${1:-build/hysteron}
REPEATS=${2:-5}
NAIVE_REPEATS=${3:-3}
[ -x "$BIN" ] || { echo "no executable $BIN" >&2; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
/usr/bin/python3 "$(dirname "$0")/numpy_compare.py" --bin "$BIN" --repeats "$REPEATS" \
  --naive-repeats "$NAIVE_REPEATS" --dir "$T"
