#!/usr/bin/env bash
# A model checked on records other than its training one (fit --validate-data, evaluate): a
# validation record the model cannot be run on (an input beyond its bound) is never left out: it
# is listed with its error and counts as a useless validation (exit 3, the model still written).
# Usage: bash validate_records.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
# two records of the same actuator (different amplitudes)
$PY - "$T" <<'PYEOF'
import sys
for name, amps in (("a", (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)), ("b", (0.55, 0.35, 0.45, 0.15))):
    with open(f"{sys.argv[1]}/{name}_x.csv", "w") as f:
        f.write("p\n")
        for a in amps:
            for k in range(300):
                f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
for r in a b; do
  "$BIN" simulate --model "$T/gpi.json" --input "$T/${r}_x.csv" --output "$T/${r}_sim.csv" || fail "simulate $r"
  sed '1s/.*/p,y/' "$T/${r}_sim.csv" > "$T/$r.csv"
done
# b with one input sample far beyond any model's input bound
$PY - "$T/b.csv" "$T/huge.csv" <<'PYEOF'
import sys
rows = open(sys.argv[1]).read().split("\n")
p, y = rows[500].split(",")
rows[500] = f"1e307,{y}"
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

exit $fails
