#!/usr/bin/env bash
# hysteron sweep: bad input (unknown parameter paths with the closest names, bad values,
# unknown experiments and sets, grid files, outputs equal to inputs) is exit 1 with nothing
# written; a tiny sweep (gpi-pid on the nominal rig and 35 kg, plus a regulator whose air
# dynamics need more sub-steps than allowed, which fails at once) writes the CSV table, the
# HTML page and one JSON document, records the failure and exits 2; a sweep whose only
# variant is the nominal rig exits 0. Learning runs are switched off (--learning-periods 0) for speed.
# Usage: bash sweep.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail, expect_error

expect_error "typo in a path" "unknown rig parameter 'load.mas' (did you mean load.mass?)" \
  "$BIN" sweep gpi-pid --vary load.mas=10,35 --out "$T/bad.csv"
expect_error "bare key" "load.mass" "$BIN" sweep gpi-pid --vary mass=10
expect_error "NaN value" "load.mass: 'nan' is not a finite number" "$BIN" sweep gpi-pid --vary load.mass=nan
expect_error "value with a unit" "'35kg' is not a finite number" "$BIN" sweep gpi-pid --vary load.mass=35kg
expect_error "empty value" "an empty value" "$BIN" sweep gpi-pid --vary load.mass=10,,35
expect_error "value the rig refuses" "load.mass = -5" "$BIN" sweep gpi-pid --vary load.mass=-5
expect_error "pair with one value" "1 value(s) for 2 parameter(s)" \
  "$BIN" sweep gpi-pid --vary regulator.time_constant/regulator.dead_time=0.1
expect_error "unknown experiment" "unknown experiment 'gpi-pd' (did you mean gpi-pid?)" \
  "$BIN" sweep gpi-pd --vary load.mass=35
expect_error "no variants" "no variants" "$BIN" sweep gpi-pid
expect_error "unknown set" "--set worst: unknown set" "$BIN" sweep gpi-pid --set worst
expect_error "jobs 0" "--jobs" "$BIN" sweep gpi-pid --vary load.mass=35 --jobs 0
expect_error "jobs -1" "--jobs" "$BIN" sweep gpi-pid --vary load.mass=35 --jobs -1
expect_error "learning periods" "--learning-periods" "$BIN" sweep gpi-pid --vary load.mass=35 --learning-periods 1001
expect_error "mistyped option" "unknown option --vray (did you mean --vary?)" "$BIN" sweep gpi-pid --vray load.mass=35
cat > "$T/grid_bad.json" <<'JSON'
{"variants": [{"name": "heavy", "set": {"load.mass": 35}}, {"set": {"load.damping": 200}, "nmae": "x"}]}
JSON
expect_error "grid: unknown key" "grid_bad.json.variants[1]: unknown key 'nmae'" "$BIN" sweep gpi-pid --grid "$T/grid_bad.json"
cat > "$T/grid_bad2.json" <<'JSON'
{"variants": [{"set": {"load.mass": 35}}, {"set": {"loads.damping": 200}}]}
JSON
expect_error "grid: unknown path" "unknown rig parameter 'loads.damping' (did you mean load.damping?)" \
  "$BIN" sweep gpi-pid --grid "$T/grid_bad2.json"
printf '{"variants": [{"set": {"load.mass": 35, "load.mass": 10}}]}\n' > "$T/grid_bad3.json"
expect_error "grid: repeated key" "load.mass" "$BIN" sweep gpi-pid --grid "$T/grid_bad3.json"
expect_error "output is the grid" "--grid" "$BIN" sweep gpi-pid --grid "$T/grid_bad.json" --out "$T/grid_bad.json"
grep -q nmae "$T/grid_bad.json" || fail "the grid file was overwritten"
# where the outputs go is checked before anything runs (an unknown experiment would fail at once:
# the destination's error shows that it came first)
expect_error "table into a missing directory" "--out $T/missing/t.csv: directory $T/missing does not exist" \
  "$BIN" sweep gpi-pd --vary load.mass=35 --out "$T/missing/t.csv"
expect_error "page into a missing directory" "--report $T/missing/t.html: directory" \
  "$BIN" sweep gpi-pd --vary load.mass=35 --report "$T/missing/t.html"
[ ! -e "$T/missing" ] || fail "a refused sweep created its output directory"
# an output naming stdout (/dev/stdout here: stdout is $T/out.txt) is handled as -, before anything runs
expect_error "--json --out /dev/stdout" "--json and --out /dev/stdout both write to stdout" \
  "$BIN" sweep gpi-pid --vary load.mass=35 --json --out /dev/stdout
expect_error "--json --out (stdout's file)" "both write to stdout" \
  "$BIN" sweep gpi-pid --vary load.mass=35 --json --out "$T/out.txt"
expect_error "--report /dev/stdout" "--report /dev/stdout: the HTML page needs a file of its own, not stdout" \
  "$BIN" sweep gpi-pid --vary load.mass=35 --report /dev/stdout
[ ! -e "$T/bad.csv" ] || fail "a failed sweep wrote its table"
ls -A "$T" | grep -q '^\.' && fail "temporary files left: $(ls -A "$T")"

# the tiny sweep: 2 rigs run (nominal, 35 kg), one variant fails at construction
printf '{"simulation": {"max_substeps": 1}}\n' > "$T/base.json"
"$BIN" sweep gpi-pid --plant "$T/base.json" --vary load.mass=35 --vary regulator.sonic_conductance=1e-5 \
  --jobs 2 --learning-periods 0 --out "$T/sweep.csv" --report "$T/sweep.html" --json > "$T/sweep.json" 2> "$T/sweep.err"
rc=$?
[ $rc -eq 2 ] || fail "sweep with a failing variant: exit $rc, expected 2 ($(cat "$T/sweep.err"))"
grep -q "1 of 3 run(s) failed" "$T/sweep.err" || fail "no failure summary on stderr: $(cat "$T/sweep.err")"
[ "$(grep -c '^sweep: [123]/3 gpi-pid' "$T/sweep.err")" -eq 3 ] || fail "not one progress line per run: $(cat "$T/sweep.err")"
grep -q $'\r' "$T/sweep.err" && fail "a progress bar was drawn on a non-terminal"
$PY - "$T/sweep.csv" "$T/sweep.json" <<'PYEOF' || fail "table or JSON"
import csv, json, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
doc = json.load(open(sys.argv[2]))
assert doc["failures"] == 1, doc["failures"]
assert [v["name"] for v in doc["variants"]] == ["nominal", "load.mass=35", "regulator.sonic_conductance=1e-05"]
failed = [r for r in rows if r["status"] == "failed"]
assert len(failed) == 1 and "max_substeps" in failed[0]["error"], failed
ok = [r for r in rows if r["status"] == "ok"]
kinds = {r["kind"] for r in ok}
assert {"faithful", "compensated", "baseline"} <= kinds, kinds
nominal = {(r["reference"], r["kind"]): r for r in ok if r["variant"] == "nominal"}
heavy = {(r["reference"], r["kind"]): r for r in ok if r["variant"] == "load.mass=35"}
assert nominal.keys() == heavy.keys() and len(nominal) >= 3
for k, r in heavy.items():
    n = nominal[k]
    assert float(n["rms_vs_nominal"]) == 1.0
    ratio = float(r["rms_mm"]) / float(n["rms_mm"])
    assert math.isclose(float(r["rms_vs_nominal"]), ratio, rel_tol=1e-12), (r, ratio)
    assert r["rms_mm"] != n["rms_mm"], k
    assert float(r["max_mm"]) >= float(r["rms_mm"]) >= float(r["mae_mm"]) > 0, r
    assert float(r["command_limit_mpa"]) == 0.6, r  # the nominal muscle's rating, the regulator's range above it
    assert 0.0 <= float(r["min_command_mpa"]) <= float(r["max_command_mpa"]) <= float(r["command_limit_mpa"]), r
# the JSON holds the same numbers as the table
runs = {run["variant"]: run for run in doc["runs"]}
for t in runs["load.mass=35"]["tracking"]:
    assert t["rms_error_mm"] == float(heavy[(t["reference"], t["kind"])]["rms_mm"])
PYEOF
grep -q "<svg" "$T/sweep.html" || fail "no plot in the page"
grep -q "RMS error against load.mass" "$T/sweep.html" || fail "no RMS-against-load.mass plot"
grep -q "failed: rig: the air dynamics" "$T/sweep.html" || fail "the failure is not on the page"
grep -q "hysteron sweep gpi-pid" "$T/sweep.html" || fail "the command line is not on the page"

# --identify-on-base: the variant's run is `hysteron experiment --tracking-plant` on it (identified
# on the base rig), to the last digit; the default identifies it on its own rig (other errors)
printf '{"load": {"damping": 200}}\n' > "$T/d200.json"
"$BIN" sweep gpi-pid --vary load.damping=200 --identify-on-base --learning-periods 0 --model gpi --jobs 2 \
  --json > "$T/iob.json" 2> "$T/iob.err" || fail "identify-on-base sweep: exit $? ($(cat "$T/iob.err"))"
"$BIN" sweep gpi-pid --vary load.damping=200 --learning-periods 0 --model gpi --jobs 2 --json > "$T/own.json" \
  2> "$T/own.err" || fail "sweep: exit $? ($(cat "$T/own.err"))"
"$BIN" experiment gpi-pid --tracking-plant "$T/d200.json" --learning-periods 0 --model gpi --json \
  > "$T/iob_exp.json" 2> "$T/iob_exp.err" || fail "experiment --tracking-plant: exit $? ($(cat "$T/iob_exp.err"))"
$PY - "$T/iob.json" "$T/own.json" "$T/iob_exp.json" <<'PYEOF' || fail "identify-on-base"
import json, sys
iob, own, exp = (json.load(open(p)) for p in sys.argv[1:])
assert iob["identify_on_base"] is True and own["identify_on_base"] is False
def rms(doc, variant):
    run = next(r for r in doc["runs"] if r["variant"] == variant)
    return {t["kind"]: t["rms_error_mm"] for t in run["tracking"]}
changed = rms(iob, "load.damping=200")
for kind in ("faithful", "compensated", "baseline"):
    assert changed[kind] == exp[kind]["rms_error_mm"], (kind, changed[kind], exp[kind]["rms_error_mm"])
assert changed["compensated"] != rms(own, "load.damping=200")["compensated"]
assert rms(iob, "nominal") == rms(own, "nominal")
PYEOF
grep -q "identify-on-base" <("$BIN" sweep --help) || fail "--identify-on-base is not in the help"

# only the nominal rig (a variant equal to it is the nominal row): exit 0, the text table
printf '{"variants": [{"name": "same", "set": {"load.mass": 20}}]}\n' > "$T/grid_nominal.json"
"$BIN" sweep gpi-pid --grid "$T/grid_nominal.json" --jobs 1 --learning-periods 0 > "$T/nominal.txt" 2> "$T/nominal.err"
rc=$?
[ $rc -eq 0 ] || fail "nominal-only sweep: exit $rc ($(cat "$T/nominal.err"))"
grep -q "variant 'same' is the nominal rig" "$T/nominal.txt" || fail "no note for the nominal repeat: $(cat "$T/nominal.txt")"
grep -qE '^nominal +sine' "$T/nominal.txt" || fail "no nominal row: $(cat "$T/nominal.txt")"

# bench/issue11_targets.py on a made-up sweep CSV: every target met (exit 0), then one variant
# above 1.5x its nominal RMS and one learning max above 0.3 mm (exit 1, both named), then a
# file that is not a sweep CSV (exit 2)
TARGETS="$(cd "$(dirname "$0")/../.." && pwd)/bench/issue11_targets.py"
/usr/bin/python3 - "$T/t_ok.csv" "$T/t_miss.csv" <<'PYEOF'
import sys
head = "experiment,variant,overrides,reference,kind,max_mm,mae_mm,rms_mm,rms_vs_nominal,rms_vs_baseline,min_command_mpa,max_command_mpa,saturated,reference_scale,status,error,wall_time_s,guard_cuts,guard_final_scale"
def rows(ratio, learning_max):
    out = [head]
    def row(e, v, r, k, mx, rms, ratio_):
        out.append(f"{e},{v},,{r},{k},{mx},0,{rms},{ratio_},0,0.05,0.55,0,1,ok,,1,0,1")
    for e, refs in (("gpi-pid", ["sine"]), ("mpi-openloop", ["triangle", "sine"]), ("mpi-pwm", ["sine", "triangle"])):
        for r in refs:
            row(e, "nominal", r, "compensated", 0.9, 0.25, 1)
            row(e, "nominal", r, "learning", learning_max if e == "mpi-pwm" else 0.2, 0.05, 0.2)
            row(e, "nominal", r, "baseline", 5.0, 3.0, 12)
    row("gpi-pid", "load 35 kg", "sine", "compensated", 1.0, 0.25 * ratio, ratio)
    row("gpi-pid", "load 35 kg", "sine", "baseline", 5.0, 3.0, 12)
    return "\n".join(out) + "\n"
open(sys.argv[1], "w").write(rows(1.4, 0.25))
open(sys.argv[2], "w").write(rows(1.6, 0.35))
PYEOF
/usr/bin/python3 "$TARGETS" "$T/t_ok.csv" > "$T/t_ok.txt" 2>&1 || fail "issue11_targets: an all-met CSV: exit $? ($(cat "$T/t_ok.txt"))"
grep -q "^0 target(s) missed" "$T/t_ok.txt" || fail "issue11_targets: $(tail -1 "$T/t_ok.txt")"
/usr/bin/python3 "$TARGETS" "$T/t_miss.csv" > "$T/t_miss.txt" 2>&1
[ $? -eq 1 ] || fail "issue11_targets: misses not exit 1"
grep -q "^MISSED gpi-pid load 35 kg sine compensated RMS / nominal: 1.600 (limit 1.5)" "$T/t_miss.txt" \
  || fail "issue11_targets: the ratio miss is not named: $(cat "$T/t_miss.txt")"
grep -q "^MISSED mpi-pwm nominal triangle learning max \[mm\]: 0.350" "$T/t_miss.txt" \
  || fail "issue11_targets: the learning miss is not named"
grep -q "^3 target(s) missed" "$T/t_miss.txt" || fail "issue11_targets: $(tail -1 "$T/t_miss.txt")"
/usr/bin/python3 "$TARGETS" "$T/grid_nominal.json" > /dev/null 2>&1
[ $? -eq 2 ] || fail "issue11_targets: a JSON file not refused with exit 2"

if [ $fails -ne 0 ]; then
  echo "$fails failure(s)"
  exit 1
fi
echo "sweep.sh: all checks passed"
