#!/usr/bin/env bash
# Peak memory of `hysteron fit` (issue 13, item 8: "fit memory at most a small multiple of the
# record's size"): maximum RSS (/usr/bin/time -v) and wall time of `fit --model M` on records of
# R rows (input,output CSV), and the ratio of the peak RSS to the record's raw size (16 bytes a
# row: two doubles).
#
#   bench/fit_memory.sh [HYSTERON_BINARY] [ROWS...]        # defaults: build/hysteron, 1000000
#   MODELS="pi gpi" FIT_ARGS="--threads 1" bench/fit_memory.sh build/hysteron 1000000 10000000
#
# MODELS (default "pi gpi") are the kinds fitted (MODELS=all: pi gpi mpi-deadzone mpi-asym
# preisach kp maxwell-slip rate-pi bouc-wen auto, every `fit --model` choice); FIT_ARGS are
# added to every fit (default: none, i.e. 2 starts on one thread per core); COMPARE=/path/to/other/hysteron runs every fit with that
# binary too, on the same record, and says whether the two model files are identical (if not:
# the largest relative difference of their numbers; KEEP=DIR keeps them as DIR/MODEL_ROWS_{0,1}.json). The records (a GPI, n = 10, driven by a slow chirp-like
# input, plus 0.2 % noise; about 40 bytes a row as CSV) are written in a temporary directory and
# removed at the end.
set -euo pipefail
BIN=${1:-build/hysteron}
shift || true
ROWS=("$@")
[ ${#ROWS[@]} -gt 0 ] || ROWS=(1000000)
MODELS=${MODELS:-pi gpi}
[ "$MODELS" != all ] || MODELS="pi gpi mpi-deadzone mpi-asym preisach kp maxwell-slip rate-pi bouc-wen auto"
FIT_ARGS=${FIT_ARGS:-}
PY=/usr/bin/python3
[ -x "$BIN" ] || { echo "no executable $BIN" >&2; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05}
JSON

COMPARE=${COMPARE:-}
BINS=("$BIN")
[ -z "$COMPARE" ] || BINS+=("$COMPARE")
printf '%-12s %10s %12s %12s %8s %10s %-16s %s\n' model rows "record MB" "peak RSS MB" ratio "wall" status binary
for n in "${ROWS[@]}"; do
  $PY - "$T/x.csv" "$n" <<'PYEOF'
import sys
import numpy as np
n = int(sys.argv[2])
k = np.arange(n)
# a few hundred cycles whatever the length, amplitude swept between 0.05 and 0.25
x = 0.3 + (0.15 + 0.1 * np.cos(2 * np.pi * 3 * k / n)) * np.sin(2 * np.pi * 400 * k / n)
with open(sys.argv[1], "w") as f:
    f.write("input\n")
    f.write("\n".join(map(repr, x.tolist())))
    f.write("\n")
PYEOF
  "$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/sim.csv" 2> /dev/null
  $PY - "$T/sim.csv" "$T/d.csv" <<'PYEOF'
import sys
import numpy as np
d = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1)
rng = np.random.default_rng(1)
y = d[:, 1] + 0.002 * (d[:, 1].max() - d[:, 1].min()) * rng.standard_normal(d.shape[0])
with open(sys.argv[2], "w") as f:
    f.write("input,output\n")
    f.write("\n".join(map("{!r},{!r}".format, d[:, 0].tolist(), y.tolist())))
    f.write("\n")
PYEOF
  rm -f "$T/x.csv" "$T/sim.csv"
  for m in $MODELS; do
    for i in "${!BINS[@]}"; do
      b=${BINS[$i]}
      set +e
      # shellcheck disable=SC2086
      extra=()  # rate-pi needs the sample time (the record's is taken as 1 ms)
      [ "$m" != rate-pi ] || [[ "$FIT_ARGS" == *--sample-time* ]] || extra=(--sample-time 0.001)
      /usr/bin/time -v "$b" fit --model "$m" --data "$T/d.csv" --input input --output output \
        --out "$T/m$i.json" --force $FIT_ARGS "${extra[@]}" > "$T/fit.txt" 2> "$T/time.txt"
      code=$?
      set -e
      rss=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$T/time.txt")
      wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$T/time.txt")
      status=$(grep -o -m1 ' fit: [a-z_]*' "$T/fit.txt" | sed 's/ fit: //' || true)
      awk -v m="$m" -v n="$n" -v rss="$rss" -v wall="$wall" -v st="${status:-exit $code}" -v b="$b" 'BEGIN {
        rec = 16 * n / 1048576; mb = rss / 1024;
        printf "%-12s %10d %12.1f %12.1f %8.1f %10s %-16s %s\n", m, n, rec, mb, mb / rec, wall, st, b }'
    done
    if [ -n "$COMPARE" ]; then
      if cmp -s <(grep -v '"note"' "$T/m0.json") <(grep -v '"note"' "$T/m1.json"); then
        echo "       $m: the two model files are identical"
      else
        # the largest relative difference of any number of the two model files (same keys)
        $PY - "$T/m0.json" "$T/m1.json" "$m" <<'PYEOF'
import json, sys
def nums(v, key=""):
    if isinstance(v, dict):
        for k, w in v.items():
            yield from nums(w, f"{key}.{k}")
    elif isinstance(v, list):
        for i, w in enumerate(v):
            yield from nums(w, f"{key}[{i}]")
    elif isinstance(v, (int, float)) and not isinstance(v, bool):
        yield key, float(v)
a = dict(nums(json.load(open(sys.argv[1]))))
b = dict(nums(json.load(open(sys.argv[2]))))
if a.keys() != b.keys():
    print(f"       {sys.argv[3]}: the two model files DIFFER in their keys")
else:
    k = max(a, key=lambda k: abs(a[k] - b[k]) / max(abs(a[k]), abs(b[k]), 1e-300))
    rel = abs(a[k] - b[k]) / max(abs(a[k]), abs(b[k]), 1e-300)
    print(f"       {sys.argv[3]}: the model files differ; largest relative difference {rel:.2g} ({k}: {a[k]!r} vs {b[k]!r})")
PYEOF
      fi
      [ -z "${KEEP:-}" ] || cp "$T/m0.json" "$KEEP/${m}_${n}_0.json"
      [ -z "${KEEP:-}" ] || cp "$T/m1.json" "$KEEP/${m}_${n}_1.json"
    fi
  done
done
