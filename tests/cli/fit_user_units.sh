#!/usr/bin/env bash
# A user's record differs from ours by a sensor offset, a flipped sign and absolute
# instead of gauge input (issue 10): `hysteron fit` gives the same validation error in %
# of span as on the clean record, writes a decreasing model with its units map, and
# `simulate` / `invert` of that model are exact inverses in the user's raw units.
# Usage: bash fit_user_units.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
PY=/usr/bin/python3

cat > "$T/truth.json" <<'JSON'
{"model": "mpi-asym", "q": 0.5, "r": [0.1, 0.3], "p": [0.3, 0.2],
 "ascending": {"envelope": "tanh", "c": [2.0, 0.5, -0.5, 1.0]},
 "descending": {"envelope": "tanh", "c": [1.8, 0.45, -0.3, 1.0]}, "input_limits": [-10, 10]}
JSON
# identification run (triangles) and a validation run of another signal type (a sine)
$PY - "$T" <<'PYEOF'
import math, sys
d = sys.argv[1]
tri = []
for a in (6, 4, 5, 2, 3.5, 1):
    tri += [a * k / 200 for k in range(200)] + [a * (1 - k / 200) for k in range(200)]
sine = [3 + 2.5 * math.sin(2 * math.pi * k / 400) * (0.6 + 0.4 * math.sin(k / 700)) for k in range(2400)]
for name, xs in (("id", tri), ("val", sine)):
    with open(f"{d}/{name}_x.csv", "w") as f:
        f.write("x\n" + "".join(f"{v!r}\n" for v in xs))
PYEOF
for r in id val; do
  "$BIN" simulate --model "$T/truth.json" --input "$T/${r}_x.csv" --output "$T/${r}_y.csv"
  # the user's sensors: absolute input (+101.3), output negated, offset -119 and scaled x1000
  $PY - "$T/${r}_y.csv" "$T/${r}_user.csv" <<'PYEOF'
import csv, random, sys
random.seed(1)
rows = list(csv.DictReader(open(sys.argv[1])))
with open(sys.argv[2], "w") as f:
    f.write("p,s\n")
    for r in rows:
        y = float(r["output"]) + random.gauss(0, 0.01)
        f.write(f"{float(r['input']) + 101.3!r},{-1000 * y - 119000.0!r}\n")
PYEOF
  $PY - "$T/${r}_y.csv" "$T/${r}_clean.csv" <<'PYEOF'
import csv, random, sys
random.seed(1)
rows = list(csv.DictReader(open(sys.argv[1])))
with open(sys.argv[2], "w") as f:
    f.write("p,s\n")
    for r in rows:
        f.write(f"{float(r['input'])!r},{float(r['output']) + random.gauss(0, 0.01)!r}\n")
PYEOF
done

val_pct() {  # fit on $1 (id), validate on $2 -> validation RMS in % of span
  "$BIN" fit --model "$3" --data "$1" --input p --output s --validate-data "$2" --out "$4" --json --threads 1 \
    | $PY -c 'import json,sys; r=json.load(sys.stdin); assert r["status"]=="converged", r["status"]; print(r["validate_files"][0]["rms_percent_span"])'
}
for m in pi gpi mpi-deadzone mpi-asym; do
  clean=$(val_pct "$T/id_clean.csv" "$T/val_clean.csv" $m "$T/m_clean.json")
  user=$(val_pct "$T/id_user.csv" "$T/val_user.csv" $m "$T/m_user.json")
  $PY - "$clean" "$user" "$m" <<'PYEOF'
import sys
c, u, m = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
print(f"{m}: validation {c:.4f} % of span on the clean record, {u:.4f} % on the user's")
assert abs(u - c) <= 0.01 * c, (m, c, u)
PYEOF
  # the user's model decreases and carries the map; invert(simulate(x)) = x in raw units
  $PY - "$T/m_user.json" <<'PYEOF'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["output_gain"] < 0, j.get("output_gain")
assert abs(j["input_origin"] - 101.3) < 1e-9, j["input_origin"]
assert "output_offset" in j
PYEOF
  "$BIN" simulate --model "$T/m_user.json" --input "$T/val_user.csv" --column p --output "$T/ys.csv"
  "$BIN" invert --model "$T/m_user.json" --input "$T/ys.csv" --column output --output "$T/xs.csv" 2> /dev/null
  $PY - "$T/val_user.csv" "$T/xs.csv" "$m" <<'PYEOF'
import csv, sys
a = [float(r["p"]) for r in csv.DictReader(open(sys.argv[1]))]
b = [float(r["input"]) for r in csv.DictReader(open(sys.argv[2]))]
err = max(abs(x - y) for x, y in zip(a, b))
assert len(a) == len(b) and err < 1e-9, (sys.argv[3], err)
PYEOF
done
echo "fit_user_units: ok"
