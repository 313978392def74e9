#!/usr/bin/env bash
# hysteron rig: the nominal rig lists every parameter with its unit and its static map; a rig
# file is read as --plant reads it (a typo or an impossible value is exit 1 naming the key,
# nothing written); --out writes the complete rig, which reads back to the same parameters and
# is accepted by experiment; a horizontal rig without a spring is warned as the experiments
# refuse it, and with a spring its lift-off moves with the spring's preload; a weak return force
# is warned; --out naming stdout is handled as --out -.
# Usage: bash rig.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

"$BIN" rig > "$T/nominal.txt" 2> "$T/err.txt" || fail "nominal rig: exit $?"
for key in muscle.rest_length load.mass load.spring_rate sensors.displacement_bits simulation.dt; do
  grep -q "$key" "$T/nominal.txt" || fail "nominal rig: $key not listed"
done
grep -q "load.mass *20 kg" "$T/nominal.txt" || fail "nominal rig: load.mass without its unit: $(grep load.mass "$T/nominal.txt")"
grep -q '^  \*' "$T/nominal.txt" && fail "nominal rig: a parameter marked as changed"

# a typo and an impossible value: exit 1, the key named, --out not written
echo '{"load": {"mas": 35}}' > "$T/typo.json"
"$BIN" rig "$T/typo.json" --out "$T/full.json" > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "typo: exit $rc"
grep -q "did you mean 'mass'" "$T/err.txt" || fail "typo: $(cat "$T/err.txt")"
[ -e "$T/full.json" ] && fail "typo: --out written"
echo '{"load": {"spring_rate": -1}}' > "$T/neg.json"
"$BIN" rig "$T/neg.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "negative spring: not exit 1"
grep -q "load.spring_rate" "$T/err.txt" || fail "negative spring: $(cat "$T/err.txt")"
# a directory and a missing file: exit 1, said
"$BIN" rig "$T" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "directory: not exit 1"
grep -q "is a directory" "$T/err.txt" || fail "directory: $(cat "$T/err.txt")"
"$BIN" rig "$T/none.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "missing file: not exit 1"
grep -q "cannot open" "$T/err.txt" || fail "missing file: $(cat "$T/err.txt")"
# --out the input file itself: refused, the file kept
cp "$T/typo.json" "$T/same.json"
"$BIN" rig "$T/same.json" --out "$T/same.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "--out = FILE: not exit 1"
cmp -s "$T/typo.json" "$T/same.json" || fail "--out = FILE: the input changed"

# a changed rig: marked, written complete, read back the same, accepted by experiment
echo '{"load": {"mass": 35}, "muscle": {"rest_length": 0.6}}' > "$T/heavy.json"
"$BIN" rig "$T/heavy.json" --out "$T/full.json" > "$T/heavy.txt" 2> /dev/null || fail "heavy: exit $?"
grep -q '^  \*load.mass *35 kg' "$T/heavy.txt" || fail "heavy: load.mass not marked: $(grep load.mass "$T/heavy.txt")"
"$BIN" rig "$T/full.json" --json > "$T/a.json" || fail "full: exit $?"
"$BIN" rig "$T/heavy.json" --json > "$T/b.json" || fail "heavy --json: exit $?"
$PY - "$T/a.json" "$T/b.json" "$T/full.json" <<'PYEOF' || fail "round trip"
import json, sys
a, b, full = (json.load(open(f)) for f in sys.argv[1:])
assert a["parameters"] == b["parameters"], "the written rig reads back differently"
n = sum(len(v) for v in full.values())
assert n == len(a["units"]) and n >= 50, (n, len(a["units"]))
assert a["parameters"]["load"]["mass"] == 35 and a["parameters"]["muscle"]["rest_length"] == 0.6
s = a["statics"]
assert abs(s["return_force_rest_n"] - 35 * 9.81) < 1e-9, s["return_force_rest_n"]
assert abs(s["fall_speed_rest_m_s"] - 35 * 9.81 / 400) < 1e-9, s["fall_speed_rest_m_s"]
assert s["unusable"] == ""
rising = s["rising_m"]
assert len(rising) == len(s["pressure_pa"]) == len(s["falling_m"])
assert rising == sorted(rising) and rising[-1] > 0, rising
PYEOF
"$BIN" experiment gpi-pid --plant "$T/full.json" --learning-periods 0 --no-adaptive > /dev/null 2> "$T/err.txt" \
  || fail "experiment on the written rig: $(cat "$T/err.txt")"

# horizontal: without a spring warned (and refused by experiment), with one the preload sets lift-off
echo '{"load": {"gravity": 0}}' > "$T/flat.json"
"$BIN" rig "$T/flat.json" > "$T/flat.txt" 2> "$T/flat.err" || fail "flat: exit $?"
grep -q "^rig: warning: the experiments refuse this rig: rig.load.gravity = 0 with no return spring" "$T/flat.err" \
  || fail "flat: no warning on stderr: $(cat "$T/flat.err")"
"$BIN" rig "$T/flat.json" --json 2> "$T/flat.err" | $PY -c 'import json, sys; json.load(sys.stdin)' \
  || fail "flat --json: not one JSON document on stdout"
grep -q "^rig: warning: the experiments refuse this rig" "$T/flat.err" || fail "flat --json: no warning on stderr"
"$BIN" experiment gpi-pid --plant "$T/flat.json" --learning-periods 0 > /dev/null 2>&1 && fail "flat: experiment ran"
echo '{"load": {"gravity": 0, "spring_preload": 98.1}}' > "$T/half.json"
echo '{"load": {"gravity": 0, "spring_preload": 392.4}}' > "$T/double.json"
"$BIN" rig "$T/half.json" --json > "$T/half.out" || fail "half: exit $?"
"$BIN" rig "$T/double.json" --json > "$T/double.out" || fail "double: exit $?"
$PY - "$T/half.out" "$T/double.out" <<'PYEOF' || fail "horizontal spring rigs"
import json, sys
h, d = (json.load(open(f))["statics"] for f in sys.argv[1:])
assert h["weight_n"] == 0 and abs(h["return_force_rest_n"] - 98.1) < 1e-9
assert h["lift_off_pa"] < d["lift_off_pa"], (h["lift_off_pa"], d["lift_off_pa"])
assert h["unusable"] == ""
PYEOF
# a load the muscle cannot lift: warned, and said by experiment; a spring too stiff to simulate: exit 1
echo '{"load": {"spring_preload": 5000}}' > "$T/heavy2.json"
"$BIN" rig "$T/heavy2.json" > "$T/heavy2.txt" 2> "$T/heavy2.err" || fail "heavy2: exit $?"
grep -q "^rig: warning: the experiments refuse this rig: the muscle cannot lift its load" "$T/heavy2.err" \
  || fail "heavy2: no warning on stderr"
"$BIN" experiment gpi-pid --plant "$T/heavy2.json" --learning-periods 0 > /dev/null 2> "$T/err.txt" && fail "heavy2 ran"
grep -q "the muscle cannot lift its load" "$T/err.txt" || fail "heavy2 experiment: $(cat "$T/err.txt")"
echo '{"load": {"spring_rate": 1e14}}' > "$T/stiff.json"
"$BIN" rig "$T/stiff.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "stiff: not exit 1"
grep -q "load.spring_rate 1e+14" "$T/err.txt" || fail "stiff: $(cat "$T/err.txt")"

# a weak return force (horizontal, 1 N preload): the creep element holds the vented muscle near the top
# (docs/plant.md, "A weak return force"): warned on stderr, and in --json; the stall is where the creep's
# pull, 150 N/m x (top - x), meets the 1 N (the vented muscle pulls nothing there): top - 1/150 m
echo '{"load": {"gravity": 0, "spring_preload": 1}}' > "$T/weak.json"
"$BIN" rig "$T/weak.json" > "$T/weak.txt" 2> "$T/err.txt" || fail "weak: exit $?"
grep -q "^rig: warning: the return force is weak against the creep element" "$T/err.txt" \
  || fail "weak: no warning on stderr: $(cat "$T/err.txt")"
"$BIN" rig "$T/weak.json" --json > "$T/weak.out" 2> /dev/null || fail "weak --json: exit $?"
$PY - "$T/weak.out" "$T/half.out" "$T/a.json" <<'PYEOF' || fail "weak return in --json"
import json, sys
w, h, a = (json.load(open(f))["statics"] for f in sys.argv[1:])
assert w["weak_return"].startswith("the return force is weak"), w["weak_return"]
assert abs(w["vented_stall_m"] - (w["rising_m"][-1] - 1 / 150)) < 1e-6, w["vented_stall_m"]
assert abs(w["creep_return_speed_m_s"] - 1 / (400 + 150 * 4)) < 1e-12, w["creep_return_speed_m_s"]
assert h["weak_return"] == "" and a["weak_return"] == "", (h["weak_return"], a["weak_return"])
PYEOF
# ... where no loop gets the vented muscle down: the compensation is not below the baseline, so
# experiment exits 3 naming the run (README, Exit codes), with its results written all the same
"$BIN" experiment gpi-pid --plant "$T/weak.json" --learning-periods 0 --no-adaptive --out "$T/weak_run" \
  > "$T/weak_exp.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 3 ] || fail "weak experiment: exit $rc, not 3"
grep -q "^experiment: gpi-pid: not below the baseline's RMS error: compensated (sine)" "$T/err.txt" \
  || fail "weak experiment: stderr $(cat "$T/err.txt")"
grep -q "NOT BELOW THE BASELINE: compensated (sine)" "$T/weak_exp.txt" || fail "weak experiment: table"
$PY -c 'import json, sys; j = json.load(open(sys.argv[1])); assert j["status"] == "not_below_baseline", j["status"]' \
  "$T/weak_run/result.json" || fail "weak experiment: result.json"
grep -q "<strong>Not below the baseline:</strong> compensated (sine)" "$T/weak_run/report.html" \
  || fail "weak experiment: report.html"
"$BIN" rig "$T/half.json" > /dev/null 2> "$T/err.txt" || fail "half: exit $?"
[ -s "$T/err.txt" ] && fail "half: warned: $(cat "$T/err.txt")"

# --out naming stdout (/dev/stdout, or the file stdout is redirected to) is handled as --out -: with
# --json refused (two JSON documents), without it the template alone on stdout
"$BIN" rig --json --out /dev/stdout > "$T/two.out" 2> "$T/err.txt"
[ $? -eq 1 ] || fail "--json --out /dev/stdout: not exit 1"
grep -q "both print on stdout" "$T/err.txt" || fail "--json --out /dev/stdout: $(cat "$T/err.txt")"
[ -s "$T/two.out" ] && fail "--json --out /dev/stdout: stdout written: $(head -c 200 "$T/two.out")"
"$BIN" rig --json --out "$T/same.out" > "$T/same.out" 2> "$T/err.txt"
[ $? -eq 1 ] || fail "--json --out (stdout's file): not exit 1"
grep -q "both print on stdout" "$T/err.txt" || fail "--json --out (stdout's file): $(cat "$T/err.txt")"
"$BIN" rig --out /dev/stdout > "$T/one.out" 2> /dev/null || fail "--out /dev/stdout: exit $?"
"$BIN" rig --out - > "$T/dash.out" 2> /dev/null || fail "--out -: exit $?"
cmp -s "$T/one.out" "$T/dash.out" || fail "--out /dev/stdout differs from --out -: $(tail -3 "$T/one.out")"
$PY -c 'import json, sys; json.load(open(sys.argv[1]))' "$T/one.out" || fail "--out /dev/stdout: not one JSON document"
# the null device as both is no conflict: nothing reads the two documents
"$BIN" rig --json --out /dev/null > /dev/null 2> "$T/err.txt" || fail "--json --out /dev/null > /dev/null: $(cat "$T/err.txt")"

[ $fails -eq 0 ] && echo "rig.sh: all passed"
exit $((fails > 0))
