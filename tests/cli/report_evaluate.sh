#!/usr/bin/env bash
# hysteron evaluate --report ev.json, then hysteron report ev.json: the evaluation page (loops,
# output over the record, residuals; the document's metrics and what it records besides), from a
# model fitted on one measured record and evaluated on a segment of another (the Festo records of
# ../shared/data, or $HYSTERON_SHARED_DATA; a simulated pair where they are absent). The time
# column in ms (data.time_unit) draws the page the one in s draws, as does a document without
# time_unit (s). Errors: an unknown "format" is named; a missing data file is named, exit 1,
# nothing written and an existing --out left as it was; another record given by --data is refused.
# evaluate's own page words its "Data:" line as report's; --data with --input or --output alone
# keeps the other column, the document's time column is looked up in --data's file (refused,
# naming both, where it is not there; --time-column / --time-unit / --no-time), and a read
# error of the data given names the document and the file.
# Usage: bash report_evaluate.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail
BIN=$(cd "$(dirname "$BIN")" && pwd)/$(basename "$BIN")  # absolute: the evaluations run in $T

# two records, no header: 0 = output (force [N]), 1 = input (pressure [kPa]), 2 = time [s]
D="${HYSTERON_SHARED_DATA:-$2/../shared/data}/pam-force-pressure"
if [ -f "$D/festo10mm_20cm_test8.csv" ] && [ -f "$D/festo10mm_20cm_test9.csv" ]; then
  cp "$D/festo10mm_20cm_test8.csv" "$T/train.csv"
  cp "$D/festo10mm_20cm_test9.csv" "$T/track.csv"
  RANGE=2000:12000
  echo "report_evaluate: the Festo records (fit on test8, evaluate on test9 samples $RANGE)"
else
  echo "report_evaluate: ../shared/data absent: a simulated pair of records"
  cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
  $PY - "$T/x.csv" <<'PYEOF'
import sys
with open(sys.argv[1], "w") as f:
    f.write("pressure\n")
    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1, 0.45, 0.25):
        for k in range(300):
            f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
  # the tracking run on a muscle that has changed a little since (another c)
  sed 's/"c": \[60, 4, -0.5, 30\]/"c": [63, 4, -0.6, 28]/' "$T/gpi.json" > "$T/gpi2.json"
  "$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/sim.csv" || fail "simulate"
  "$BIN" simulate --model "$T/gpi2.json" --input "$T/x.csv" --output "$T/sim2.csv" || fail "simulate"
  $PY - "$T/sim.csv" "$T/sim2.csv" "$T/train.csv" "$T/track.csv" <<'PYEOF'
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n")[1:] if r]
rows2 = [r.split(",") for r in open(sys.argv[2]).read().split("\n")[1:] if r]
for name, part in ((sys.argv[3], rows[:1800]), (sys.argv[4], rows2[1800:])):
    with open(name, "w") as f:
        for i, (x, y) in enumerate(part):
            f.write(f"{y},{x},{i * 0.002!r}\n")
PYEOF
  RANGE=100:500
fi

"$BIN" fit --model gpi --data "$T/train.csv" --input 1 --output 0 --time-column 2 --threads 1 \
  --out "$T/m.json" > /dev/null 2> "$T/err" || fail "fit: $(cat "$T/err")"
# evaluated on a segment of the other record, the document written beside its data (relative paths)
(cd "$T" && "$BIN" evaluate --model m.json --data track.csv --input 1 --output 0 --time-column 2 --range "$RANGE" \
  --input-label "Pressure [kPa]" --output-label "Force [N]" --report ev.json > /dev/null 2> "$T/err") \
  || fail "evaluate --report ev.json: $(cat "$T/err")"

# 1. the page: three figures, the document's metrics and records, the model and data files
"$BIN" report "$T/ev.json" --out "$T/ev.html" 2> "$T/err" || fail "report ev.json: $(cat "$T/err")"
[ "$(grep -o '<svg' "$T/ev.html" 2>/dev/null | wc -l)" -eq 3 ] || fail "report ev.json: expected 3 figures"
for s in "Hysteresis loops: measured and model" "Output over the record" "Residuals" "Force \[N\]" \
  "Pressure \[kPa\]" "Time \[s\]" "Model: m.json" "track.csv" "Recorded by the evaluation" "R²" \
  "hysteron evaluate: gpi model"; do
  grep -q "$s" "$T/ev.html" 2>/dev/null || fail "report ev.json: no '$s' on the page"
done
$PY - "$T/ev.json" "$T/ev.html" <<'PYEOF' || fail "report ev.json: the page lacks the document's values"
import json, sys
d = json.load(open(sys.argv[1]))
html = open(sys.argv[2]).read()
m = d["metrics"]
assert d["format"] == "hysteron-evaluation", d["format"]
# the metrics row of the evaluated range: RMS, max, MAE (4 digits), % of span (3), R^2 (5), samples
b, e = m["range"]
row = (f"samples {b}..{e} [N]</td><td>{m['rms']:.4g}</td><td>{m['max']:.4g}</td><td>{m['mae']:.4g}</td>"
       f"<td>{m['rms_percent_span']:.3g}</td><td>{m['r2']:.5g}</td><td>{m['n']}</td>")
assert row in html, row
for label, v in (("censored samples (output at its clip limit, no error)", str(m["censored_samples"])),
                 ("samples outside the model&#39;s input limits", str(m["outside_input_limits"])),
                 ("output map: gain (record&#39;s output against the prediction)", f"{m['output_map']['gain']:.6g}"),
                 ("output map: R² mapped", f"{m['output_map']['r2_mapped']:.5g}")):
    cell = f"{label}</td><td>{v}</td>"
    assert cell in html, cell
print("report_evaluate: rms", m["rms"], "r2", m["r2"], "on", m["n"], "samples")
PYEOF

# 2. data.time_unit: the record's time in ms read as ms draws the same figures; a document
# without time_unit (before it was recorded) reads its time column as s
$PY - "$T/track.csv" "$T/track_ms.csv" <<'PYEOF'
import sys
with open(sys.argv[2], "w") as f:
    for r in open(sys.argv[1]).read().split("\n"):
        if r:
            c = r.split(",")
            c[2] = repr(float(c[2]) * 1000.0)
            f.write(",".join(c) + "\n")
PYEOF
(cd "$T" && "$BIN" evaluate --model m.json --data track_ms.csv --input 1 --output 0 --time-column 2 --time-unit ms \
  --range "$RANGE" --input-label "Pressure [kPa]" --output-label "Force [N]" --report ev_ms.json > /dev/null 2>&1) \
  || fail "evaluate --time-unit ms"
$PY - "$T/ev.json" "$T/ev_ms.json" "$T/ev_old.json" <<'PYEOF' || fail "time_unit: the documents"
import json, sys
ms = json.load(open(sys.argv[2]))
assert ms["data"]["time_unit"] == "ms", ms["data"]
d = json.load(open(sys.argv[1]))
del d["data"]["time_unit"]
json.dump(d, open(sys.argv[3], "w"))
PYEOF
"$BIN" report "$T/ev_ms.json" --out "$T/ev_ms.html" 2> "$T/err" || fail "report ev_ms.json: $(cat "$T/err")"
"$BIN" report "$T/ev_old.json" --out "$T/ev_old.html" 2> "$T/err" || fail "report ev_old.json: $(cat "$T/err")"
svgs() { sed -n '/<svg/,/<\/svg>/p' "$1" | grep -v '<title>\|<desc>'; }
# the figures compared through the time axis' tick labels (a time column drawn in ms reaches 1000 times as far)
ticks() { svgs "$1" | grep -o '<tspan[^>]*>[^<]*</tspan>' | tr -d '\n'; }
[ -n "$(ticks "$T/ev.html")" ] || fail "time_unit: no tick labels found in the page's figures"
[ "$(ticks "$T/ev_ms.html")" = "$(ticks "$T/ev.html")" ] || fail "time_unit ms: the figures' axes differ from the s record's"
[ "$(ticks "$T/ev_old.html")" = "$(ticks "$T/ev.html")" ] || fail "no time_unit: not read as s"

# 3. errors
# an unknown format is named, nothing written
$PY - "$T/ev.json" "$T/other.json" "$T/gone.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["format"] = "hysteron-sweep"
json.dump(d, open(sys.argv[2], "w"))
d = json.load(open(sys.argv[1]))
d["data"]["input"]["file"] = d["data"]["output"]["file"] = "gone.csv"
json.dump(d, open(sys.argv[3], "w"))
PYEOF
"$BIN" report "$T/other.json" --out "$T/x.html" 2> "$T/err"
[ $? -eq 1 ] || fail "unknown format: not exit 1"
grep -q 'other.json: unknown document format "hysteron-sweep"' "$T/err" || fail "unknown format: $(cat "$T/err")"
[ ! -e "$T/x.html" ] || fail "unknown format: a page was written"
# a missing data file: named, exit 1, no page; an existing --out is left as it was
"$BIN" report "$T/gone.json" --out "$T/x.html" 2> "$T/err"
[ $? -eq 1 ] || fail "missing data file: not exit 1"
grep -q "gone.json: data: data file gone.csv not found" "$T/err" || fail "missing data file: $(cat "$T/err")"
[ ! -e "$T/x.html" ] || fail "missing data file: a page was written"
echo "an older page" > "$T/keep.html"
"$BIN" report "$T/gone.json" --out "$T/keep.html" 2> /dev/null
[ $? -eq 1 ] || fail "missing data file, existing --out: not exit 1"
[ "$(cat "$T/keep.html")" = "an older page" ] || fail "missing data file: the existing --out was replaced"
# the data given by hand (--data) must be the record evaluated: the training record is refused
"$BIN" report "$T/ev.json" --data "$T/train.csv" --input 1 --output 0 --out "$T/x.html" 2> "$T/err"
[ $? -eq 1 ] || fail "another record by --data: not exit 1"
grep -q "not the record the evaluation used" "$T/err" || fail "another record by --data: $(cat "$T/err")"
[ ! -e "$T/x.html" ] || fail "another record by --data: a page was written"
# ... and the record itself by hand gives the page
"$BIN" report "$T/ev.json" --data "$T/track.csv" --input 1 --output 0 --out "$T/x.html" 2> "$T/err" \
  || fail "report ev.json --data track.csv: $(cat "$T/err")"
# the page never replaces the record the document names (it wrote HTML over it), nor a fit's
chmod u+w "$T/track.csv"  # (a copy of a read-only shared file: refused as read-only, not as the data)
cp "$T/track.csv" "$T/track.before"
(cd "$T" && "$BIN" report ev.json --out track.csv) 2> "$T/err"
[ $? -eq 1 ] || fail "--out the document's data file: not exit 1"
grep -q "is the data file ev.json names" "$T/err" || fail "--out the document's data file: $(cat "$T/err")"
cmp -s "$T/track.csv" "$T/track.before" || fail "--out the document's data file: the record was replaced"
# a schema that is not a number: the file named, exit 1 (was an internal error, exit 4)
$PY - "$T/ev.json" "$T/schema.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["schema"] = "1"
json.dump(d, open(sys.argv[2], "w"))
PYEOF
"$BIN" report "$T/schema.json" --out "$T/x2.html" 2> "$T/err"
[ $? -eq 1 ] || fail "schema \"1\": not exit 1: $(cat "$T/err")"
grep -q 'schema.json: unsupported evaluation schema "1"' "$T/err" || fail "schema \"1\": $(cat "$T/err")"
[ ! -e "$T/x2.html" ] || fail "schema \"1\": a page was written"

# 4. the page's "Data:" line: `evaluate --report x.html` and `report ev.json` word it alike
(cd "$T" && "$BIN" evaluate --model m.json --data track.csv --input 1 --output 0 --time-column 2 --range "$RANGE" \
  --input-label "Pressure [kPa]" --output-label "Force [N]" --report direct.html > /dev/null 2> "$T/err") \
  || fail "evaluate --report direct.html: $(cat "$T/err")"
dataline() { grep -o '<p>Data: [^<]*</p>' "$1"; }
[ -n "$(dataline "$T/direct.html")" ] || fail "Data line: none on evaluate's page"
[ "$(dataline "$T/direct.html")" = "$(dataline "$T/ev.html")" ] \
  || fail "Data line: evaluate's '$(dataline "$T/direct.html")', report's '$(dataline "$T/ev.html")'"

# 5. report --data/--input/--output/--time-column/--no-time: each replaces only its own part
mkdir -p "$T/moved" && cp "$T/track.csv" "$T/moved/track.csv"
"$BIN" report "$T/ev.json" --data "$T/moved/track.csv" --input 1 --out "$T/in_only.html" 2> "$T/err" \
  || fail "report --data --input (no --output): $(cat "$T/err")"
"$BIN" report "$T/ev.json" --data "$T/moved/track.csv" --output 0 --out "$T/out_only.html" 2> "$T/err" \
  || fail "report --data --output (no --input): $(cat "$T/err")"
grep -q "Time \[s\]" "$T/in_only.html" 2>/dev/null || fail "report --data: the document's time column not drawn"
# a file without the document's time column (column 2): refused naming both, with what to give
cut -d, -f1,2 "$T/track.csv" > "$T/moved/notime.csv"
"$BIN" report "$T/ev.json" --data "$T/moved/notime.csv" --input 1 --output 0 --out "$T/x3.html" 2> "$T/err"
[ $? -eq 1 ] || fail "--data without the time column: not exit 1"
for s in "ev.json: data: time column 2" "moved/notime.csv" "--time-column" "--no-time"; do
  grep -q -- "$s" "$T/err" || fail "--data without the time column: no '$s' in: $(cat "$T/err")"
done
[ ! -e "$T/x3.html" ] || fail "--data without the time column: a page was written"
"$BIN" report "$T/ev.json" --data "$T/moved/notime.csv" --input 1 --output 0 --no-time --out "$T/notime.html" 2> "$T/err" \
  || fail "report --data --no-time: $(cat "$T/err")"
grep -q "Sample" "$T/notime.html" && ! grep -q "Time \[s\]" "$T/notime.html" \
  || fail "report --no-time: not drawn against the sample index"
# its own time column, given in ms
$PY - "$T/track.csv" "$T/moved/swapped.csv" <<'PYEOF'
import sys
with open(sys.argv[2], "w") as f:
    for r in open(sys.argv[1]).read().split("\n"):
        if r:
            c = r.split(",")
            f.write(",".join([repr(float(c[2]) * 1000.0), c[1], c[0]]) + "\n")
PYEOF
"$BIN" report "$T/ev.json" --data "$T/moved/swapped.csv" --input 1 --output 2 --time-column 0 --time-unit ms \
  --out "$T/swapped.html" 2> "$T/err" || fail "report --time-column --time-unit: $(cat "$T/err")"
[ "$(ticks "$T/swapped.html")" = "$(ticks "$T/ev.html")" ] || fail "report --time-column 0 --time-unit ms: other axes"
# a read error of the data given names the document and the file
"$BIN" report "$T/ev.json" --data "$T/moved/track.csv" --input 7 --out "$T/x3.html" 2> "$T/err"
[ $? -eq 1 ] || fail "--input 7: not exit 1"
grep -q "ev.json: data: input column 7: .*moved/track.csv" "$T/err" || fail "--input 7: $(cat "$T/err")"

[ $fails -eq 0 ] && echo "report_evaluate: all passed"
exit $fails
