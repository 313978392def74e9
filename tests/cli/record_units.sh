#!/usr/bin/env bash
# A record's units (docs/data-files.md, "Units"): a header "p [kPa]" or a units row below the
# header names them. `fit` writes them into the model file ("units"), a --validate-data file
# whose columns name other units is refused, and so is `evaluate` of a record in units other
# than the model's (a record in bar scored by a model fitted in kPa: every value 100x off,
# silently); agreeing units, or a record or model that names none, are not checked. A column is
# selected by its name without the unit ("p" for "p [kPa]"). The experiments' models record
# MPa / mm. simulate and invert check their input column against the model's units too (a pipe too).
# Usage: bash record_units.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

# a PI-like record: input in kPa, output in N (the header), the same in bar, and one without units
$PY - "$T" <<'PYEOF'
import math, sys
d = sys.argv[1]
rows = [300 + 250 * math.sin(k / 80) * (0.5 + 0.5 * math.cos(k / 900)) for k in range(3000)]
y = []
z = rows[0]
for k, p in enumerate(rows):  # one play of width 40 kPa plus a linear term, a little noise
    z = min(max(z, p - 40), p + 40)
    y.append(0.8 * p + 0.5 * z + 3 * math.sin(k / 7))
def write(name, head, scale, units=None):
    with open(f"{d}/{name}", "w") as f:
        f.write(head + "\n")
        if units:
            f.write(units + "\n")
        f.writelines(f"{k * 0.001!r},{rows[k] * scale!r},{y[k]!r}\n" for k in range(len(rows)))
write("kpa.csv", "t [s],p [kPa],F [N]", 1)
write("row.csv", "t,p,F", 1, "s,kPa,N")
write("bar.csv", "t [s],p [bar],F [N]", 0.01)
write("plain.csv", "t,p,F", 1)
PYEOF

"$BIN" fit --model pi --data "$T/kpa.csv" --input p --output F --time-column t --out "$T/m.json" > /dev/null 2> "$T/err.txt" \
  || fail "fit on p [kPa] selected as p: exit $?: $(cat "$T/err.txt")"
$PY -c "import json,sys; u=json.load(open(sys.argv[1])).get('units'); assert u == {'input': 'kPa', 'output': 'N'}, u" \
  "$T/m.json" || fail "the model file does not record the record's units"
"$BIN" fit --model pi --data "$T/plain.csv" --input p --output F --out "$T/plain.json" > /dev/null 2>&1 \
  || fail "fit on a record without units: exit $?"
$PY -c "import json,sys; assert 'units' not in json.load(open(sys.argv[1]))" "$T/plain.json" \
  || fail "a model fitted on a record without units records some"
"$BIN" fit --model pi --data "$T/plain.csv" --input p --output F --input-label "Pressure [psi]" --out "$T/psi.json" \
  > /dev/null 2>&1 || fail "fit --input-label: exit $?"
$PY -c "import json,sys; u=json.load(open(sys.argv[1])).get('units'); assert u == {'input': 'psi'}, u" "$T/psi.json" \
  || fail "fit --input-label [psi]: the model's units"

# evaluate: the same units (header or units row, any case of brackets) pass; other units are refused
for f in kpa row plain; do
  "$BIN" evaluate --model "$T/m.json" --data "$T/$f.csv" --input p --output F > /dev/null 2> "$T/err.txt" \
    || fail "evaluate $f.csv: exit $?: $(cat "$T/err.txt")"
done
"$BIN" evaluate --model "$T/m.json" --data "$T/bar.csv" --input p --output F --report "$T/ev.json" > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "evaluate of a record in bar with a model in kPa: exit $rc (expected 1)"
grep -q "bar.csv: the input column p is in bar, but the model .*m.json's input is in kPa" "$T/err.txt" \
  || fail "evaluate bar: $(cat "$T/err.txt")"
[ -e "$T/ev.json" ] && fail "evaluate bar: a report written"
# (evaluated, not refused; its values 100 times smaller score far worse than the training error: exit 3)
"$BIN" evaluate --model "$T/plain.json" --data "$T/bar.csv" --input p --output F > /dev/null 2>&1
rc=$?
[ $rc -eq 3 ] || fail "evaluate with a model without units: exit $rc (expected 3: evaluated, useless)"

# fit --validate-data in other units than the training record's: refused, nothing written
"$BIN" fit --model pi --data "$T/kpa.csv" --input p --output F --validate-data "$T/bar.csv" --out "$T/v.json" \
  > /dev/null 2> "$T/err.txt"
rc=$?
[ $rc -eq 1 ] || fail "fit --validate-data in bar: exit $rc (expected 1)"
grep -q "bar.csv: the input column p is in bar, but the training record .*kpa.csv's input is in kPa" "$T/err.txt" \
  || fail "fit --validate-data bar: $(cat "$T/err.txt")"
[ -e "$T/v.json" ] && fail "fit --validate-data bar: a model written"
"$BIN" fit --model pi --data "$T/kpa.csv" --input p --output F --validate-data "$T/row.csv" --out "$T/v.json" \
  > /dev/null 2>&1 || fail "fit --validate-data with the same units in a units row: exit $?"

# simulate / invert: the input column against the model's input (simulate) or output (invert) unit;
# without --column the column "input" ("output") is found with its unit; a pipe is checked as it is read
{ echo "t,input [bar],x"; tail -n +2 "$T/plain.csv"; } > "$T/sim_bar.csv"
{ echo "t,input [KPA],x"; tail -n +2 "$T/plain.csv"; } > "$T/sim_kpa.csv"
"$BIN" simulate --model "$T/m.json" --input "$T/sim_bar.csv" --output "$T/sim.csv" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "simulate of an input in bar with a model in kPa: not exit 1"
grep -q "sim_bar.csv: the column input is in bar, but the model .*m.json's input is in kPa" "$T/err.txt" \
  || fail "simulate bar: $(cat "$T/err.txt")"
[ -e "$T/sim.csv" ] && fail "simulate bar: an output written"
"$BIN" simulate --model "$T/m.json" --input "$T/sim_kpa.csv" --output "$T/sim.csv" > /dev/null 2> "$T/err.txt" \
  || fail "simulate of input [KPA] without --column: exit $?: $(cat "$T/err.txt")"
[ "$(wc -l < "$T/sim.csv")" -eq 3001 ] || fail "simulate of input [KPA]: $(wc -l < "$T/sim.csv") lines"
# a pipe is checked as it is read, before anything is written; to stdout alike
"$BIN" simulate --model "$T/m.json" --input <(cat "$T/sim_bar.csv") --output "$T/simp.csv" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "simulate of an input in bar from a pipe: not exit 1"
grep -q "the column input is in bar, but the model .*m.json's input is in kPa" "$T/err.txt" \
  || fail "simulate bar from a pipe: $(cat "$T/err.txt")"
[ -e "$T/simp.csv" ] && fail "simulate bar from a pipe: an output written"
"$BIN" simulate --model "$T/m.json" --input "$T/sim_bar.csv" --output - > "$T/out.txt" 2> "$T/err.txt"
[ $? -eq 1 ] || fail "simulate of an input in bar to stdout: not exit 1"
[ -s "$T/out.txt" ] && fail "simulate bar to stdout: rows printed"
"$BIN" simulate --model "$T/m.json" --input <(cat "$T/sim_kpa.csv") --output "$T/simp.csv" > /dev/null 2>&1 \
  || fail "simulate of input [KPA] from a pipe: exit $?"
{ echo "t,p,output [mm]"; tail -n +2 "$T/plain.csv"; } > "$T/inv_mm.csv"
"$BIN" invert --model "$T/m.json" --input "$T/inv_mm.csv" --output "$T/inv.csv" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "invert of an output in mm with a model in N: not exit 1"
grep -q "inv_mm.csv: the column output is in mm, but the model .*m.json's output is in N" "$T/err.txt" \
  || fail "invert mm: $(cat "$T/err.txt")"

# what is not compared: free text in the model's "units" ("Pressure [kPa]" is kPa, "kPa (gauge)" no
# known unit), brackets that are no unit ("x[0]"), prefixes of another case (mPa is not MPa)
$PY -c "import json,sys; d=json.load(open(sys.argv[1])); d['units']={'input': 'Pressure [kPa]', 'output': 'N (gauge)'}; \
  json.dump(d,open(sys.argv[2],'w'))" "$T/m.json" "$T/free.json"
"$BIN" evaluate --model "$T/free.json" --data "$T/kpa.csv" --input p --output F > /dev/null 2> "$T/err.txt" \
  || fail "evaluate with free-text units: exit $?: $(cat "$T/err.txt")"
"$BIN" evaluate --model "$T/free.json" --data "$T/bar.csv" --input p --output F > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "evaluate bar with 'Pressure [kPa]' in the model: not refused"
{ echo "t,x[0],x[1]"; tail -n +2 "$T/plain.csv"; } > "$T/vec.csv"
{ echo "t,u[1],y[1]"; tail -n +2 "$T/plain.csv"; } > "$T/vec2.csv"
"$BIN" fit --model pi --data "$T/vec.csv" --input "x[0]" --output "x[1]" --out "$T/vec.json" > /dev/null 2>&1 \
  || fail "fit on x[0]: exit $?"
$PY -c "import json,sys; assert 'units' not in json.load(open(sys.argv[1]))" "$T/vec.json" || fail "x[0]: a unit recorded"
"$BIN" evaluate --model "$T/vec.json" --data "$T/vec2.csv" --input "u[1]" --output "y[1]" > /dev/null 2>&1 \
  || fail "evaluate u[1] with a model fitted on x[0]: exit $?"
# a label whose unit contradicts the column's: refused (the model would record the wrong one)
"$BIN" fit --model pi --data "$T/bar.csv" --input p --output F --input-label "Pressure [kPa]" --out "$T/lab.json" \
  > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "fit --input-label [kPa] on a column in bar: not exit 1"
grep -q 'bar.csv: the input column p is in bar, but --input-label "Pressure \[kPa\]" says kPa' "$T/err.txt" \
  || fail "label against column: $(cat "$T/err.txt")"
[ -e "$T/lab.json" ] && fail "fit --input-label [kPa] on bar: a model written"

# two columns with the same name and different units: the bare name is ambiguous, named as such
{ echo "p [kPa],p [bar],F"; echo "1,0.01,2"; echo "2,0.02,3"; } > "$T/two.csv"
"$BIN" evaluate --model "$T/plain.json" --data "$T/two.csv" --input p --output F > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "an ambiguous bare name: not exit 1"
grep -q '2 columns are named "p" with a unit' "$T/err.txt" || fail "ambiguous bare name: $(cat "$T/err.txt")"

# the experiments' models record the rig's units
"$BIN" experiment gpi-pid --model gpi --learning-periods 0 --no-adaptive --out "$T/ex" > /dev/null 2>&1 \
  || fail "experiment: exit $?"
for m in model best_model; do
  $PY -c "import json,sys; u=json.load(open(sys.argv[1])).get('units'); assert u == {'input': 'MPa', 'output': 'mm'}, u" \
    "$T/ex/$m.json" || fail "experiment's $m.json: units"
done

# the model on stdin (--model -) goes through the same reader as a file: its units are checked
"$BIN" evaluate --model - --data "$T/bar.csv" --input p --output F < "$T/m.json" > /dev/null 2> "$T/err.txt"
[ $? -eq 1 ] || fail "evaluate --model - (a model in kPa) of a record in bar: not exit 1"
grep -q "bar.csv: the input column p is in bar, but the model <stdin>'s input is in kPa" "$T/err.txt" \
  || fail "evaluate --model - bar: $(cat "$T/err.txt")"
# export: the C file and its header state the model's units (and nothing for a model without)
"$BIN" export --model "$T/m.json" --out "$T/comp.c" --header "$T/comp.h" > /dev/null 2> "$T/err.txt" \
  || fail "export: exit $?: $(cat "$T/err.txt")"
for f in comp.c comp.h; do
  grep -q 'Units (the model file.s "units"): input kPa, output N\.' "$T/$f" || fail "export: $f does not state the units"
done
"$BIN" export --model "$T/plain.json" --out "$T/plain.c" > /dev/null 2>&1 || fail "export plain.json: exit $?"
grep -q "Units (the model" "$T/plain.c" && fail "export of a model without units states some"

[ $fails -eq 0 ] && echo "record_units: all passed"
exit $fails
