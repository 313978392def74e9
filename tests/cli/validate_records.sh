#!/usr/bin/env bash
# A model checked on records other than its training one (fit --validate-data, evaluate): a
# validation record the model cannot be run on (an input beyond its bound) is never left out: it
# is listed with its error and counts as a useless validation (exit 3, the model still written).
# fit records the training error in the model file ("training"), and evaluate judges a record by it
# as fit judges a validation record: exit 3 on a record the model does not describe, nothing blamed
# on a unit or a zero on a short stretch (with or without "training"). A record whose input is in
# another zero (absolute against gauge pressure) or unit (MPa against kPa) is said to be so, not
# blamed on its output (the shared Festo records, transformed here; skipped where they are absent).
# Usage: bash validate_records.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

# two records of the same actuator (different amplitudes): a.csv, b.csv (t_s, p, y)
gpi_record_pair
# b with one input sample far beyond any model's input bound
$PY - "$T/b.csv" "$T/huge.csv" <<'PYEOF'
import sys
rows = open(sys.argv[1]).read().split("\n")
t, p, y = rows[500].split(",")
rows[500] = f"{t},1e307,{y}"
open(sys.argv[2], "w").write("\n".join(rows))
PYEOF

# 1. a --validate-data file the model cannot be run on: exit 3, the model written, a warning naming the
# file, the sample and the error, listed in the document with its error; `validate` is the first
# set's (null: it was not scored), never another file's
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/huge.csv" \
  --validate-data "$T/b.csv" --out "$T/m1.json" --report "$T/r1.json" > "$T/f1.txt" 2> "$T/f1.err"
rc=$?
[ $rc -eq 3 ] || fail "fit with an unrunnable validation record: exit $rc (expected 3): $(cat "$T/f1.txt" "$T/f1.err")"
[ -s "$T/m1.json" ] || fail "fit with an unrunnable validation record: no model written"
grep -q "warning: $T/huge.csv: the model cannot be run on this validation record (.*1e+307" "$T/f1.txt" \
  || fail "no warning naming the file and the sample: $(cat "$T/f1.txt")"
grep -q "validate: not scored: .*\[$T/huge.csv" "$T/f1.txt" || fail "no validate: line for the file: $(cat "$T/f1.txt")"
grep -q "the validation is useless: .*cannot be run on $T/huge.csv" "$T/f1.txt" || fail "no useless-validation warning"
$PY - "$T/r1.json" "$T/huge.csv" "$T/b.csv" <<'PYEOF' || fail "the document does not list the unrunnable set"
import json, math, sys
d = json.load(open(sys.argv[1]))
v = d["validate_files"]
assert [e["file"] for e in v] == sys.argv[2:], v
assert "1e+307" in v[0]["error"] and "input sample" in v[0]["error"], v[0]
assert v[0]["rms"] is None and v[0]["r2"] is None, v[0]
assert "error" not in v[1] and v[1]["rms"] > 0, v[1]
assert d["validate"] is None, d["validate"]   # the first set's: not scored
assert d["status"] == "converged" and d["model_written"], d["status"]
PYEOF
# the same with --json, and the HTML report, are as the JSON report
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/b.csv" \
  --validate-data "$T/huge.csv" --out "$T/m2.json" --json > "$T/f2.json" 2> "$T/f2.err"
rc=$?
[ $rc -eq 3 ] || fail "fit --json with an unrunnable validation record: exit $rc"
$PY - "$T/f2.json" <<'PYEOF' || fail "--json: the first set's figures are not validate's"
import json, sys
d = json.load(open(sys.argv[1]))
v = d["validate_files"]
assert len(v) == 2 and "error" in v[1] and "error" not in v[0], v
assert d["validate"]["rms"] == v[0]["rms"], (d["validate"], v[0])
assert any("cannot be run" in w for w in d["warnings"]), d["warnings"]
PYEOF
# a validation that can be run is scored as before: exit 0
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/b.csv" \
  --out "$T/m3.json" > "$T/f3.txt" 2>&1 || fail "fit with a good validation record: exit $?: $(cat "$T/f3.txt")"

# 2. the model file records the training error; evaluate judges a record against it
$PY - "$T/m3.json" "$T/r3.json" <<'PYEOF' || fail "the model file's training"
import json, sys
m = json.load(open(sys.argv[1]))
t = m["training"]
assert set(t) == {"rms", "r2", "samples"} and t["samples"] == 1800 and 0 < t["rms"] and t["r2"] <= 1, t
PYEOF
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --out "$T/m3.json" --json > "$T/f3.json" \
  || fail "fit --json"
$PY - "$T/m3.json" "$T/f3.json" "$T/m3_old.json" <<'PYEOF' || fail "the fit document's model is not the model file's"
import json, sys
m, d = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert d["model"]["training"] == m["training"], (d["model"]["training"], m["training"])
assert m["training"]["rms"] == d["train"]["rms"] and m["training"]["r2"] == d["train"]["r2"], d["train"]
del m["training"]   # a model file written before "training": still read, judged as before
json.dump(m, open(sys.argv[3], "w"))
PYEOF
# a short stretch near a turning point (30 samples, 11 % of the input range): R^2 < 0 there, but the
# RMS error is within twice the training one: no warning, exit 0; without "training": no unit or zero
# blamed (before: "differs ... by a scale (another unit, a gain) or a zero (a sensor offset)")
for m in m3 m3_old; do
  "$BIN" evaluate --model "$T/$m.json" --data "$T/b.csv" --input p --output y --range 400:430 > "$T/e_$m.txt" 2>&1
  rc=$?
  [ $rc -eq 0 ] || fail "evaluate $m on a short stretch: exit $rc: $(cat "$T/e_$m.txt")"
  grep -q "scale (another unit\|sensor offset\|sign flipped" "$T/e_$m.txt" && fail "evaluate $m on a short stretch blames the record: $(cat "$T/e_$m.txt")"
done
grep -q "warning" "$T/e_m3.txt" && fail "evaluate with training on a short stretch warns: $(cat "$T/e_m3.txt")"
grep -q "spans only 11.3 % of the model's input range" "$T/e_m3_old.txt" \
  || fail "evaluate without training on a short stretch: $(cat "$T/e_m3_old.txt")"
# a record the model does not describe (its output negated: a sensor mounted the other way): exit 3 with
# "training", the metrics printed as always; exit 0 without it (nothing to compare with), as before
$PY - "$T/b.csv" "$T/neg.csv" <<'PYEOF'
import sys
rows = [r for r in open(sys.argv[1]).read().split("\n") if r]
with open(sys.argv[2], "w") as f:
    f.write(rows[0] + "\n")
    for r in rows[1:]:
        t, p, y = r.split(",")
        f.write(f"{t},{p},{-float(y)!r}\n")
PYEOF
"$BIN" evaluate --model "$T/m3.json" --data "$T/neg.csv" --input p --output y > "$T/e4.txt" 2> "$T/e4.err"
rc=$?
[ $rc -eq 3 ] || fail "evaluate on a record the model does not describe: exit $rc (expected 3)"
grep -q "^evaluate: rms" "$T/e4.txt" || fail "evaluate exit 3: no metrics printed"
grep -q "the evaluation is useless: .*evaluate exits 3" "$T/e4.err" || fail "evaluate exit 3: $(cat "$T/e4.err")"
grep -q "sign flipped" "$T/e4.err" || fail "evaluate: the negated output not named: $(cat "$T/e4.err")"
"$BIN" evaluate --model "$T/m3.json" --data "$T/neg.csv" --input p --output y --json > "$T/e4.json" 2> /dev/null
[ $? -eq 3 ] || fail "evaluate --json on a record the model does not describe: not exit 3"
"$BIN" evaluate --model "$T/m3_old.json" --data "$T/neg.csv" --input p --output y > /dev/null 2>&1 \
  || fail "evaluate of a model file without training: exit $?"
# "training" is checked as strictly as the rest of the file
for bad in '{"rms": -1, "r2": 0.9, "samples": 10}' '{"rms": 1, "r2": 0.9}' '{"rms": 1, "r2": 0.9, "samples": 10, "x": 1}' \
  '{"rms": 1, "r2": 2, "samples": 10}' '{"rms": 1, "r2": 0.9, "samples": 1.5}' '"good"'; do
  $PY - "$T/m3.json" "$T/bad.json" "$bad" <<'PYEOF'
import json, sys
m = json.load(open(sys.argv[1]))
m["training"] = json.loads(sys.argv[3])
json.dump(m, open(sys.argv[2], "w"))
PYEOF
  "$BIN" evaluate --model "$T/bad.json" --data "$T/b.csv" --input p --output y > /dev/null 2> "$T/err"
  rc=$?
  [ $rc -eq 1 ] && grep -q 'training' "$T/err" || fail "training $bad: exit $rc: $(cat "$T/err")"
done

# 3. the input in another zero or unit: named (the Festo records: pressure [kPa] -> force [N])
D="${HYSTERON_SHARED_DATA:-$2/../shared/data}/pam-force-pressure"
if [ -f "$D/festo10mm_20cm_test8.csv" ] && [ -f "$D/festo10mm_20cm_test10.csv" ]; then
  $PY - "$D/festo10mm_20cm_test10.csv" "$T" <<'PYEOF'
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n") if r.strip()]
for name, f in (("abs", lambda p, y: (p + 101.325, y)), ("mpa", lambda p, y: (p / 1000, y)),
                ("yoff", lambda p, y: (p, y + 500.0))):
    with open(f"{sys.argv[2]}/t10_{name}.csv", "w") as o:  # as the file: force, pressure (no header)
        for r in rows:
            p, y = f(float(r[1]), float(r[0]))
            o.write(f"{y!r},{p!r}\n")
PYEOF
  "$BIN" fit --model kp --data "$D/festo10mm_20cm_test8.csv" --input 1 --output 0 --threads 1 --out "$T/kp.json" \
    --validate-data "$T/t10_abs.csv" > "$T/f5.txt" 2>&1
  grep -q "t10_abs.csv: the record's input matches the model's when shifted by -101.3 (another zero: absolute" \
    "$T/f5.txt" || fail "fit --validate-data absolute pressure: $(grep warning "$T/f5.txt")"
  for v in abs mpa yoff; do
    "$BIN" evaluate --model "$T/kp.json" --data "$T/t10_$v.csv" --input 1 --output 0 > /dev/null 2> "$T/e_$v.txt"
  done
  grep -q "shifted by -101.3 (another zero: absolute against gauge pressure" "$T/e_abs.txt" \
    || fail "evaluate absolute pressure: $(cat "$T/e_abs.txt")"
  grep -q "scaled by 1000 (another unit" "$T/e_mpa.txt" || fail "evaluate MPa: $(cat "$T/e_mpa.txt")"
  for v in abs mpa; do
    grep -q "sensor offset\|a scale (another unit, a gain)\|another actuator" "$T/e_$v.txt" \
      && fail "evaluate $v: the output blamed: $(cat "$T/e_$v.txt")"
  done
  grep -q "the record's output matches .* or a zero (a sensor offset)" "$T/e_yoff.txt" \
    || fail "evaluate with the output offset: $(cat "$T/e_yoff.txt")"
  grep -q "record's input matches" "$T/e_yoff.txt" && fail "evaluate with the output offset: the input blamed"
  # 4. narrow stretches (input spanning less than half the model's input range; review of 2026-12-01):
  # a flipped sign the map explains convincingly is named (test9 with its force negated, until its
  # pressure passes 260 kPa: only "R^2 ... say little" before), with the training error or without;
  # 100-sample windows of the training record itself are not blamed and never useless (exit 3 before)
  $PY - "$D/festo10mm_20cm_test9.csv" "$D/festo10mm_20cm_test8.csv" "$T" <<'PYEOF'
import json, sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n") if r.strip()]
k = next(i for i, r in enumerate(rows) if float(r[1]) > 260)
open(f"{sys.argv[3]}/k9.txt", "w").write(str(k))
with open(f"{sys.argv[3]}/neg9.csv", "w") as o:
    for r in rows:
        o.write(f"{-float(r[0])!r},{r[1]}\n")
m = json.load(open(f"{sys.argv[3]}/kp.json"))
del m["training"]
json.dump(m, open(f"{sys.argv[3]}/kp_nt.json", "w"))
PYEOF
  k9=$(cat "$T/k9.txt")
  for m in kp kp_nt; do
    "$BIN" evaluate --model "$T/$m.json" --data "$T/neg9.csv" --input 1 --output 0 --range 0:$k9 > /dev/null \
      2> "$T/e_n_$m.txt"
    rc=$?
    # with "training": useless (exit 3), the sign explaining the narrow stretch; without: exit 0
    [ $rc -eq "$([ $m = kp ] && echo 3 || echo 0)" ] || fail "$m: negated test9 on 0:$k9: exit $rc"
    grep -q "sign flipped" "$T/e_n_$m.txt" || fail "$m: negated test9 on 0:$k9: sign not named: $(cat "$T/e_n_$m.txt")"
    for s in 500 1400 2200; do
      "$BIN" evaluate --model "$T/$m.json" --data "$D/festo10mm_20cm_test8.csv" --input 1 --output 0 \
        --range $s:$((s + 100)) > /dev/null 2> "$T/e_w.txt"
      rc=$?
      [ $rc -eq 0 ] || fail "$m: test8 $s:$((s + 100)) (its own training record): exit $rc: $(cat "$T/e_w.txt")"
      grep -q "sign flipped\|sensor offset\|another unit" "$T/e_w.txt" \
        && fail "$m: test8 $s:$((s + 100)) blamed: $(cat "$T/e_w.txt")"
    done
  done
  # fit judges a narrow validation file alike (samples 500..600 of test8, its training record): not
  # useless (exit 0), its warning kept
  sed -n 501,600p "$D/festo10mm_20cm_test8.csv" > "$T/w500.csv"
  "$BIN" fit --model kp --data "$D/festo10mm_20cm_test8.csv" --input 1 --output 0 --threads 1 \
    --validate-data "$T/w500.csv" --out "$T/kp2.json" > "$T/f6.txt" 2>&1
  rc=$?
  [ $rc -eq 0 ] || fail "fit --validate-data a narrow window of the record: exit $rc: $(grep warning "$T/f6.txt")"
  grep -q "w500.csv: .* of the model's input range" "$T/f6.txt" || fail "fit narrow window: no warning"
else
  echo "validate_records: ../shared/data absent: the Festo records' input maps not checked"
fi

exit $fails
