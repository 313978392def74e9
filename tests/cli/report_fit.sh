#!/usr/bin/env bash
# hysteron fit --report fit.json, then hysteron report fit.json (the report names its
# data) and hysteron report fit.json --data ...: an HTML report with the three fit
# plots; a report that does not name its data and no --data: a clear error.
# Usage: bash report_fit.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
/usr/bin/python3 - "$T/x.csv" <<'PYEOF'
import sys
with open(sys.argv[1], "w") as f:
    f.write("pressure\n")
    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1):
        for k in range(300):
            f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/data.csv"
"$BIN" fit --data "$T/data.csv" --input input --output output --train 0:1200 --out "$T/m.json" --report "$T/fit.json" > /dev/null
"$BIN" report "$T/fit.json" --out "$T/r0.html"
[ "$(grep -o '<svg' "$T/r0.html" | wc -l)" -eq 3 ]
/usr/bin/python3 - "$T/fit.json" "$T/nodata.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
del d["data"], d["format"], d["schema"]
json.dump(d, open(sys.argv[2], "w"))
PYEOF
if "$BIN" report "$T/nodata.json" --out "$T/r.html" 2> "$T/err"; then
  echo "report without data should fail"; exit 1
fi
grep -q "nodata.json: the report does not name its data" "$T/err"
"$BIN" report "$T/fit.json" --data "$T/data.csv" --input input --output output --out "$T/r.html"
[ "$(grep -o '<svg' "$T/r.html" | wc -l)" -eq 3 ]
grep -q "after training (validation)" "$T/r.html"
# the page never replaces the record the fit report names (it wrote HTML over it)
cp "$T/data.csv" "$T/data.before"
if "$BIN" report "$T/fit.json" --out "$T/data.csv" 2> "$T/err"; then echo "report --out the fit's data file should fail"; exit 1; fi
grep -q "is the data file $T/fit.json names" "$T/err" || { echo "report --out the fit's data file: $(cat "$T/err")"; exit 1; }
cmp -s "$T/data.csv" "$T/data.before" || { echo "report --out the fit's data file: the record was replaced"; exit 1; }
# malformed JSON names the file
echo '{"status": ' > "$T/bad.json"
if "$BIN" report "$T/bad.json" --out "$T/x.html" 2> "$T/err"; then exit 1; fi
grep -q "bad.json: not valid JSON" "$T/err"
[ ! -e "$T/x.html" ]
# the rows a sensor-fault warning names are marked on the record's figures (loops and output over the record), in
# the page fit writes and in the one regenerated from its JSON; a clean record's page marks none
grep -q "sensor fault (see the warnings)" "$T/r0.html" && { echo "a clean record's report marks sensor faults"; exit 1; }
/usr/bin/python3 - "$T/data.csv" "$T/stuck.csv" <<'PYEOF'
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n") if r]
with open(sys.argv[2], "w") as f:
    f.write(",".join(rows[0]) + "\n")
    for i, r in enumerate(rows[1:]):
        f.write(f"{r[0]},{rows[1 + 365][1] if 365 <= i < 435 else r[1]}\n")  # the output frozen while the input rises
PYEOF
set +e
"$BIN" fit --data "$T/stuck.csv" --input input --output output --out "$T/ms.json" --report "$T/stuck.html" > /dev/null 2>&1
"$BIN" fit --data "$T/stuck.csv" --input input --output output --out "$T/ms.json" --force --report "$T/stuck.json" > /dev/null 2>&1
set -e
"$BIN" report "$T/stuck.json" --out "$T/stuck_again.html"
for page in stuck.html stuck_again.html; do
  [ "$(grep -c "output sensor fault (see the warnings)" "$T/$page")" -ge 2 ] \
    || { echo "$page: the stuck rows are not marked on both figures"; exit 1; }
  grep -q "input sensor fault" "$T/$page" && { echo "$page: an input fault marked"; exit 1; }
  grep -q "the rows the sensor-fault warnings name are marked" "$T/$page" || { echo "$page: no caption"; exit 1; }
done
echo "report_fit: ok"
