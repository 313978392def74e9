#!/usr/bin/env bash
# .mat matrix columns on the CLI: --input data:1 reads column 1 (0-based) of the 2-D matrix
# "data"; a fit from matrix columns (and from vector variables) gives the same model as the
# same columns of a CSV file; simulate --column data:1 too; every error names the file and
# the variable (missing variable with the file's variables, index out of range with the
# size, matrix without an index, sparse, complex, char, N-D); a CSV header "p:x" is a name.
# The .mat file is written by scipy (another writer than hysteron's matio).
# Usage: bash mat_matrix.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

cat > "$T/pi.json" <<'JSON'
{"model": "pi", "r": [0, 0.1, 0.2, 0.3], "p": [1.0, 0.5, 0.3, 0.2]}
JSON
$PY - "$T" <<'PYEOF' || { echo "FAIL: cannot write the input (python3)"; exit 1; }
import sys
with open(f"{sys.argv[1]}/x.csv", "w") as f:
    f.write("pressure\n")
    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1):
        for k in range(300):
            f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
"$BIN" simulate --model "$T/pi.json" --input "$T/x.csv" --output "$T/y.csv" || fail "simulate"
# rec.csv: t_s, p:x (a colon in a CSV header), y; rec.mat: data = [t x y] (N x 3) and more
$PY - "$T" <<'PYEOF' || { echo "FAIL: cannot write rec.mat (python3 with numpy and scipy)"; exit 1; }
import sys
import numpy as np
import scipy.io
import scipy.sparse
d = sys.argv[1]
x = np.loadtxt(f"{d}/x.csv", skiprows=1)
y = np.loadtxt(f"{d}/y.csv", skiprows=1, delimiter=",", ndmin=2)[:, -1]
t = np.arange(len(x)) * 0.01
with open(f"{d}/rec.csv", "w") as f:
    f.write("t_s,p:x,y\n")
    for row in zip(t, x, y):
        f.write(",".join(repr(float(v)) for v in row) + "\n")
scipy.io.savemat(f"{d}/rec.mat", {
    "data": np.column_stack([t, x, y]),          # N x 3 double
    "xrow": x,                                   # 1 x N (scipy saves 1-D arrays as rows)
    "ycol": y.reshape(-1, 1),                    # N x 1
    "label": "pressure",                         # char
    "cube": np.zeros((2, 2, 2)),                 # 3-D
    "z": np.array([[1 + 2j, 3], [4, 5]]),        # complex
    "S": scipy.sparse.csc_matrix(np.eye(3)),     # sparse
})
PYEOF

# 1. fit from matrix columns == fit from the CSV columns == fit from the vector variables
fit() { "$BIN" fit --model pi --train 0s:12s --threads 1 "$@"; }
fit --data "$T/rec.csv" --time-column t_s --input p:x --output y --out "$T/m_csv.json" > "$T/csv.txt" 2>&1 \
  || fail "fit from CSV (header \"p:x\"): $(cat "$T/csv.txt")"
fit --data "$T/rec.mat" --time-column data:0 --input data:1 --output data:2 --out "$T/m_mat.json" \
  > "$T/mat.txt" 2>&1 || fail "fit from matrix columns: $(cat "$T/mat.txt")"
fit --data "$T/rec.mat" --time-column data:0 --input xrow --output ycol:0 --out "$T/m_vec.json" \
  > "$T/vec.txt" 2>&1 || fail "fit from vector variables: $(cat "$T/vec.txt")"
[ -s "$T/m_mat.json" ] || fail "no model from matrix columns"
# the models are equal but for their "note" (which names the data file)
same_model() { diff <(grep -v '"note"' "$1") <(grep -v '"note"' "$2"); }
grep -q '"r"' "$T/m_mat.json" || fail "model from matrix columns: no \"r\": $(cat "$T/m_mat.json")"
same_model "$T/m_csv.json" "$T/m_mat.json" > "$T/d" || fail "model from data:1/data:2 differs from the CSV's: $(head -5 "$T/d")"
same_model "$T/m_csv.json" "$T/m_vec.json" > "$T/d" || fail "model from xrow/ycol:0 differs from the CSV's: $(head -5 "$T/d")"
grep -q "^pi fit: converged" "$T/mat.txt" || fail "fit from matrix: not converged: $(head -3 "$T/mat.txt")"
# a wrong column would give another model: the output column read as the input
fit --data "$T/rec.mat" --time-column data:0 --input data:2 --output data:1 --out "$T/m_swap.json" --force \
  > /dev/null 2>&1
same_model "$T/m_csv.json" "$T/m_swap.json" > /dev/null && fail "swapped columns give the same model: the column index is ignored"

# 2. simulate --column NAME:INDEX
"$BIN" simulate --model "$T/pi.json" --input "$T/rec.mat" --column data:1 --output "$T/y_mat.csv" \
  || fail "simulate --column data:1"
cmp -s "$T/y.csv" "$T/y_mat.csv" || fail "simulate from data:1 differs from the CSV input's"

# 3. errors: exit 1, the file, the variable and what is wrong
expect_fail() {
  local what=$1 spec=$2
  shift 2
  "$BIN" fit --model pi --data "$T/rec.mat" --input "$spec" --output data:2 --out "$T/never.json" \
    > "$T/out" 2> "$T/err"
  local rc=$?
  [ $rc -eq 1 ] || { fail "$what: exit $rc, expected 1: $(cat "$T/err")"; return; }
  for needle in "$T/rec.mat" "$@"; do
    grep -qF -- "$needle" "$T/err" || { fail "$what: stderr lacks '$needle': $(cat "$T/err")"; return; }
  done
  [ -e "$T/never.json" ] && fail "$what: a model file was written"
  echo "ok: $what: $(head -1 "$T/err")"
}
expect_fail "index out of range" data:3 'variable "data"' "column index 3 is out of range" "1800x3" "3 columns"
expect_fail "matrix without index" data 'variable "data"' "1800x3" '"data:0" .. "data:2"'
expect_fail "missing variable" nope:1 'no variable "nope"' '"data"' '"xrow"' '"ycol"' '"S"'
expect_fail "bad index" data:one '"data:one"' "NAME:INDEX"
expect_fail "vector index 1" xrow:1 'variable "xrow"' "column index 1" "vector" "1x1800"
expect_fail "char" label:0 'variable "label"' "not numeric" "char"
expect_fail "3-D" cube:0 'variable "cube"' "3-D array" "2x2x2"
expect_fail "complex" z:0 'variable "z"' "complex"
expect_fail "sparse" S:1 'variable "S"' "sparse" "full()"
# simulate / invert without --column on a file of several variables, none named input / output: the error lists
# them and says which name was looked for (a variable of that name would be taken: cli/simulate_invert.sh)
for cmd in simulate:input invert:output; do
  "$BIN" "${cmd%%:*}" --model "$T/pi.json" --input "$T/rec.mat" --output "$T/never.csv" > /dev/null 2> "$T/err"
  rc=$?
  [ $rc -eq 1 ] || fail "${cmd%%:*} without --column: exit $rc"
  grep -qF "$T/rec.mat: has 7 variables (" "$T/err" && grep -qF "\"xrow\"" "$T/err" \
    && grep -qF "), none named \"${cmd#*:}\"; choose one by name" "$T/err" \
    || fail "${cmd%%:*} without --column: message: $(cat "$T/err")"
  [ -e "$T/never.csv" ] && fail "${cmd%%:*} without --column: wrote an output"
done
# NAME:INDEX in a CSV file: not a matrix column (a header named so would win)
"$BIN" fit --model pi --data "$T/rec.csv" --input data:1 --output y --out "$T/never.json" > /dev/null 2> "$T/err"
rc=$?
[ $rc -eq 1 ] || fail "CSV data:1: exit $rc"
grep -qF 'no column named "data:1"' "$T/err" && grep -qF ".mat file only" "$T/err" \
  || fail "CSV data:1: message: $(cat "$T/err")"
# the help says 0-based and NAME:INDEX
"$BIN" fit --help | grep -q "NAME:INDEX = column INDEX (0-based)" || fail "fit --help does not describe NAME:INDEX"

if [ $fails -ne 0 ]; then
  echo "$fails failure(s)"
  exit 1
fi
echo "all mat_matrix checks passed"
