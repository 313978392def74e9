#!/usr/bin/env bash
# hysteron experiment --reference SPEC: a bad spec (an unknown key, a missing key, a value that is
# no finite number or out of range, a missing file, a duplicate name, a trajectory finer than the
# control period) is exit 1 naming the option and the key, before anything runs, and --out is not
# created; a user sine runs (fast: no learning, no adaptive, the model pinned) with its name in the
# table, the CSV files and result.json, and no published figures.
# Usage: bash experiment_reference.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail, expect_error

# refused "what" "part of the message" command...: expect_error, and nothing ran, $T/o not created
refused() {
  expect_error "$@"
  grep -qF -- "identification" "$T/out.txt" && fail "$1: something ran: $(head -3 "$T/out.txt")"
  [ ! -e "$T/o" ] || fail "$1: $T/o was written"
}

run=("$BIN" experiment gpi-pid --out "$T/o")
refused "bad key" "--reference 'sine:amplitude=20,offset=50,frequency=0.5,periods=2,phase=1': unknown key \"phase\"" \
  "${run[@]}" --reference sine:amplitude=20,offset=50,frequency=0.5,periods=2,phase=1
refused "missing key" "missing key \"periods\"" "${run[@]}" --reference sine:amplitude=20,offset=50,frequency=0.5
refused "bad value" "frequency = \"fast\" is not a finite number" \
  "${run[@]}" --reference triangle:amplitude=20,offset=50,frequency=fast,periods=2
refused "inf" "offset = \"inf\" is not a finite number" \
  "${run[@]}" --reference sine:amplitude=20,offset=inf,frequency=0.5,periods=2
refused "hex" "amplitude = \"0x10\" is not a finite number" \
  "${run[@]}" --reference sine:amplitude=0x10,offset=50,frequency=0.5,periods=2
refused "frequency 0" "frequency = 0 Hz must be > 0" "${run[@]}" --reference sine:amplitude=20,offset=50,frequency=0,periods=2
refused "negative amplitude" "amplitude = -5 mm must be >= 0" \
  "${run[@]}" --reference sine:amplitude=-5,offset=50,frequency=0.5,periods=2
refused "periods 0" "periods = 0 must be a whole number" "${run[@]}" --reference sine:amplitude=5,offset=50,frequency=0.5,periods=0
refused "periods 1.5" "periods = 1.5 must be a whole number" \
  "${run[@]}" --reference sine:amplitude=5,offset=50,frequency=0.5,periods=1.5
refused "unknown kind" "expected sine:KEY=VALUE" "${run[@]}" --reference square:amplitude=5
refused "missing file" "$T/none.csv" "${run[@]}" --reference "file:$T/none.csv"
refused "file key" "unknown key \"column\"" "${run[@]}" --reference "file:$T/none.csv,column=2"
refused "duplicate name" "its name \"a\" is that of" "${run[@]}" \
  --reference sine:amplitude=5,offset=50,frequency=0.5,periods=1,name=a \
  --reference triangle:amplitude=5,offset=50,frequency=0.5,periods=1,name=a
refused "too fast" "frequency = 30 Hz needs more than the control period resolves" \
  "${run[@]}" --reference sine:amplitude=5,offset=50,frequency=30,periods=1
# a record that is not increasing, and one finer than the control period
printf 't,x\n0,30\n0.5,40\n0.4,50\n' > "$T/back.csv"
refused "time backwards" "does not increase at sample 2" "${run[@]}" --reference "file:$T/back.csv"
{ echo "t,x"; for k in $(seq 0 100); do echo "$(echo "$k * 0.001" | bc -l),$((30 + (k % 2) * 10))"; done; } > "$T/fine.csv"
refused "finer than the period" "needs more than the control period resolves" \
  "${run[@]}" --control-period 0.01 --reference "file:$T/fine.csv"

# a user sine runs under its name; no figures of a paper beside it
"$BIN" experiment gpi-pid --learning-periods 0 --no-adaptive --model gpi \
  --reference sine:amplitude=20,offset=50,frequency=0.5,periods=2,name=mine --out "$T/ok" > "$T/ok.txt" 2>&1
rc=$?
[ $rc -eq 0 ] || fail "user sine: exit $rc: $(tail -5 "$T/ok.txt")"
for v in faithful compensated baseline; do
  [ -s "$T/ok/tracking_${v}_mine.csv" ] || fail "no tracking_${v}_mine.csv: $(ls "$T/ok")"
done
ls "$T/ok" | grep -q "tracking_.*_sine.csv" && fail "the paper's sine was tracked too: $(ls "$T/ok")"
grep -q "paper Fig\. 1[123]" "$T/ok/report.html" && fail "report.html captions a user reference as the paper's figure"
grep -q "Desired and measured contraction, mine reference\." "$T/ok/report.html" || fail "report.html: no tracking caption"
grep -qE "^  mine +published +- +- +-$" "$T/ok.txt" || fail "no published row of dashes: $(cat "$T/ok.txt")"
$PY - "$T/ok/result.json" <<'PYEOF' || fail "result.json"
import json, math, sys
r = json.load(open(sys.argv[1]))
assert [x["reference"] for x in r["references"]] == ["mine"], r["references"]
assert r["published"]["mine"] == {}, r["published"]
assert r["compensated"]["rms_error_mm"] < r["baseline"]["rms_error_mm"], (r["compensated"], r["baseline"])
PYEOF

# a record in --out under an output file's name (the run would replace it, or remove it as stale):
# refused before anything runs, also through a symbolic link, and the record is kept
replay=(--learning-periods 0 --no-adaptive --model gpi --out "$T/ok")
refused_kept() {
  expect_error "$@"
  grep -qF -- "identification" "$T/out.txt" && fail "$1: something ran"
  [ -s "$T/ok/tracking_faithful_mine.csv" ] || fail "$1: the record was removed: $(ls "$T/ok")"
}
refused_kept "record in --out" "--reference $T/ok/tracking_faithful_mine.csv are the same file" \
  "$BIN" experiment gpi-pid "${replay[@]}" \
  --reference "file:$T/ok/tracking_faithful_mine.csv,time=t_s,contraction=measured_mm,name=replayed"
ln -s "$T/ok/tracking_faithful_mine.csv" "$T/link.csv"
refused_kept "record in --out, linked" "--reference $T/link.csv are the same file" \
  "$BIN" experiment gpi-pid "${replay[@]}" --reference "file:$T/link.csv,time=t_s,contraction=measured_mm,name=replayed"
refused_kept "sweep --out the record" "--reference $T/link.csv are the same file" \
  "$BIN" sweep gpi-pid --vary load.mass=20 --reference "file:$T/link.csv,time=t_s,contraction=measured_mm" \
  --out "$T/ok/tracking_faithful_mine.csv"
head -c 10 "$T/ok/tracking_faithful_mine.csv" | grep -q "^t_s," || fail "sweep replaced the record"

# sweep takes the same --reference: checked before any run, then every run tracks it
"$BIN" sweep gpi-pid --vary load.mass=20 --reference sine:amplitude=20,offset=50,frequency=0,periods=2 \
  --out "$T/s.csv" > "$T/out.txt" 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "sweep bad spec: exit $rc"
grep -qF "frequency = 0 Hz must be > 0" "$T/err.txt" || fail "sweep bad spec: $(cat "$T/err.txt")"
[ ! -e "$T/s.csv" ] || fail "sweep bad spec wrote its table"
"$BIN" sweep gpi-pid --vary load.mass=20 --learning-periods 0 --model gpi --jobs 1 \
  --reference triangle:amplitude=20,offset=50,frequency=0.5,periods=2,name=mine --out "$T/s.csv" > "$T/out.txt" 2>&1
rc=$?
[ $rc -eq 0 ] || fail "sweep: exit $rc: $(tail -3 "$T/out.txt")"
grep -q ",mine," "$T/s.csv" || fail "sweep: no run of the reference mine: $(head -3 "$T/s.csv")"
grep -q ",sine," "$T/s.csv" && fail "sweep: the paper's sine was tracked too"
exit $fails
