#!/usr/bin/env bash
# The time base: a rig whose simulation.dt does not divide the 1 ms control period is refused by
# experiment, demo and sweep (exit 1, before anything runs, naming both values and the nearest
# dt that divides the period) and warned by `rig`; a dt that divides it runs.
# Usage: bash time_base.sh <hysteron-binary> <source-dir>
set -uo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
PY=/usr/bin/python3

# ---- F1: the rig's dt against the control period ----
"$BIN" rig -o - > "$T/rig.json" || fail "rig -o -: exit $?"
set_dt() { $PY -c "import json,sys; j=json.load(open(sys.argv[1])); j['simulation']['dt']=float(sys.argv[2]); json.dump(j,open(sys.argv[3],'w'))" "$T/rig.json" "$1" "$2"; }
set_dt 9.52e-5 "$T/rig952.json"
set_dt 5e-5 "$T/rig5.json"
# 1e-3 / 9.52e-5 = 10.504 steps; the dts dividing 1 ms nearest it: 1e-3/10 = 1e-4 (4.8e-6 away) and
# 1e-3/11 = 9.0909e-5 (4.3e-6 away): the nearest is 9.09091e-05 s
check_refusal() {  # $1: what, $2: stderr file
  grep -q "0.001 s" "$2" || fail "$1: the control period not named: $(cat "$2")"
  grep -q "9.52e-05 s" "$2" || fail "$1: the rig's dt not named: $(cat "$2")"
  grep -q "nearest dt that divides it is 9.09091e-05 s" "$2" || fail "$1: no nearest dt: $(cat "$2")"
}
"$BIN" experiment gpi-pid --model gpi --learning-periods 0 --no-adaptive --plant "$T/rig952.json" --out "$T/ex952" \
  > "$T/out.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "experiment on dt 9.52e-5: exit $rc (expected 1)"
check_refusal "experiment" "$T/err.txt"
[ -e "$T/ex952/result.json" ] && fail "experiment on dt 9.52e-5: result.json written"
# the tracking rig is checked too
"$BIN" experiment gpi-pid --model gpi --learning-periods 0 --no-adaptive --tracking-plant "$T/rig952.json" \
  > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "experiment, tracking rig on dt 9.52e-5: exit $rc (expected 1)"
grep -q "tracking rig" "$T/err.txt" || fail "tracking rig not named: $(cat "$T/err.txt")"
check_refusal "experiment --tracking-plant" "$T/err.txt"
"$BIN" demo --model gpi --learning-periods 0 --plant "$T/rig952.json" --out "$T/demo952" > "$T/out.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "demo on dt 9.52e-5: exit $rc (expected 1)"
check_refusal "demo" "$T/err.txt"
ls "$T"/demo952/*/result.json > /dev/null 2>&1 && fail "demo on dt 9.52e-5: a result written"
"$BIN" sweep gpi-pid --model gpi --learning-periods 0 --plant "$T/rig952.json" --vary load.mass=25 > "$T/out.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "sweep --plant dt 9.52e-5: exit $rc (expected 1)"
grep -q "base rig" "$T/err.txt" || fail "sweep: the base rig not named: $(cat "$T/err.txt")"
check_refusal "sweep --plant" "$T/err.txt"
"$BIN" sweep gpi-pid --model gpi --learning-periods 0 --vary simulation.dt=9.52e-5 > "$T/out.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "sweep --vary simulation.dt=9.52e-5: exit $rc (expected 1)"
grep -q "variant" "$T/err.txt" || fail "sweep: the variant not named: $(cat "$T/err.txt")"
check_refusal "sweep --vary" "$T/err.txt"
[ -s "$T/out.txt" ] && fail "sweep --vary: a table printed: $(head -3 "$T/out.txt")"
"$BIN" rig "$T/rig952.json" > /dev/null 2> "$T/err.txt" || fail "rig on dt 9.52e-5: exit $?"
grep -q "^rig: warning: the experiments refuse this rig: .*nearest dt that divides it is 9.09091e-05 s" "$T/err.txt" \
  || fail "rig: no warning: $(cat "$T/err.txt")"
# a dt that divides the period: runs, the results at 1 ms
"$BIN" experiment gpi-pid --model gpi --learning-periods 0 --no-adaptive --plant "$T/rig5.json" --out "$T/ex5" \
  > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -le 0 ] || [ $rc -eq 3 ] || fail "experiment on dt 5e-5: exit $rc: $(cat "$T/err.txt")"
$PY - "$T/ex5/tracking_faithful_sine.csv" <<'PYEOF' || fail "dt 5e-5: the loop not at 1 ms"
import csv, sys
t = [float(r["t_s"]) for r in csv.DictReader(open(sys.argv[1]))]
steps = {round(b - a, 9) for a, b in zip(t, t[1:])}
assert steps == {0.001}, sorted(steps)[:5]
PYEOF
"$BIN" rig "$T/rig5.json" > /dev/null 2> "$T/err.txt"
grep -q "control period" "$T/err.txt" && fail "rig on dt 5e-5 warned: $(cat "$T/err.txt")"

[ $fails -eq 0 ] && echo "time_base: all passed"
exit $fails
