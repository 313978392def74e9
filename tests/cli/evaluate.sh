#!/usr/bin/env bash
# hysteron evaluate: fit a model, then score it on the same and on new data. Checks that
# evaluate reproduces the fit's own validation numbers, that a model scores far worse on
# a record of another actuator, --model - (stdin), --json (one document), the HTML/JSON
# reports, and the exit codes (0 evaluated, 1 bad input or usage, 3 useless against the model
# file's training error).
# Usage: bash evaluate.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
cat > "$T/other.json" <<'JSON'
{"model": "gpi", "c": [40, 6, -0.3, 20], "q": 1.5, "n": 10, "rho": 0.1, "tau": 0.5, "alpha": 3}
JSON
$PY - "$T/x.csv" <<'PYEOF'
import sys
with open(sys.argv[1], "w") as f:
    f.write("pressure\n")
    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1):
        for k in range(300):
            f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/data.csv" || fail "simulate"
"$BIN" simulate --model "$T/other.json" --input "$T/x.csv" --output "$T/new.csv" || fail "simulate other"
# a time column (10 ms samples) for the seconds ranges
$PY - "$T/data.csv" "$T/data_t.csv" <<'PYEOF'
import sys
rows = open(sys.argv[1]).read().split("\n")[1:]
with open(sys.argv[2], "w") as f:
    f.write("t_s,input,output\n")
    for i, r in enumerate(x for x in rows if x):
        f.write(f"{i * 0.01!r},{r}\n")
PYEOF

"$BIN" fit --model gpi --data "$T/data.csv" --input input --output output --train 0:1200 --threads 1 \
  --out "$T/m.json" --report "$T/fit.json" > "$T/fit.txt"
rc=$?
[ $rc -eq 0 ] || fail "fit exit $rc"
[ -s "$T/m.json" ] || fail "fit wrote no model"

# --report naming stdout (/dev/stdout, or the file stdout is redirected to) with --json: refused as --report -
for r in - /dev/stdout "$T/ev2.json"; do
  "$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output output --json --report "$r" \
    > "$T/ev2.json" 2> "$T/err"
  [ $? -eq 1 ] || fail "--report $r with --json: not exit 1"
  grep -q "both write to standard output" "$T/err" || fail "--report $r with --json: $(cat "$T/err")"
done

# 1. evaluate on the validation range reproduces the fit's validation metrics
"$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output output --range 1200:1800 --json \
  > "$T/ev.json"
rc=$?
[ $rc -eq 0 ] || fail "evaluate exit $rc"
$PY - "$T/fit.json" "$T/ev.json" <<'PYEOF' || fail "evaluate numbers differ from the fit's validation"
import json, sys
fit = json.load(open(sys.argv[1]))
ev = json.load(open(sys.argv[2]))   # --json: exactly one document
assert ev["format"] == "hysteron-evaluation", ev.get("format")
v = fit["validate"]
m = ev["metrics"]
assert m["n"] == 600 == v["n"], (m["n"], v["n"])
for k in ("rms", "max", "mae", "rms_percent_span", "r2"):
    assert abs(m[k] - v[k]) <= 1e-12 * max(1.0, abs(v[k])), (k, m[k], v[k])
assert m["range"] == [1200, 1800], m["range"]
# a good model: below 0.5 % of the span on data it has not seen
assert m["rms_percent_span"] < 0.5, m
print("evaluate == fit validation: rms", m["rms"])
PYEOF

# 1b. the same record with its output negated, or offset: scored as it is, and the warning says the
# record's output matches the prediction by a sign / a zero; the record itself gets no such warning.
# Both score worse than their mean with more than twice the training RMS error that the model file
# records ("training"): exit 3, as fit --validate-data (exit 0 before 2026-12-01)
$PY - "$T/data.csv" "$T/neg.csv" "$T/off.csv" <<'PYEOF'
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n")[1:] if r]
ys = [float(r[1]) for r in rows]
span = max(ys) - min(ys)
for name, f in ((sys.argv[2], lambda v: -v), (sys.argv[3], lambda v: v + 0.3 * span)):
    with open(name, "w") as o:
        o.write("input,output\n")
        for r in rows:
            o.write(f"{r[0]},{f(float(r[1]))!r}\n")
PYEOF
"$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output output > /dev/null 2> "$T/err" \
  || fail "evaluate own record: exit $?"
grep -q "the record's output matches" "$T/err" && fail "own record: an output-map warning: $(cat "$T/err")"
"$BIN" evaluate --model "$T/m.json" --data "$T/neg.csv" --input input --output output --json > "$T/ev_neg.json" \
  2> "$T/err"
rc=$?
[ $rc -eq 3 ] || fail "evaluate negated: exit $rc (expected 3)"
grep -q "^warning: $T/neg.csv: the record's output matches -1 x the model's prediction.*is its sign flipped" "$T/err" \
  || fail "negated: no sign warning: $(cat "$T/err")"
$PY -c 'import json, sys; m = json.load(open(sys.argv[1]))["metrics"]["output_map"]; assert abs(m["gain"] + 1) < 1e-3 and m["r2"] < 0 < 0.99 < m["r2_mapped"], m' \
  "$T/ev_neg.json" || fail "negated: output_map in --json"
# the document records the warnings and the verdict (useless: exit 3), and the HTML page shows them
$PY -c 'import json, sys; d = json.load(open(sys.argv[1])); assert d["useless"] is True and any("sign flipped" in w for w in d["warnings"]), (d.get("useless"), d.get("warnings"))' \
  "$T/ev_neg.json" || fail "negated: warnings / useless in --json"
$PY -c 'import json, sys; d = json.load(open(sys.argv[1])); assert d["useless"] is False and d["warnings"] == [], d' \
  "$T/ev.json" || fail "own record: warnings / useless in --json"
"$BIN" evaluate --model "$T/m.json" --data "$T/neg.csv" --input input --output output --report "$T/ev_neg.html" \
  > /dev/null 2>&1
grep -q "is its sign flipped" "$T/ev_neg.html" && grep -q "The evaluation is useless" "$T/ev_neg.html" \
  || fail "negated: the HTML report does not show the warnings"
"$BIN" report "$T/ev_neg.json" --out "$T/ev_neg2.html" > /dev/null 2>&1
grep -q "is its sign flipped" "$T/ev_neg2.html" || fail "report ev_neg.json: the page does not show the warnings"
"$BIN" evaluate --model "$T/m.json" --data "$T/off.csv" --input input --output output > /dev/null 2> "$T/err"
rc=$?
[ $rc -eq 3 ] || fail "evaluate offset: exit $rc (expected 3)"
grep -q "the record's output matches 1 x the model's prediction +.*or a zero (a sensor offset)" "$T/err" \
  || fail "offset: no zero warning: $(cat "$T/err")"
# fit --validate-data says the same of a validation record, in its warnings; the validation as it
# is scores R^2 far below 0 (useless): exit 3, the model written (record_columns.sh)
"$BIN" fit --model gpi --data "$T/data.csv" --input input --output output --train 0:1200 --threads 1 \
  --validate-data "$T/neg.csv" --out "$T/m2.json" --report "$T/fit2.json" > "$T/fit2.txt" 2> "$T/err"
rc=$?
[ $rc -eq 3 ] || fail "fit2: exit $rc (expected 3: a validation with R^2 <= 0)"
[ -s "$T/m2.json" ] || fail "fit2: the model was not written"
grep -q "^warning: $T/neg.csv: the record's output matches .*is its sign flipped" "$T/fit2.txt" \
  || fail "fit --validate-data negated: $(cat "$T/fit2.txt")"
$PY -c 'import json, sys; d = json.load(open(sys.argv[1])); assert any("sign flipped" in w for w in d["warnings"]), d["warnings"]' \
  "$T/fit2.json" || fail "fit --validate-data negated: the report's warnings"

# 2. the same model on another actuator's record is much worse (the numbers are real): exit 3
"$BIN" evaluate --model "$T/m.json" --data "$T/new.csv" --input input --output output --json > "$T/ev_new.json" \
  2> /dev/null
rc=$?
[ $rc -eq 3 ] || fail "evaluate on new data: exit $rc (expected 3: useless against the training error)"
$PY - "$T/ev.json" "$T/ev_new.json" <<'PYEOF' || fail "a wrong model does not score worse"
import json, sys
good = json.load(open(sys.argv[1]))["metrics"]
bad = json.load(open(sys.argv[2]))["metrics"]
assert bad["n"] == 1800, bad["n"]
assert bad["rms"] > 20 * good["rms"], (bad["rms"], good["rms"])
PYEOF

# 3. --model - reads the model from stdin; the text summary names the range and the numbers
"$BIN" evaluate --model - --data "$T/data.csv" --input input --output output --train 1200:1800 \
  < "$T/m.json" > "$T/ev.txt" || fail "evaluate --model -"
grep -q "^evaluate: rms " "$T/ev.txt" || fail "no evaluate: line"
grep -q "samples 1200..1800" "$T/ev.txt" || fail "range not named"
# fit --out - | evaluate --model -: a pipe of model JSON only
"$BIN" fit --model pi --data "$T/data.csv" --input input --output output --train 0:1200 --threads 1 --force \
  --out - 2> "$T/pipe.err" | "$BIN" evaluate --model - --data "$T/data.csv" --input input --output output > "$T/pipe.txt"
grep -q "^evaluate: rms " "$T/pipe.txt" || fail "fit --out - | evaluate --model -: $(cat "$T/pipe.txt")"
grep -q "pi fit" "$T/pipe.err" || fail "fit --out -: the summary is not on stderr"

# 4. reports: HTML by extension (loops, output, residuals against time), JSON otherwise
"$BIN" evaluate --model "$T/m.json" --data "$T/data_t.csv" --input input --output output --time-column t_s \
  --range 12s:17s --report "$T/ev.html" --input-label "Pressure [MPa]" --output-label "Contraction [mm]" > /dev/null \
  || fail "evaluate --report html"
[ "$(grep -o '<svg' "$T/ev.html" 2>/dev/null | wc -l)" -eq 3 ] || fail "evaluate html: expected 3 figures"
grep -q "Pressure \[MPa\]" "$T/ev.html" || fail "evaluate html: input label"
grep -q "Time \[s\]" "$T/ev.html" || fail "evaluate html: time axis"
grep -q "samples 1200..1700" "$T/ev.html" || fail "evaluate html: 12s:17s is samples 1200..1700"
# a half-open range in seconds may end one sample step past the last stamp (17.99 s): the record's end
"$BIN" evaluate --model "$T/m.json" --data "$T/data_t.csv" --input input --output output --time-column t_s \
  --range 12s:18s > "$T/end.txt" || fail "evaluate --range 12s:18s (the end one step past the last stamp)"
grep -q "samples 1200..1800" "$T/end.txt" || fail "12s:18s is samples 1200..1800: $(cat "$T/end.txt")"
"$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output output --report "$T/ev2.json" \
  > /dev/null || fail "evaluate --report json"
$PY -c "import json,sys; d=json.load(open(sys.argv[1])); assert d['metrics']['n'] == 1800" "$T/ev2.json" \
  || fail "evaluate json report"

# 5. errors: exit 1 with a message naming what and where; no report left behind
expect_rc1() {
  local what=$1 needle=$2
  shift 2
  "$@" > "$T/out" 2> "$T/err"
  local rc=$?
  if [ $rc -ne 1 ]; then fail "$what: exit $rc (expected 1)"; return; fi
  grep -qF -- "$needle" "$T/err" || fail "$what: stderr lacks '$needle': $(cat "$T/err")"
}
expect_rc1 "missing model file" "nope.json" \
  "$BIN" evaluate --model "$T/nope.json" --data "$T/data.csv" --input input --output output --report "$T/x.html"
[ -e "$T/x.html" ] && fail "a report was written for a failed evaluate"
expect_rc1 "unknown column" "no column named" \
  "$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output force
expect_rc1 "mixed units in a range" "mixes seconds and sample indices" \
  "$BIN" evaluate --model "$T/m.json" --data "$T/data_t.csv" --input input --output output --time-column t_s --range 0s:10
expect_rc1 "a range ending beyond the record" "time 18.5 s is outside the record" \
  "$BIN" evaluate --model "$T/m.json" --data "$T/data_t.csv" --input input --output output --time-column t_s \
  --range 12s:18.5s
expect_rc1 "empty stdin" "standard input is empty" \
  "$BIN" evaluate --model - --data "$T/data.csv" --input input --output output < /dev/null
expect_rc1 "usage error (CLI11)" "--bogus" \
  "$BIN" evaluate --model "$T/m.json" --data "$T/data.csv" --input input --output output --bogus
expect_rc1 "missing required option (CLI11)" "--data" \
  "$BIN" evaluate --model "$T/m.json" --input input --output output
"$BIN" evaluate --help > /dev/null 2>&1 || fail "evaluate --help exits non-zero"

# a model fitted on the two smallest loops (input up to 0.2) scored on the whole record (up to
# 0.6): a warning says how much of it lies outside the fitted input range, the document counts
# them, the exit stays 0; on its own range: no warning. fit's --validate says the same.
"$BIN" fit --model gpi --data "$T/data.csv" --input input --output output --train 1200:1800 --threads 1 \
  --out "$T/small.json" --force > /dev/null 2>&1 || fail "fit on the small loops"
"$BIN" evaluate --model "$T/small.json" --data "$T/data.csv" --input input --output output --json \
  > "$T/cov.json" 2> "$T/cov.err" || fail "evaluate beyond the fitted range: non-zero exit"
grep -q "of the 1800 scored samples .* have an input outside the model's input_limits \[0, 0.2\]" "$T/cov.err" \
  || { fail "no coverage warning:"; cat "$T/cov.err"; }
$PY - "$T/cov.json" "$T/data.csv" "$T/small.json" <<'PYEOF' || fail "outside_input_limits in the document"
import csv, json, sys
n = json.load(open(sys.argv[1]))["metrics"]["outside_input_limits"]
x = [float(r["input"]) for r in csv.DictReader(open(sys.argv[2]))]
lo, hi = json.load(open(sys.argv[3]))["input_limits"]  # the small loops' range, about [0, 0.2]
assert abs(lo) < 1e-12 and abs(hi - 0.2) < 1e-12, (lo, hi)
expected = sum(max(lo - v, v - hi) > 0.02 * (hi - lo) for v in x)  # beyond by more than 2 % of the span
assert n == expected > 500, (n, expected)
PYEOF
"$BIN" evaluate --model "$T/small.json" --data "$T/data.csv" --input input --output output --range 1200:1800 \
  > /dev/null 2> "$T/cov2.err" || fail "evaluate on the fitted range"
grep -q "outside the model's input_limits" "$T/cov2.err" && fail "coverage warning on the fitted range itself"
"$BIN" fit --model gpi --data "$T/data.csv" --input input --output output --train 1200:1800 --validate 0:1200 \
  --threads 1 --out "$T/small2.json" --force > "$T/cov3.txt" 2>&1
grep -q "validation range: .* outside the model's input_limits" "$T/cov3.txt" \
  || { fail "fit --validate beyond the training range: no warning"; cat "$T/cov3.txt"; }

if [ $fails -ne 0 ]; then echo "evaluate: $fails failures"; exit 1; fi
echo "evaluate: ok"
