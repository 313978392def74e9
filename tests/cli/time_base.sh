#!/usr/bin/env bash
# The time base: a rig whose simulation.dt does not divide the 1 ms control period is refused by
# experiment, demo and sweep (exit 1, before anything runs, naming both values and the nearest
# dt that divides the period) and warned by `rig`; a dt that divides it runs. rate-pi's sample
# time: --sample-time and a time column that disagree by more than 1 % are refused (fit,
# evaluate); fit's --validate-data files get evaluate's check against the model's dt; evaluate
# without a time column, simulate and invert say the model's dt is assumed.
# --time-unit ms|us reads the time column as seconds; fit asks about a sample time above 0.1 s.
# A unit the file gives ("t [ms]", a units row) is read without --time-unit and checked against it.
# The report of a --time-unit ms fit draws its time axis in seconds. A time column's step is the
# mean step without its gaps (stamps rounded to 1 ms average out). simulate and invert say rate-pi's
# dt is assumed only once the input was read.
# Usage: bash time_base.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

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
  grep -q "nearest dt that divides it is 9.09090909090909[0-9]e-05 s" "$2" || fail "$1: no nearest dt: $(cat "$2")"
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
grep -q "^rig: warning: the experiments refuse this rig: .*nearest dt that divides it is 9.09090909090909[0-9]e-05 s" "$T/err.txt" \
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

# ---- records for rate-pi: 400 samples of 1 ms (t in s, ms and us), one of 2 ms, one without time ----
rec() {  # $1: file, $2: time step in the column's unit, $3: header of the time column
  awk -v step="$2" -v head="$3" 'BEGIN { print head ",p,y"; for (k = 0; k < 400; ++k) { \
    p = 50 + 40 * sin(k / 20); printf "%.10g,%.10g,%.10g\n", k * step, p, 0.3 * p + 2 + 3 * sin(k / 20 + 0.4) } }' > "$1"
}
rec "$T/r.csv" 0.001 t
rec "$T/r2.csv" 0.002 t
rec "$T/rms.csv" 1 t
rec "$T/rus.csv" 1000 t
cut -d, -f2- "$T/r.csv" > "$T/rnot.csv"
fit() { "$BIN" fit --model rate-pi --input p --output y --threads 1 --force "$@"; }
model_dt() { $PY -c "import json,sys; print('%.9g' % json.load(open(sys.argv[1]))['dt'])" "$1"; }  # to 9 digits
fit --data "$T/r.csv" --time-column t --out "$T/rp.json" > /dev/null 2> "$T/err.txt" || true
[ "$(model_dt "$T/rp.json")" = "0.001" ] || fail "rate-pi on 1 ms: dt $(model_dt "$T/rp.json"): $(cat "$T/err.txt")"
"$BIN" fit --model gpi --data "$T/r.csv" --input p --output y --threads 1 --force --out "$T/gpi.json" > /dev/null 2>&1

# ---- F3: --sample-time and a time column that disagree: refused, both named ----
fit --data "$T/r.csv" --time-column t --sample-time 0.002 --out "$T/st.json" > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "fit --sample-time 0.002 on a 1 ms column: exit $rc (expected 1)"
grep -q -- "--sample-time 0.002 s disagrees with the mean step 0.001 s of the time column t (by 100 %, more than the 1 % allowed)" \
  "$T/err.txt" || fail "fit --sample-time 0.002: $(cat "$T/err.txt")"
[ -e "$T/st.json" ] && fail "fit --sample-time 0.002: model written"
# within 1 % (0.5 %): --sample-time is taken
fit --data "$T/r.csv" --time-column t --sample-time 0.001005 --out "$T/st.json" > /dev/null 2> "$T/err.txt" || true
[ "$(model_dt "$T/st.json")" = "0.001005" ] || fail "fit --sample-time 0.001005: $(cat "$T/err.txt")"
# evaluate checks them alike
"$BIN" evaluate --model "$T/rp.json" --data "$T/r.csv" --input p --output y --time-column t --sample-time 0.002 \
  > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "evaluate --sample-time 0.002 on a 1 ms column: exit $rc (expected 1)"
grep -q -- "--sample-time 0.002 s disagrees with the mean step 0.001 s" "$T/err.txt" || fail "evaluate: $(cat "$T/err.txt")"

# ---- F4: fit's --validate-data files get evaluate's check of the record's sample time ----
fit --data "$T/r.csv" --time-column t --validate-data "$T/r2.csv" --out "$T/v.json" > "$T/out.txt" 2>&1
grep -q "r2.csv: the record's sample time 0.002 s (mean step of the time column t) differs from the rate-pi model's dt 0.001 s: the model runs its rates 2x too slow" \
  "$T/out.txt" || fail "fit --validate-data of 2 ms: no warning: $(grep -i warn "$T/out.txt")"
fit --data "$T/r.csv" --time-column t --validate-data "$T/r.csv" --out "$T/v.json" --json > "$T/out.json" 2>&1
grep -q "the record's sample time" "$T/out.json" && fail "fit --validate-data of 1 ms: warned: $(grep "sample time" "$T/out.json")"
# the same warning as evaluate's
"$BIN" evaluate --model "$T/rp.json" --data "$T/r2.csv" --input p --output y --time-column t > /dev/null 2> "$T/err.txt"
grep -q "the model runs its rates 2x too slow" "$T/err.txt" || fail "evaluate on 2 ms: $(cat "$T/err.txt")"

# ---- F5: no time column: the model's dt assumed, said; --sample-time checked as a column is ----
"$BIN" evaluate --model "$T/rp.json" --data "$T/rnot.csv" --input p --output y > /dev/null 2> "$T/err.txt" \
  || fail "evaluate without time: exit $?"
grep -q "^warning: .*rnot.csv: the record's sample time is unknown (no time column): the rate-pi model's dt 0.001 s is assumed" \
  "$T/err.txt" || fail "evaluate without time: $(cat "$T/err.txt")"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rnot.csv" --input p --output y --sample-time 0.001 > /dev/null \
  2> "$T/err.txt" || fail "evaluate --sample-time 0.001: exit $?"
grep -q "the record's sample time" "$T/err.txt" && fail "evaluate --sample-time 0.001 warned: $(cat "$T/err.txt")"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rnot.csv" --input p --output y --sample-time 0.002 > /dev/null \
  2> "$T/err.txt"
grep -q "sample time 0.002 s (--sample-time) differs from the rate-pi model's dt 0.001 s: the model runs its rates 2x too slow" \
  "$T/err.txt" || fail "evaluate --sample-time 0.002: $(cat "$T/err.txt")"
"$BIN" evaluate --model "$T/gpi.json" --data "$T/rnot.csv" --input p --output y > /dev/null 2> "$T/err.txt"
grep -q "the record's sample time" "$T/err.txt" && fail "evaluate gpi without time warned: $(cat "$T/err.txt")"
cut -d, -f2 "$T/r.csv" > "$T/x.csv"
"$BIN" simulate --model "$T/rp.json" --input "$T/x.csv" --output "$T/sim.csv" 2> "$T/err.txt" || fail "simulate: exit $?"
grep -q "^simulate: warning: .*x.csv: the record's sample time is unknown (no time column): the rate-pi model's dt 0.001 s is assumed" \
  "$T/err.txt" || fail "simulate rate-pi: $(cat "$T/err.txt")"
cut -d, -f2 "$T/sim.csv" > "$T/yd.csv"
"$BIN" invert --model "$T/rp.json" --input "$T/yd.csv" --output "$T/inv.csv" 2> "$T/err.txt" || fail "invert: exit $?"
grep -q "^invert: warning: .*the rate-pi model's dt 0.001 s is assumed" "$T/err.txt" || fail "invert rate-pi: $(cat "$T/err.txt")"
# a read error is the only message: the dt is said once the input was read (streamed to a file, or to stdout)
awk 'NR == 200 { print "oops"; next } { print }' "$T/x.csv" > "$T/xbad.csv"
for out in "$T/simbad.csv" -; do
  for cmd in simulate invert; do
    "$BIN" $cmd --model "$T/rp.json" --input "$T/xbad.csv" --output "$out" > /dev/null 2> "$T/err.txt"
    rc=$?
    [ $rc -eq 1 ] || fail "$cmd of a bad input to $out: exit $rc (expected 1)"
    grep -q "xbad.csv" "$T/err.txt" || fail "$cmd of a bad input to $out: no error naming it: $(cat "$T/err.txt")"
    grep -q "is assumed" "$T/err.txt" && fail "$cmd of a bad input to $out: said the dt: $(cat "$T/err.txt")"
  done
done
"$BIN" simulate --model "$T/rp.json" --input "$T/x.csv" --output - > /dev/null 2> "$T/err.txt" || fail "simulate to -"
grep -q "^simulate: warning: .*x.csv: .*the rate-pi model's dt 0.001 s is assumed" "$T/err.txt" \
  || fail "simulate rate-pi to -: $(cat "$T/err.txt")"
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/sim.csv" 2> "$T/err.txt" || fail "simulate gpi"
grep -q "the record's sample time" "$T/err.txt" && fail "simulate gpi warned: $(cat "$T/err.txt")"

# ---- F2: --time-unit ms|us: read as seconds; a sample time above 0.1 s asks whether the column is in ms ----
fit --data "$T/rms.csv" --time-column t --time-unit ms --out "$T/ms.json" > "$T/out.txt" 2>&1
[ "$(model_dt "$T/ms.json")" = "0.001" ] || fail "--time-unit ms: dt $(model_dt "$T/ms.json")"
grep -q "see --time-unit" "$T/out.txt" && fail "--time-unit ms: still warned"
fit --data "$T/rus.csv" --time-column t --time-unit us --out "$T/us.json" > /dev/null 2>&1
[ "$(model_dt "$T/us.json")" = "0.001" ] || fail "--time-unit us: dt $(model_dt "$T/us.json")"
fit --data "$T/rms.csv" --time-column t --out "$T/ms1.json" > "$T/out.txt" 2>&1
grep -q "rate-pi's sample time is 1 s (the mean step of the time column t in s), above 0.1 s: is the time column in ms? see --time-unit" \
  "$T/out.txt" || fail "ms column read as s: no warning: $(grep -i warn "$T/out.txt")"
# ranges in seconds are seconds: 0.1 s .. 0.3 s of a 1 ms record in ms = samples 100..300
"$BIN" fit --model pi --data "$T/rms.csv" --input p --output y --time-column t --time-unit ms --train 0.1s:0.3s \
  --threads 1 --force --out "$T/pi.json" --json > "$T/out.json" 2> /dev/null
$PY -c "import json,sys; d=json.load(open(sys.argv[1]))['data']['train']; assert d == [100, 300], d" \
  "$T/out.json" || fail "--time-unit ms --train 0.1s:0.3s"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rms.csv" --input p --output y --time-column t --time-unit ms \
  > /dev/null 2> "$T/err.txt" || fail "evaluate --time-unit ms: exit $?"
grep -q "the record's sample time" "$T/err.txt" && fail "evaluate --time-unit ms warned: $(cat "$T/err.txt")"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rms.csv" --input p --output y --time-unit ms > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "--time-unit without --time-column: not exit 1"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rms.csv" --input p --output y --time-column t --time-unit min \
  > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "--time-unit min: not exit 1"

# the file's own unit: "t [ms]" or a units row below the header reads the column in it without
# --time-unit; --time-unit agreeing is fine, disagreeing an error naming both; a time unit that is
# not read (min) an error; a bracket that is no time unit is not one; the axes take the header's units
# (columns by index; fit exits 3 on these records' poor fit, writing the model all the same: --force)
fitc() { "$BIN" fit --model rate-pi --input 1 --output 2 --threads 1 --force "$@"; }
sed '1s/.*/t [ms],p (kPa),y/' "$T/rms.csv" > "$T/rhead.csv"
{ echo "time,p,y"; echo "msec,kPa,mm"; tail -n +2 "$T/rms.csv"; } > "$T/rrow.csv"
for f in rhead rrow; do
  fitc --data "$T/$f.csv" --time-column 0 --out "$T/$f.json" --report "$T/$f-fit.json" > "$T/out.txt" 2>&1 \
    || [ $? -eq 3 ] || fail "$f: exit $?: $(cat "$T/out.txt")"
  [ "$(model_dt "$T/$f.json")" = "0.001" ] || fail "$f: the unit the file gives not read: dt $(model_dt "$T/$f.json")"
  grep -q "see --time-unit" "$T/out.txt" && fail "$f: warned as a column in s"
  $PY -c "import json,sys; d=json.load(open(sys.argv[1]))['data']; assert d['time_unit'] == 'ms', d; \
    assert d['input_axis'] == {'label': 'p', 'unit': 'kPa'}, d['input_axis']" "$T/$f-fit.json" \
    || fail "$f: the fit document's time unit or input axis"
  fitc --data "$T/$f.csv" --time-column 0 --time-unit ms --out "$T/${f}2.json" > /dev/null 2>&1 \
    || [ $? -eq 3 ] || fail "$f --time-unit ms (agreeing): exit $?"
  fitc --data "$T/$f.csv" --time-column 0 --time-unit s --out "$T/${f}s.json" > /dev/null 2> "$T/err.txt"
  rc=$?
  [ $rc -eq 1 ] || fail "$f --time-unit s (disagreeing): exit $rc (expected 1)"
  grep -q "$f.csv: --time-unit s but the file gives the time column 0 the unit" "$T/err.txt" \
    || fail "$f --time-unit s: $(cat "$T/err.txt")"
  [ -e "$T/${f}s.json" ] && fail "$f --time-unit s: a model written"
  # hysteron report with the time column named anew reads its unit as fit did ("msec" in rrow's units row)
  "$BIN" report "$T/$f-fit.json" --time-column 0 --out "$T/$f.html" > /dev/null 2> "$T/err.txt" \
    || fail "report $f-fit.json --time-column 0: exit $?: $(cat "$T/err.txt")"
  "$BIN" evaluate --model "$T/rp.json" --data "$T/$f.csv" --input 1 --output 2 --time-column 0 > /dev/null 2> "$T/err.txt" \
    || fail "evaluate $f: exit $?: $(cat "$T/err.txt")"
  grep -q "the record's sample time" "$T/err.txt" && fail "evaluate $f: read as seconds: $(cat "$T/err.txt")"
done
# the figures of a report page (its SVGs)
figures() { $PY -c "import re,sys; print(''.join(re.findall(r'<svg.*?</svg>', open(sys.argv[1]).read(), re.S)))" "$1"; }
# the report of a fit on a "t [ms]" record validated on records in s, one saying so ("t [s]") and
# one not ("t"): both validation files are drawn in seconds, as fit read them (the same figures)
sed '1s/.*/t [s],p,y/' "$T/r.csv" > "$T/rsec.csv"
for v in r rsec; do
  mkdir -p "$T/val_$v"
  cp "$T/rhead.csv" "$T/val_$v/"
  cp "$T/$v.csv" "$T/val_$v/val.csv"  # one name: the page names the file
  (cd "$T/val_$v" && "$BIN" fit --model pi --data rhead.csv --input 1 --output 2 --time-column 0 --validate-data val.csv \
    --threads 1 --force --out m.json --report fit.json > /dev/null 2>&1 && "$BIN" report fit.json --out r.html 2> err.txt) \
    || fail "fit/report validated on $v.csv: $(cat "$T/val_$v/err.txt")"
  figures "$T/val_$v/r.html" > "$T/val_$v/figures.txt"
done
grep -q '> 0.4</tspan>' "$T/val_r/figures.txt" || fail "validation in s under a document in ms: no tick at 0.4 s"
cmp -s "$T/val_r/figures.txt" "$T/val_rsec/figures.txt" \
  || fail "a validation file without a time unit is drawn otherwise than one in s (under a document in ms)"
sed '1s/.*/t (min),p,y/' "$T/rms.csv" > "$T/rmin.csv"
fitc --data "$T/rmin.csv" --time-column 0 --out "$T/rmin.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "a time column in min: not exit 1"
grep -q 'rmin.csv: the time column 0 is in "min", a time unit that is not read' "$T/err.txt" \
  || fail "a time column in min: $(cat "$T/err.txt")"
sed '1s/.*/t (corrected),p,y/' "$T/r.csv" > "$T/rcorr.csv"
fitc --data "$T/rcorr.csv" --time-column 0 --out "$T/rcorr.json" > /dev/null 2>&1
[ "$(model_dt "$T/rcorr.json")" = "0.001" ] || fail "t (corrected): dt $(model_dt "$T/rcorr.json")"

# a column in s read with --time-unit ms: dt 1e-6 s, asked about too (1 us or below)
fit --data "$T/r.csv" --time-column t --time-unit ms --out "$T/msw.json" > "$T/out.txt" 2>&1
grep -q "rate-pi's sample time is 1e-06 s (the mean step of the time column t in ms), 1 us or below: is the time column in s or another unit? see --time-unit" \
  "$T/out.txt" || fail "s column read as ms: no warning: $(grep -i warn "$T/out.txt")"

# ---- an agreeing --sample-time does not hide the time column's faults (a gap) ----
awk -F, 'NR == 1 || NR <= 201 { print; next } { printf "%.10g,%s,%s\n", $1 + 1, $2, $3 }' "$T/r.csv" > "$T/rgap.csv"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rgap.csv" --input p --output y --time-column t --sample-time 0.001 \
  > /dev/null 2> "$T/err.txt"
grep -q "rgap.csv: the time column t is not uniformly sampled" "$T/err.txt" \
  || fail "evaluate --sample-time on a gap: no warning: $(cat "$T/err.txt")"
fit --data "$T/rgap.csv" --time-column t --sample-time 0.001 --out "$T/gap.json" > "$T/out.txt" 2>&1
grep -q "rgap.csv: the time column t is not uniformly sampled" "$T/out.txt" \
  || fail "fit --sample-time on a gap: no warning: $(grep -i warn "$T/out.txt")"

# ---- the report of a fit document of a --time-unit ms record draws its time in seconds ----
# the same record in s and in ms, each fitted and reported beside its document: the same figures
# (the HTML's table has the fit's wall time), the time axis to 0.399 s
for u in s ms old; do
  mkdir -p "$T/rep_$u"
  cp "$T/$([ $u = ms ] && echo rms || echo r).csv" "$T/rep_$u/rec.csv"
  (cd "$T/rep_$u" && "$BIN" fit --model pi --data rec.csv --input p --output y --time-column t \
    --time-unit $([ $u = ms ] && echo ms || echo s) --threads 1 --force --out m.json --report fit.json > /dev/null 2>&1) \
    || fail "fit --time-unit $u --report fit.json: exit $?"
  # old: a document of before 2026-11-30, without time_unit (its time column in s): the same report
  [ $u = old ] && $PY -c "import json,sys; d=json.load(open(sys.argv[1])); del d['data']['time_unit']; \
    json.dump(d,open(sys.argv[1],'w'))" "$T/rep_old/fit.json"
  (cd "$T/rep_$u" && "$BIN" report fit.json --out r.html 2> err.txt) || fail "report of the $u fit: $(cat "$T/rep_$u/err.txt")"
  figures "$T/rep_$u/r.html" > "$T/rep_$u/figures.txt"
done
grep -q '"time_unit": "ms"' "$T/rep_ms/fit.json" || fail "the fit document of a --time-unit ms record has no time_unit"
[ "$(grep -c '<svg' "$T/rep_s/figures.txt")" -ge 3 ] || fail "the report of the fit in s: no figures"
grep -q '> 0.4</tspan>' "$T/rep_s/figures.txt" || fail "the report of the fit in s: no tick at 0.4 s"
cmp -s "$T/rep_s/figures.txt" "$T/rep_ms/figures.txt" || fail "the report of a --time-unit ms record differs from that in s"
cmp -s "$T/rep_s/figures.txt" "$T/rep_old/figures.txt" || fail "a document without time_unit reported otherwise"
# an unknown unit is refused, naming it
$PY -c "import json,sys; d=json.load(open(sys.argv[1])); d['data']['time_unit']='min'; json.dump(d,open(sys.argv[2],'w'))" \
  "$T/rep_s/fit.json" "$T/rep_s/min.json"
(cd "$T/rep_s" && "$BIN" report min.json --out min.html > /dev/null 2> err.txt)
[ $? -eq 1 ] || fail "report of time_unit min: not exit 1"
grep -q 'min.json.data.time_unit: unknown time unit "min" (expected s, ms or us)' "$T/rep_s/err.txt" \
  || fail "time_unit min: $(cat "$T/rep_s/err.txt")"
"$BIN" evaluate --model "$T/rp.json" --data "$T/rms.csv" --input p --output y --time-column t --time-unit ms --json \
  2> /dev/null | grep -q '"time_unit": "ms"' || fail "the evaluation document of a --time-unit ms record has no time_unit"

# ---- the record's time step: the mean step without the gaps, not the median ----
# stamps of a 1.887 ms record rounded to 1 ms (as Festo test8's: steps of 1, 2, 3 ms, median 2 ms),
# the same with a gap of 1 s, and 1 ms stamps jittered by up to +-0.3 ms; truth within 0.5 %
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 2000; ++k) { p = 50 + 40 * sin(k / 60); \
  printf "%.10g,%.10g,%.10g\n", sprintf("%.0f", k * 1.887) / 1000, p, 0.3 * p + 2 + 3 * sin(k / 60 + 0.4) } }' > "$T/q.csv"
awk -F, 'NR <= 1001 { print; next } { printf "%.10g,%s,%s\n", $1 + 1, $2, $3 }' "$T/q.csv" > "$T/qgap.csv"
awk 'BEGIN { srand(7); print "t,p,y"; for (k = 0; k < 2000; ++k) { p = 50 + 40 * sin(k / 60); \
  printf "%.10g,%.10g,%.10g\n", k * 0.001 + 0.0003 * (2 * rand() - 1), p, 0.3 * p + 2 + 3 * sin(k / 60 + 0.4) } }' \
  > "$T/jit.csv"
# the step the CLI takes, as --sample-time's refusal names it
step_of() {  # $1: file, $2 $3 $4: input, output, time columns (default p, y, t)
  "$BIN" evaluate --model "$T/gpi.json" --data "$1" --input "${2:-p}" --output "${3:-y}" --time-column "${4:-t}" \
    --sample-time 1 2>&1 \
    | sed -n 's/.*disagrees with the mean step \([0-9.e+-]*\) s.*/\1/p'
}
near() { $PY -c "import sys; a, b, tol = map(float, sys.argv[1:]); sys.exit(0 if abs(a / b - 1) <= tol else 1)" "$@"; }
for f in q:0.001887 qgap:0.001887 jit:0.001; do
  s=$(step_of "$T/${f%%:*}.csv")
  near "${s:-nan}" "${f#*:}" 0.005 || fail "${f%%:*}.csv: the step ${s:-none} s, not within 0.5 % of ${f#*:} s"
done
# a lost sample (a step of 2) does not count: 1 ms stamps with every 25th row dropped give 1 ms
# (a mean over steps up to 2.5 medians gave 1.0413 ms and refused --sample-time 0.001)
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 2000; ++k) { if (k % 25 == 24) continue; p = 50 + 40 * sin(k / 60); \
  printf "%.10g,%.10g,%.10g\n", k * 0.001, p, 0.3 * p + 2 + 3 * sin(k / 60 + 0.4) } }' > "$T/lost.csv"
s=$(step_of "$T/lost.csv")
near "${s:-nan}" 0.001 0.005 || fail "lost.csv (every 25th sample lost): the step ${s:-none} s, not 1 ms"
# --sample-time is taken where it agrees with the mean step without gaps or with the overall mean
# step: 1 ms on the record with lost samples; 1.4 ms on 1.4 ms stamps rounded to 1 ms (steps of 1
# and 2 ms, which look like lost samples)
awk 'BEGIN { print "t,p,y"; for (k = 0; k < 2000; ++k) { p = 50 + 40 * sin(k / 60); \
  printf "%.10g,%.10g,%.10g\n", sprintf("%.0f", k * 1.4) / 1000, p, 0.3 * p + 2 + 3 * sin(k / 60 + 0.4) } }' \
  > "$T/coarse.csv"
for f in lost:0.001 coarse:0.0014; do
  "$BIN" evaluate --model "$T/gpi.json" --data "$T/${f%%:*}.csv" --input p --output y --time-column t \
    --sample-time "${f#*:}" > "$T/st.txt" 2>&1
  ! grep -q "disagrees" "$T/st.txt" || fail "${f%%:*}.csv: --sample-time ${f#*:} refused: $(cat "$T/st.txt")"
done
# rate-pi fitted on the rounded stamps runs at their mean step
fit --data "$T/q.csv" --time-column t --out "$T/q.json" > /dev/null 2>&1 || true
near "$(model_dt "$T/q.json")" 0.001887 0.005 || fail "rate-pi on 1.887 ms rounded to 1 ms: dt $(model_dt "$T/q.json")"
# the measured records: the piezo's 5 kHz (0.2 ms), Festo test8's 1.887 ms
D="$2/../shared/data"
if [ -f "$D/piezo-sine/piezo_150V_1Hz.csv" ]; then
  s=$(step_of "$D/piezo-sine/piezo_150V_1Hz.csv" 3 2 1)
  near "${s:-nan}" 0.0002 1e-4 || fail "piezo: the step ${s:-none} s, not 0.2 ms"
  s=$(step_of "$D/pam-force-pressure/festo10mm_20cm_test8.csv" 1 0 2)
  near "${s:-nan}" 0.00188719 1e-5 || fail "Festo test8: the step ${s:-none} s, not its mean 1.88719 ms"
else
  echo "time_base: ../shared/data absent: the measured records' steps not checked"
fi

[ $fails -eq 0 ] && echo "time_base: all passed"
exit $fails
