#!/usr/bin/env bash
# --control-period S of hysteron experiment, demo and sweep: a bad period (NaN, <= 0, above
# 0.01 s, not a whole number of the rig's 1e-4 s steps, not a number) is exit 1 with the
# library's message and nothing written; a run at 0.5 ms (2 kHz) records that sample time in
# every loop of result.json, logs every 0.5 ms, says its period in the table, report.html and
# result.json, and its feedforward lead, counted in samples, is about twice the 1 ms run's (the
# same lead in seconds). Learning and adaptive runs are off
# and the model pinned, for speed.
# Usage: bash control_period.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

# expect_error "what" "part of the message" OUT command...: exit 1, the message on stderr, OUT not created
expect_error() {
  local what=$1 part=$2 out=$3
  shift 3
  "$@" > "$T/out.txt" 2> "$T/err.txt"
  local rc=$?
  [ $rc -eq 1 ] || fail "$what: exit $rc, expected 1 ($(cat "$T/err.txt"))"
  grep -qF -- "$part" "$T/err.txt" || fail "$what: stderr lacks '$part': $(cat "$T/err.txt")"
  [ ! -e "$out" ] || fail "$what: $out was written"
}

for cmd in experiment demo; do
  args=(gpi-pid)
  [ $cmd = demo ] && args=()
  # nan and hex are no decimal number (io/numbers.hpp, for every FLOAT option: CLI11 alone read "0x1p-10")
  expect_error "$cmd nan" "--control-period: nan is not a finite decimal number" "$T/o" \
    "$BIN" $cmd "${args[@]}" --control-period nan --out "$T/o"
  expect_error "$cmd hex" "--control-period: 0x1p-10 is not a finite decimal number" "$T/o" \
    "$BIN" $cmd "${args[@]}" --control-period 0x1p-10 --out "$T/o"
  expect_error "$cmd 0" "control_period = 0 s must be within" "$T/o" "$BIN" $cmd "${args[@]}" --control-period 0 --out "$T/o"
  expect_error "$cmd negative" "control_period = -0.001 s must be within" "$T/o" \
    "$BIN" $cmd "${args[@]}" --control-period -0.001 --out "$T/o"
  expect_error "$cmd too slow" "control_period = 0.03 s must be within" "$T/o" \
    "$BIN" $cmd "${args[@]}" --control-period 0.03 --out "$T/o"
  # 0.02 s: mpi-openloop's fit had too few samples of its identification run (the demo wrote gpi-pid first)
  expect_error "$cmd 0.02" "control_period = 0.02 s must be within" "$T/o" \
    "$BIN" $cmd "${args[@]}" --control-period 0.02 --out "$T/o"
  expect_error "$cmd not whole steps" "control_period = 0.00025 s is not a whole multiple of the rig's simulation.dt" \
    "$T/o" "$BIN" $cmd "${args[@]}" --control-period 0.00025 --out "$T/o"
  expect_error "$cmd not a number" "--control-period" "$T/o" "$BIN" $cmd "${args[@]}" --control-period 1ms --out "$T/o"
done
# an existing --out directory keeps its files untouched
mkdir -p "$T/keep" && echo old > "$T/keep/result.json"
"$BIN" experiment gpi-pid --control-period 0.00025 --out "$T/keep" > /dev/null 2>&1
[ "$(cat "$T/keep/result.json")" = old ] || fail "a rejected period changed an existing --out"
expect_error "sweep not whole steps" "sweep: base rig: control_period = 0.00025 s is not a whole multiple" "$T/s.csv" \
  "$BIN" sweep gpi-pid --vary load.mass=35 --control-period 0.00025 --out "$T/s.csv"
expect_error "sweep too slow" "sweep: control_period = 0.05 s must be within [base rig dt = 0.0001 s, 0.01 s]" "$T/s.csv" \
  "$BIN" sweep gpi-pid --vary load.mass=35 --control-period 0.05 --out "$T/s.csv"
# a variant's rig whose dt does not divide the period
expect_error "sweep variant dt" "variant 'simulation.dt=3e-05': rig: control_period = 0.0005 s is not a whole multiple" \
  "$T/s.csv" "$BIN" sweep gpi-pid --vary simulation.dt=3e-5 --control-period 0.0005 --out "$T/s.csv"

# 1 ms (the default) and 0.5 ms
fast=(--learning-periods 0 --no-adaptive --model gpi --seed 1)
"$BIN" experiment gpi-pid "${fast[@]}" --out "$T/ms1" > "$T/ms1.txt" 2>&1
rc=$?
[ $rc -eq 0 ] || fail "1 ms run: exit $rc: $(tail -3 "$T/ms1.txt")"
"$BIN" experiment gpi-pid "${fast[@]}" --control-period 0.0005 --out "$T/ms05" > "$T/ms05.txt" 2>&1
rc=$?
[ $rc -eq 0 ] || fail "0.5 ms run: exit $rc: $(tail -3 "$T/ms05.txt")"
# the table and the report say the period (a 0.5 ms run must not look like a 1 ms one)
grep -qF "  control period 0.5 ms, rig noise seed 1" "$T/ms05.txt" || fail "0.5 ms table: $(head -3 "$T/ms05.txt")"
grep -qF "  control period 1 ms, rig noise seed 1" "$T/ms1.txt" || fail "1 ms table: $(head -3 "$T/ms1.txt")"
grep -qF "at a control period of 0.5 ms" "$T/ms05/report.html" || fail "0.5 ms report.html does not say the period"
"$BIN" report "$T/ms05" --out "$T/rep05.html" > "$T/rep05.txt" 2>&1 || fail "report of the 0.5 ms run: $(cat "$T/rep05.txt")"
grep -qF "at a control period of 0.5 ms" "$T/rep05.html" || fail "hysteron report of the 0.5 ms result.json does not say the period"
"$PY" - "$T/ms1" "$T/ms05" <<'PY' || fail "0.5 ms run's result.json and CSVs"
import csv, json, sys
one, half = (json.load(open(d + "/result.json")) for d in sys.argv[1:3])
bad = []
def loops(r):
    for v in r["variants"]:
        e = r[v]
        for ref, x in (e.items() if "controller" not in e else [("", e)]):
            yield v, ref, x["controller"]
n = 0
for v, ref, c in loops(half):
    n += 1
    if c["sample_time_s"] != 0.0005:
        bad.append(f"{v} {ref}: sample_time_s {c['sample_time_s']}")
if n == 0:
    bad.append("no controller in the 0.5 ms result")
# the same identified dead time in seconds: the lead in samples about doubles (one sample of
# rounding at each rate: |2 L_1ms - L_0.5ms| <= 2)
l1 = {(v, ref): c["feedforward_lead_samples"] for v, ref, c in loops(one)}
for v, ref, c in loops(half):
    if v != "compensated":
        continue
    a, b = l1[(v, ref)], c["feedforward_lead_samples"]
    if a < 10 or abs(2 * a - b) > 2:
        bad.append(f"{v} {ref}: lead {b} samples at 0.5 ms, {a} at 1 ms")
    if abs(b * 0.0005 - half["lead_s"]) > 1e-12:
        bad.append(f"lead_s {half['lead_s']} is not {b} samples of 0.5 ms")
rows = list(csv.DictReader(open(sys.argv[2] + "/tracking_compensated_sine.csv")))
steps = {round(float(b["t_s"]) - float(a["t_s"]), 12) for a, b in zip(rows, rows[1:])}
if half.get("control_period_s") != 0.0005 or one.get("control_period_s") != 0.001:
    bad.append(f"control_period_s {half.get('control_period_s')} / {one.get('control_period_s')}")
if steps != {0.0005}:
    bad.append(f"CSV time steps {sorted(steps)[:5]}")
print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
exit $fails
