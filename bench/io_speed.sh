#!/usr/bin/env bash
# I/O speed of the CLI (issue 13, item 8): median wall time of `simulate` and `invert` on
# 1,000,000 samples (CSV in, CSV out; CSV in, .mat out), and the peak memory (max RSS from
# /usr/bin/time -v) of `simulate` on a 10,000,000-row CSV.
#
#   bench/io_speed.sh [HYSTERON_BINARY] [REPEATS]       # defaults: build/hysteron, 5
#
# Give an older binary to compare (e.g. one built at an earlier commit). Inputs are generated
# in a temporary directory (about 350 MB) and removed at the end.
set -euo pipefail
BIN=${1:-build/hysteron}
REPEATS=${2:-5}
PY=/usr/bin/python3
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
[ -x "$BIN" ] || { echo "no executable $BIN" >&2; exit 1; }

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05}
JSON
$PY - "$T/x1m.csv" "$T/x10m.csv" <<'PYEOF'
import sys
import numpy as np
for path, n in ((sys.argv[1], 1_000_000), (sys.argv[2], 10_000_000)):
    k = np.arange(n)
    x = 0.3 + 0.25 * np.sin(2e-4 * k) * np.cos(3e-6 * k)
    with open(path, "w") as f:
        f.write("input\n")
        np.savetxt(f, x, fmt="%.17g")
PYEOF
"$BIN" simulate --model "$T/gpi.json" --input "$T/x1m.csv" --output "$T/y1m.csv"

# median of REPEATS wall-clock runs of a command, in seconds
median_time() {
  local times=()
  for _ in $(seq "$REPEATS"); do
    local s e
    s=$(date +%s.%N)
    "$@" > /dev/null 2>&1
    e=$(date +%s.%N)
    times+=("$(echo "$e - $s" | bc -l)")
  done
  printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {m=(NR%2)?a[(NR+1)/2]:(a[NR/2]+a[NR/2+1])/2; printf "%.3f", m}'
}

echo "binary: $BIN ($REPEATS runs each, median wall time)"
echo "simulate 1M samples, CSV -> CSV: $(median_time "$BIN" simulate --model "$T/gpi.json" --input "$T/x1m.csv" --output "$T/o.csv") s"
echo "simulate 1M samples, CSV -> .mat: $(median_time "$BIN" simulate --model "$T/gpi.json" --input "$T/x1m.csv" --output "$T/o.mat") s"
echo "invert   1M samples, CSV -> CSV: $(median_time "$BIN" invert --model "$T/gpi.json" --input "$T/y1m.csv" --column output --output "$T/o.csv" --limits 0,0.6) s"
/usr/bin/time -v "$BIN" simulate --model "$T/gpi.json" --input "$T/x10m.csv" --output "$T/o10m.csv" 2> "$T/time.txt" > /dev/null
rss=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$T/time.txt")
wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$T/time.txt")
echo "simulate 10M rows, CSV -> CSV: peak RSS $((rss / 1024)) MB, wall $wall"
