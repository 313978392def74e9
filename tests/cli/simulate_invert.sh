#!/usr/bin/env bash
# simulate a model on a CSV, invert the result: the input must come back to 1e-12.
# Usage: bash simulate_invert.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
PY=/usr/bin/python3

cat > "$T/gpi.json" <<'JSON'
{"schema": 1, "model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05],
 "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05,
 "units": {"input": "MPa", "output": "mm"}, "note": "cli round trip"}
JSON
cat > "$T/pi.json" <<'JSON'
{"model": "pi", "q": 0.4, "r": [0, 0.1, 0.25, 0.5], "p": [0.3, 0.2, 0.15, 0.1]}
JSON
cat > "$T/dz.json" <<'JSON'
{"model": "mpi-deadzone", "q": 0.8, "r": [0.1, 0.2], "p": [0.3, 0.1], "g0": 1, "z": [-0.5, 0.25], "g": [0.2, 0.3]}
JSON
cat > "$T/asym.json" <<'JSON'
{"model": "mpi-asym", "q": 0.6, "r": [0.05, 0.15], "p": [0.2, 0.1],
 "ascending": {"envelope": "tanh", "c": [1, 1.3, 0.05, 0.01]},
 "descending": {"envelope": "affine", "c": [0.9, 0.1]}, "input_limits": [-2, 2]}
JSON

# input: time and a decaying sine with minor loops; CRLF line endings on purpose
$PY - "$T/x.csv" <<'PYEOF'
import math, sys
with open(sys.argv[1], "w", newline="") as f:
    f.write("time,x\r\n")
    for k in range(2000):
        x = 0.8 * math.sin(0.013 * k) * math.exp(-k / 1500) + 0.15 * math.sin(0.17 * k)
        f.write(f"{k * 0.002:.3f},{x!r}\r\n")
PYEOF

# max |a[col_a] - b[col_b]| over two CSV files with headers; fails above tol
check() {
  $PY - "$@" <<'PYEOF'
import csv, sys
fa, ca, fb, cb, tol, what = sys.argv[1:7]
a = [float(r[ca]) for r in csv.DictReader(open(fa, newline=""))]
b = [float(r[cb]) for r in csv.DictReader(open(fb, newline=""))]
if len(a) != len(b) or not a:
    sys.exit(f"{what}: {len(a)} vs {len(b)} samples")
err = max(abs(x - y) for x, y in zip(a, b))
print(f"{what}: max error {err:.3g}")
if not err <= float(tol):
    sys.exit(f"{what}: error {err} > {tol}")
PYEOF
}

for m in gpi pi dz asym; do
  "$BIN" simulate --model "$T/$m.json" --input "$T/x.csv" --column x --output "$T/y_$m.csv"
  head -1 "$T/y_$m.csv" | grep -qx 'input,output'
  "$BIN" invert --model "$T/$m.json" --input "$T/y_$m.csv" --column output --output "$T/x_$m.csv" 2> "$T/err_$m"
  grep -q "0 of 2000 samples saturated" "$T/err_$m"
  check "$T/x.csv" x "$T/x_$m.csv" input 1e-12 "$m virgin"
  # relaxed start on both sides
  "$BIN" simulate --model "$T/$m.json" --input "$T/x.csv" --column 1 --relaxed --output "$T/yr_$m.csv"
  "$BIN" invert --model "$T/$m.json" --input "$T/yr_$m.csv" --relaxed --output "$T/xr_$m.csv" 2> /dev/null
  check "$T/x.csv" x "$T/xr_$m.csv" input 1e-12 "$m relaxed"
done

# .mat in and out, and stdout output
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --column x --output "$T/y.mat"
"$BIN" invert --model "$T/gpi.json" --input "$T/y.mat" --column output --output - 2> /dev/null > "$T/x_mat.csv"
check "$T/x.csv" x "$T/x_mat.csv" input 1e-12 "gpi via .mat and stdout"
# without --column a .mat file of several variables gives the one named output (invert) / input
# (simulate), as a CSV file's column of that name does (y.mat holds the variables input, output)
"$BIN" invert --model "$T/gpi.json" --input "$T/y.mat" --output "$T/x_mat_default.csv" 2> /dev/null
check "$T/x.csv" x "$T/x_mat_default.csv" input 1e-12 "invert takes the .mat variable output"
"$BIN" simulate --model "$T/gpi.json" --input "$T/y.mat" --output "$T/y_mat_default.csv"
check "$T/y_gpi.csv" output "$T/y_mat_default.csv" output 0 "simulate takes the .mat variable input"

# the real piezo file (leading empty column) if the shared data are present
PIEZO="$2/../shared/data/piezo-sine/piezo_150V_1Hz.csv"
if [ -f "$PIEZO" ]; then
  cat > "$T/piezo.json" <<'JSON'
{"model": "gpi", "envelope": "affine", "c": [0.13, 0], "q": 0.8, "n": 8, "rho": 0.05, "tau": 0.02, "alpha": 10}
JSON
  "$BIN" simulate --model "$T/piezo.json" --input "$PIEZO" --column 3 --output "$T/piezo_y.csv"
  [ "$(wc -l < "$T/piezo_y.csv")" -eq 50002 ]
  "$BIN" invert --model "$T/piezo.json" --input "$T/piezo_y.csv" --output "$T/piezo_x.csv" 2> /dev/null
  check "$T/piezo_y.csv" input "$T/piezo_x.csv" input 1e-12 "piezo voltage"
else
  echo "shared piezo data absent: skipped"
fi

# saturation is reported
"$BIN" invert --model "$T/gpi.json" --input "$T/y_gpi.csv" --column output --limits=-0.2,0.2 --output "$T/sat.csv" 2> "$T/sat_err"
grep -Eq "^invert: [1-9][0-9]* of 2000 samples saturated at the input limits \[-0.2, 0.2\]" "$T/sat_err"
$PY - "$T/sat.csv" <<'PYEOF'
import csv, sys
x = [float(r["input"]) for r in csv.DictReader(open(sys.argv[1]))]
assert min(x) >= -0.2 and max(x) <= 0.2, (min(x), max(x))
PYEOF
# an analytical inverse reaches every unsaturated desired output: no miss reported
! grep -q "miss the desired output" "$T/sat_err"
# a preisach model's output jumps where a relay switches: a smooth desired output between its
# steps cannot be reached, which invert says (it reported only the saturated samples before)
cat > "$T/preisach.json" <<'JSON'
{"model": "preisach", "q": 0.1, "lo": -1, "hi": 1, "levels": 2, "w": [0.5, 0.4, 0.6], "input_limits": [-1.5, 1.5]}
JSON
# one_column FILE NAME N EXPR: a CSV with the header NAME and EXPR (Python, of k) for k < N
one_column() {
  $PY - "$@" <<'PYEOF'
import math, sys
path, name, n, expr = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
with open(path, "w") as f:
    f.write(name + "\n")
    for k in range(n):
        f.write(f"{eval(expr, {'math': math, 'k': k})!r}\n")
PYEOF
}
one_column "$T/yd.csv" y 1000 "0.6 * math.sin(0.01 * k)"
"$BIN" invert --model "$T/preisach.json" --input "$T/yd.csv" --output "$T/xd.csv" 2> "$T/pre_err"
grep -Eq "^invert: warning: [1-9][0-9]* of the [0-9]+ unsaturated samples miss the desired output" "$T/pre_err" || {
  cat "$T/pre_err"; exit 1; }
# inputs beyond the model's input_limits (its training range) are extrapolated: simulate says so
one_column "$T/wide.csv" x 400 "-3 + 6 * k / 399"
"$BIN" simulate --model "$T/asym.json" --input "$T/wide.csv" --output "$T/wide_y.csv" 2> "$T/wide_err"
grep -q "simulate: warning: .* have an input outside the model's input_limits \[-2, 2\]" "$T/wide_err" || {
  cat "$T/wide_err"; exit 1; }
"$BIN" simulate --model "$T/asym.json" --input "$T/x.csv" --column x --output "$T/in_y.csv" 2> "$T/in_err"
! grep -q "outside the model's input_limits" "$T/in_err"
# --limits beyond them too (invert and export)
"$BIN" invert --model "$T/asym.json" --input "$T/in_y.csv" --column output --limits=-3,3 --output "$T/l.csv" 2> "$T/l_err"
grep -q "invert: warning: --limits \[-3, 3\] reach beyond the model's input_limits \[-2, 2\]" "$T/l_err" || {
  cat "$T/l_err"; exit 1; }
echo "simulate_invert: ok"
