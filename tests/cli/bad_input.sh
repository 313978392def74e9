#!/usr/bin/env bash
# Bad model files and data: non-zero exit, a message naming file/line/column/key,
# and no output file created or overwritten.
# Usage: bash bad_input.sh <hysteron-binary> <source-dir>
set -uo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0

# expect_fail <description> <substring expected in stderr> -- command...
expect_fail() {
  local what=$1 needle=$2
  shift 3
  "$@" > "$T/stdout" 2> "$T/stderr"
  local rc=$?
  if [ $rc -eq 0 ]; then
    echo "FAIL: $what: exit 0"; fails=$((fails + 1)); return
  fi
  if ! grep -qF -- "$needle" "$T/stderr"; then
    echo "FAIL: $what: stderr lacks '$needle':"; cat "$T/stderr"; fails=$((fails + 1)); return
  fi
  echo "ok: $what (exit $rc): $(head -1 "$T/stderr")"
}

cat > "$T/good.json" <<'JSON'
{"model": "gpi", "c": [1, 1, 0, 0], "q": 0.5, "n": 5, "rho": 0.3, "tau": 1.5, "alpha": 0.05}
JSON
printf 'x\n0\n0.1\n0.2\n' > "$T/x.csv"
mkdir "$T/out"
echo "precious" > "$T/out/keep.csv"

# malformed model files
printf '{"model": "gpi", "c": [1, 1, 0, 0], "q": 0.5, "n": 5, "rho": 0.3, "tau": "fast", "alpha": 0.05}' > "$T/type.json"
expect_fail "wrong type" 'key "tau": expected a number, got string' -- \
  "$BIN" simulate --model "$T/type.json" --input "$T/x.csv" --output "$T/out/keep.csv"
printf '{"model": "gpi", "c": [1, 1, 0, 0], "q": 0.5, "n": 5, "rho": 0.3, "alpha": 0.05}' > "$T/missing.json"
expect_fail "missing key" 'key "tau": missing' -- \
  "$BIN" simulate --model "$T/missing.json" --input "$T/x.csv" --output "$T/out/new.csv"
printf '{"model": "pi", "r": [0.1], "p": [1], "gain": 2}' > "$T/unknown.json"
expect_fail "unknown key" 'key "gain": unknown key; allowed keys are' -- \
  "$BIN" invert --model "$T/unknown.json" --input "$T/x.csv" --output "$T/out/keep.csv"
printf '{"model": "pi",\n  "r": [0.1,, 0.2], "p": [1, 1]}' > "$T/syntax.json"
expect_fail "not JSON" 'syntax.json: not valid JSON: parse error at line 2, column' -- \
  "$BIN" simulate --model "$T/syntax.json" --input "$T/x.csv" --output "$T/out/keep.csv"
printf '{"model": "gpi", "c": [1, 1, 0], "q": 0.5, "n": 5, "rho": 0.3, "tau": 1.5, "alpha": 0.05}' > "$T/len.json"
expect_fail "array length" 'key "c": expected an array of 4 numbers, got 3' -- \
  "$BIN" simulate --model "$T/len.json" --input "$T/x.csv" --output "$T/out/keep.csv"
printf '{"model": "gpi", "c": [1, 1, 0, 0], "q": 0.5, "n": 5, "rho": 0.3, "tau": 1.5, "alpha": -1}' > "$T/val.json"
expect_fail "model validation" 'val.json: gpi: alpha must be > 0' -- \
  "$BIN" simulate --model "$T/val.json" --input "$T/x.csv" --output "$T/out/keep.csv"
printf '{"schema": 7, "model": "pi", "r": [0.1], "p": [1]}' > "$T/schema.json"
expect_fail "schema version" 'unsupported schema version 7' -- \
  "$BIN" simulate --model "$T/schema.json" --input "$T/x.csv" --output "$T/out/keep.csv"
expect_fail "no model file" 'nope.json: cannot open' -- \
  "$BIN" simulate --model "$T/nope.json" --input "$T/x.csv" --output "$T/out/keep.csv"

# bad data
printf 'x\n0\n0.1\nNaN\n0.3\n' > "$T/nan.csv"
expect_fail "NaN in CSV" 'nan.csv:4:1 (column "x"): "NaN" is not a finite number' -- \
  "$BIN" simulate --model "$T/good.json" --input "$T/nan.csv" --output "$T/out/keep.csv"
printf 't,x\n0,0\n1,0.1x\n' > "$T/num.csv"
expect_fail "bad number" 'num.csv:3:2 (column "x"): "0.1x" is not a number' -- \
  "$BIN" invert --model "$T/good.json" --input "$T/num.csv" --column x --output "$T/out/new.csv"
printf 't,x\n0,0\n1,0.1,5\n' > "$T/ragged.csv"
expect_fail "ragged row" 'ragged.csv:3: row has 3 fields, expected 2' -- \
  "$BIN" simulate --model "$T/good.json" --input "$T/ragged.csv" --column x --output "$T/out/new.csv"
expect_fail "unknown column" 'no column named "y"' -- \
  "$BIN" simulate --model "$T/good.json" --input "$T/x.csv" --column y --output "$T/out/new.csv"
expect_fail "bad limits" '--limits' -- \
  "$BIN" invert --model "$T/good.json" --input "$T/x.csv" --limits=1,0 --output "$T/out/new.csv"
expect_fail "missing option" 'model' -- \
  "$BIN" simulate --input "$T/x.csv" --output "$T/out/new.csv"
expect_fail "output directory missing" 'does not exist' -- \
  "$BIN" simulate --model "$T/good.json" --input "$T/x.csv" --output "$T/nodir/y.csv"
# an output that cannot be written is refused before anything is read or computed (a fit may take minutes)
expect_fail "fit --out into a missing directory" "--out $T/nodir/m.json: directory $T/nodir does not exist (nothing was run" -- \
  "$BIN" fit --model gpi --data "$T/x.csv" -i 0 -y 0 --out "$T/nodir/m.json"
expect_fail "fit --report into a missing directory" "--report $T/nodir/r.json: directory $T/nodir does not exist (nothing" -- \
  "$BIN" fit --model gpi --data "$T/x.csv" -i 0 -y 0 --out "$T/out/new.json" --report "$T/nodir/r.json"
expect_fail "fit --out a directory" "--out $T/out: is a directory" -- \
  "$BIN" fit --model gpi --data "$T/x.csv" -i 0 -y 0 --out "$T/out"
expect_fail "evaluate --report into a missing directory" "--report $T/nodir/r.json: directory $T/nodir does not" -- \
  "$BIN" evaluate --model "$T/good.json" --data "$T/x.csv" -i 0 -y 0 --report "$T/nodir/r.json"
expect_fail "export --header into a missing directory" "--header $T/nodir/c.h: directory $T/nodir does not" -- \
  "$BIN" export --model "$T/good.json" --out "$T/out/c.c" --header "$T/nodir/c.h"
expect_fail "report --out into a missing directory" "--out $T/nodir/r.html: directory $T/nodir does not" -- \
  "$BIN" report "$T/good.json" --out "$T/nodir/r.html"
expect_fail "experiment --out under a file, refused before the run" \
  "--out $T/out/keep.csv/run: $T/out/keep.csv is not a directory (nothing was run or written)" -- \
  "$BIN" experiment gpi-pid --out "$T/out/keep.csv/run"

# nothing was created or overwritten, and no temporary file is left behind
if [ "$(cat "$T/out/keep.csv")" != "precious" ]; then echo "FAIL: keep.csv was modified"; fails=$((fails + 1)); fi
if [ "$(ls -A "$T/out")" != "keep.csv" ]; then echo "FAIL: stray files in out/: $(ls -A "$T/out")"; fails=$((fails + 1)); fi
[ -e "$T/nodir" ] && { echo "FAIL: nodir created"; fails=$((fails + 1)); }

# and a good run does replace the file
"$BIN" simulate --model "$T/good.json" --input "$T/x.csv" --output "$T/out/keep.csv" || { echo "FAIL: good run"; fails=$((fails + 1)); }
[ "$(wc -l < "$T/out/keep.csv")" -eq 4 ] || { echo "FAIL: good run output"; fails=$((fails + 1)); }

# time columns: rate-pi's sample time and ranges in seconds need increasing stamps; a gap warns
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 400; ++k) { t = (k == 200 ? 0.1985 : k * 0.001); \
  p = 50 + 40 * sin(k / 20); print t "," p "," (0.3 * p + 2 + 3 * sin(k / 20 + 0.4)) } }' > "$T/tswap.csv"
expect_fail "time column not increasing (rate-pi)" 'the time column t goes backwards at sample 200 (data row 201' -- \
  "$BIN" fit --model rate-pi --data "$T/tswap.csv" --input p --output y --time-column t --out "$T/out/keep.csv"
expect_fail "time column not increasing (seconds range)" 'goes backwards at sample 200' -- \
  "$BIN" fit --model pi --data "$T/tswap.csv" --input p --output y --time-column t --train 0s:0.3s --out "$T/out/keep.csv"
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 400; ++k) { t = k * 0.001 + (k >= 200 ? 5 : 0); \
  p = 50 + 40 * sin(k / 20); print t "," p "," (0.3 * p + 2 + 3 * sin(k / 20 + 0.4)) } }' > "$T/tgap.csv"
"$BIN" fit --model rate-pi --data "$T/tgap.csv" --input p --output y --time-column t --force --out "$T/gap.json" \
  > "$T/gap.txt" 2>&1
grep -q "not uniformly sampled: the step to sample 200 (data row 201)" "$T/gap.txt" ||
  { echo "FAIL: a gap in the time column: no warning"; cat "$T/gap.txt"; fails=$((fails + 1)); }
# a repeated stamp (a logger's clock tick; the Festo record test9 has one) warns, it is not refused;
# repeats on more than 1 % of the steps are
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 400; ++k) { t = (k == 100 ? 0.099 : k * 0.001); \
  p = 50 + 40 * sin(k / 20); print t "," p "," (0.3 * p + 2 + 3 * sin(k / 20 + 0.4)) } }' > "$T/trep.csv"
"$BIN" fit --model rate-pi --data "$T/trep.csv" --input p --output y --time-column t --force --out "$T/rep.json" \
  > "$T/rep.txt" 2>&1
grep -q "needs increasing time stamps" "$T/rep.txt" && { echo "FAIL: one repeated stamp refused"; cat "$T/rep.txt"; fails=$((fails + 1)); }
[ -s "$T/rep.json" ] || { echo "FAIL: one repeated stamp: no model written with --force"; fails=$((fails + 1)); }
grep -q "repeats a stamp at 1 of its 399 steps (the first at sample 100, data row 101" "$T/rep.txt" ||
  { echo "FAIL: a repeated stamp: no warning"; cat "$T/rep.txt"; fails=$((fails + 1)); }
grep -q "not uniformly sampled" "$T/rep.txt" && { echo "FAIL: a repeated stamp read as a gap"; cat "$T/rep.txt"; fails=$((fails + 1)); }
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 400; ++k) { t = int(k / 2) * 0.002; \
  p = 50 + 40 * sin(k / 20); print t "," p "," (0.3 * p + 2 + 3 * sin(k / 20 + 0.4)) } }' > "$T/treps.csv"
expect_fail "time column repeating on half its steps" 'repeats a stamp at 200 of its 399 steps' -- \
  "$BIN" fit --model rate-pi --data "$T/treps.csv" --input p --output y --time-column t --out "$T/out/keep.csv"
# ... and a range in seconds needs no more than stamps that do not go backwards
"$BIN" fit --model pi --data "$T/treps.csv" --input p --output y --time-column t --train 0s:0.3s --force \
  --out "$T/reps_range.json" > "$T/reps_range.txt" 2>&1
grep -q "needs increasing time stamps" "$T/reps_range.txt" &&
  { echo "FAIL: a range in seconds refused on repeated stamps"; cat "$T/reps_range.txt"; fails=$((fails + 1)); }
# auto on a column that cannot give rate-pi its sample time fits the other kinds, and says why
"$BIN" fit --model auto --data "$T/tswap.csv" --input p --output y --time-column t --force --out "$T/auto_swap.json" \
  > "$T/auto_swap.txt" 2>&1
[ -s "$T/auto_swap.json" ] || { echo "FAIL: auto refused a backwards stamp"; cat "$T/auto_swap.txt"; fails=$((fails + 1)); }
grep -q "auto's rate-pi candidate is not fitted" "$T/auto_swap.txt" ||
  { echo "FAIL: auto: no word on its rate-pi candidate"; cat "$T/auto_swap.txt"; fails=$((fails + 1)); }
printf 'p,y\n1,2\n' > "$T/onerow.csv"
expect_fail "evaluate on one row" 'too few to score' -- \
  "$BIN" evaluate --model "$T/good.json" --data "$T/onerow.csv" --input p --output y
[ "$(cat "$T/out/keep.csv" | wc -l)" -eq 4 ] || { echo "FAIL: keep.csv replaced"; fails=$((fails + 1)); }

if [ $fails -ne 0 ]; then echo "bad_input: $fails failures"; exit 1; fi
echo "bad_input: ok"
