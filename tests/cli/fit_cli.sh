#!/usr/bin/env bash
# hysteron fit, as a new user would try it: --report x.html writes HTML (labels from
# --input-label/--output-label, time on the x axis with --time-column, every
# --validate-data file shown), each validate: line names its file, --model auto prints
# and writes the candidates, --out - prints only the model JSON, --json prints exactly one
# JSON document, --max-iterations, --train 0s:10 is an error, exit codes follow the
# documented table (0 converged, 1 error/usage, 2 no_convergence/failed, 3 poor_fit),
# and no Ceres/glog log line reaches the terminal.
# Usage: bash fit_cli.sh <hysteron-binary> <source-dir>
set -uo pipefail
source "$(dirname "$0")/lib/common.sh"  # BIN, T, PY, fail

# two records of the same actuator (different amplitudes), with a time column (10 ms)
gpi_record_pair
# glog's line format (MMDD or YYYYMMDD) and its "logging before InitGoogleLogging" notice
glog_lines() { grep -E '^[IWEF][0-9]{4,8} [0-9:.]+ |InitGoogleLogging' "$1"; }

# 1. HTML report by extension, labels, time axis, every validation file; validate: lines name their file
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --time-column t_s --train 0s:12s \
  --validate-data "$T/a.csv" --validate-data "$T/b.csv" --threads 1 --input-label "Pressure [MPa]" \
  --output-label "Contraction [mm]" --out "$T/m.json" --report "$T/fit.html" > "$T/fit.txt" 2> "$T/fit.err"
rc=$?
[ $rc -eq 0 ] || fail "fit exit $rc: $(cat "$T/fit.err")"
head -c 15 "$T/fit.html" | grep -q "<!DOCTYPE html>" || fail "--report fit.html is not HTML"
grep -q "Pressure \[MPa\]" "$T/fit.html" || fail "html: input label"
grep -q "Contraction \[mm\]" "$T/fit.html" || fail "html: output label"
grep -q "Time \[s\]" "$T/fit.html" || fail "html: no time axis with --time-column"
grep -q "validation: $T/b.csv" "$T/fit.html" || fail "html: the second --validate-data file is not shown"
grep -q "validation: $T/a.csv" "$T/fit.html" || fail "html: the first --validate-data file is not shown"
[ "$(grep -c "^validate: .*\[$T/a.csv" "$T/fit.txt")" -eq 1 ] || fail "no validate: line naming a.csv"
[ "$(grep -c "^validate: .*\[$T/b.csv" "$T/fit.txt")" -eq 1 ] || fail "no validate: line naming b.csv"
grep -q "^reference PI: rms" "$T/fit.txt" || fail "no reference PI line"
grep -q "^inverse: max slope .* max jump per sample" "$T/fit.txt" || fail "no inverse line"
glog_lines "$T/fit.err" && fail "glog lines on stderr"

# 2. JSON report by extension; --json is exactly one document and matches it
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --train 0:1200 --threads 1 --out "$T/m2.json" \
  --report "$T/fit.json" --json > "$T/fit_stdout.json" 2> "$T/json.err" || fail "fit --json"
$PY - "$T/fit.json" "$T/fit_stdout.json" "$T/m2.json" <<'PYEOF' || fail "JSON report / --json"
import json, sys
report = json.load(open(sys.argv[1]))
stdout = json.load(open(sys.argv[2]))   # json.load fails on a second document or trailing text
assert report["format"] == "hysteron-fit-report" and report["schema"] == 1
assert report["status"] == stdout["status"] == "converged"
assert report["train"] == stdout["train"]
for k in ("reference", "inverse", "warnings", "candidates", "data", "validate", "model_written"):
    assert k in report, k
assert report["model_written"] and report["model_file"].endswith("m2.json")
assert report["validate"]["n"] == 600, report["validate"]
assert json.load(open(sys.argv[3]))["model"] == "gpi"
PYEOF
[ -s "$T/json.err" ] && glog_lines "$T/json.err" && fail "glog lines on stderr (--json)"

# 3. --out -: only the model JSON on stdout, the summary on stderr
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --train 0:1200 --threads 1 --force --out - \
  > "$T/model_stdout.json" 2> "$T/summary.txt"
rc=$?
[ $rc -le 3 ] || fail "--out -: exit $rc"
$PY -c "import json,sys; m=json.load(open(sys.argv[1])); assert m['model']=='pi'" "$T/model_stdout.json" \
  || fail "--out -: stdout is not one model JSON: $(head -3 "$T/model_stdout.json")"
grep -q "pi fit" "$T/summary.txt" || fail "--out -: no summary on stderr"
"$BIN" fit --data "$T/a.csv" --input p --output y --out - --json > /dev/null 2> "$T/err"
[ $? -eq 1 ] || fail "--out - with --json must be an error (two documents on stdout)"
# --out naming stdout otherwise (/dev/stdout, the file stdout is redirected to) is --out -: refused with --json
"$BIN" fit --data "$T/a.csv" --input p --output y --out /dev/stdout --json > "$T/two.out" 2> "$T/err"
[ $? -eq 1 ] || fail "--out /dev/stdout with --json must be an error (two documents on stdout)"
grep -q "both write to standard output" "$T/err" || fail "--out /dev/stdout --json: $(cat "$T/err")"
"$BIN" fit --data "$T/a.csv" --input p --output y --out "$T/two.out" --json > "$T/two.out" 2> "$T/err"
[ $? -eq 1 ] || fail "--out (stdout's file) with --json must be an error"
# and its summary goes to stderr, as with --out -
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --train 0:1200 --threads 1 --force --out /dev/stdout \
  > "$T/model_devstdout.json" 2> "$T/summary2.txt"
$PY -c "import json,sys; m=json.load(open(sys.argv[1])); assert m['model']=='pi'" "$T/model_devstdout.json" \
  || fail "--out /dev/stdout: stdout is not one model JSON: $(tail -3 "$T/model_devstdout.json")"
grep -q "pi fit" "$T/summary2.txt" || fail "--out /dev/stdout: no summary on stderr"

# 4. --model auto: candidates in text and JSON, chosen kind in model_kind, validation RMS per candidate
"$BIN" fit --model auto --data "$T/a.csv" --input p --output y --train 0:1200 --validate-data "$T/b.csv" \
  --sample-time 0.001 --threads 1 --out "$T/auto.json" --report "$T/auto_report.json" > "$T/auto.txt" 2> "$T/auto.err"
rc=$?
$PY - "$T/auto_report.json" "$T/auto.txt" $rc <<'PYEOF' || fail "--model auto"
import json, sys
r = json.load(open(sys.argv[1]))
text = open(sys.argv[2]).read()
rc = int(sys.argv[3])
kinds = sorted(c["kind"] for c in r["candidates"])
assert kinds == sorted(["gpi", "mpi-asym", "mpi-deadzone", "pi", "preisach", "kp", "bouc-wen", "maxwell-slip",
                        "rate-pi"]), kinds
chosen = [c["kind"] for c in r["candidates"] if c["chosen"]]
assert chosen == [r["model_kind"]], (chosen, r["model_kind"])
for c in r["candidates"]:
    assert len(c["validate"]) == 1, c.get("validate")   # one --validate-data file
    assert c["kind"] in text
assert "candidates" in text and "<- chosen" in text
assert rc == {"converged": 0, "no_convergence": 2, "failed": 2, "poor_fit": 3}[r["status"]], (rc, r["status"])
# a row's status, train and validate RMS are its fold-0 fit's (the first 80 % of 0:1200), not the chosen kind's
# refit on the whole range: the JSON gives each candidate's fit_range, the text labels the columns and says so
for c in r["candidates"]:
    assert c["fit_range"] == [0, 960], (c["kind"], c.get("fit_range"))
for s in ("trained on samples 0..960", "refit on the whole training range (samples 0..1200)",
          "status (fold 0)", "train RMS (fold 0)", "validate RMS (fold 0)"):
    assert s in text, s
PYEOF
# not on a terminal (here a file), auto says as each of its 18 candidate fits (9 kinds x 2 folds) ends, one line each
[ "$(grep -c '^auto: [0-9]* of 18 candidate fits done (the last: ' "$T/auto.err")" = 18 ] &&
  grep -q '^auto: 18 of 18 candidate fits done' "$T/auto.err" ||
  fail "--model auto off a terminal: no line per candidate fit: $(cat "$T/auto.err")"
# the HTML report of that document (hysteron report reads fit_range back) labels them alike
"$BIN" report "$T/auto_report.json" --out "$T/auto_report.html" > /dev/null 2> "$T/auto_html.err" ||
  fail "report of the auto document: $(cat "$T/auto_html.err")"
for s in "trained on samples 0..960" "status (fold 0)" "train RMS (fold 0)" "validation RMS (fold 0)" \
  "refit on the whole training range (samples 0..1200)"; do
  grep -qF "$s" "$T/auto_report.html" || fail "auto HTML report lacks '$s'"
done

# 5. exit codes: no convergence (2, model not written; --force writes it), errors and usage (1)
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --max-iterations 1 --starts 1 --threads 1 \
  --out "$T/nc.json" > "$T/nc.txt" 2>&1
rc=$?
[ $rc -eq 2 ] || fail "--max-iterations 1: exit $rc (expected 2): $(cat "$T/nc.txt")"
[ -e "$T/nc.json" ] && fail "a model was written without convergence"
grep -q "model NOT written (no_convergence" "$T/nc.txt" || fail "no 'model NOT written' line"
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --max-iterations 1 --starts 1 --threads 1 --force \
  --out "$T/nc.json" > /dev/null 2>&1
rc=$?
[ $rc -eq 2 ] || fail "--force: exit $rc (expected 2)"
[ -s "$T/nc.json" ] || fail "--force did not write the model"
expect_rc1() {
  local what=$1 needle=$2
  shift 2
  "$@" > "$T/out" 2> "$T/err"
  local rc=$?
  if [ $rc -ne 1 ]; then fail "$what: exit $rc (expected 1)"; return; fi
  grep -qF -- "$needle" "$T/err" || fail "$what: stderr lacks '$needle': $(cat "$T/err")"
}
expect_rc1 "mixed units in --train" "mixes seconds and sample indices" \
  "$BIN" fit --data "$T/a.csv" --input p --output y --time-column t_s --train 0s:10 --out "$T/x.json"
expect_rc1 "unknown option" "--frobnicate" "$BIN" fit --data "$T/a.csv" --input p --output y --out "$T/x.json" --frobnicate
expect_rc1 "unknown model kind" "--model" "$BIN" fit --model spline --data "$T/a.csv" --input p --output y --out "$T/x.json"
expect_rc1 "not a number" "--max-iterations" \
  "$BIN" fit --data "$T/a.csv" --input p --output y --out "$T/x.json" --max-iterations many
expect_rc1 "no subcommand" "subcommand" "$BIN"
expect_rc1 "missing data file" "nope.csv" "$BIN" fit --data "$T/nope.csv" --input p --output y --out "$T/x.json"
[ -e "$T/x.json" ] && fail "a model was written by a failed fit"
"$BIN" fit --help > /dev/null 2>&1 || fail "fit --help exits non-zero"

# 6. poor fit: a record whose output is noise. Whatever the status, the exit code follows it.
$PY - "$T/noise.csv" <<'PYEOF'
import random, sys
random.seed(1)
with open(sys.argv[1], "w") as f:
    f.write("x,y\n")
    for i in range(2000):
        x = (i % 200) / 200 if (i // 200) % 2 == 0 else 1 - (i % 200) / 200
        f.write(f"{x!r},{random.gauss(0, 1)!r}\n")
PYEOF
for m in pi gpi; do
  "$BIN" fit --model $m --data "$T/noise.csv" --input x --output y --threads 1 --out "$T/noise_$m.json" --json \
    > "$T/noise_$m.txt" 2> "$T/noise.err"
  rc=$?
  $PY - "$T/noise_$m.txt" $rc "$T/noise_$m.json" <<'PYEOF' || fail "noise ($m): exit code does not follow the status"
import json, os, sys
r = json.load(open(sys.argv[1]))
rc = int(sys.argv[2])
expected = {"converged": 0, "no_convergence": 2, "failed": 2, "poor_fit": 3}[r["status"]]
assert rc == expected, (r["status"], rc)
assert os.path.exists(sys.argv[3]) == (r["status"] == "converged"), "model written iff converged"
print(f"noise: {r['status']} exit {rc} r2 {r['train']['r2']}")
PYEOF
  glog_lines "$T/noise.err" && fail "glog lines on stderr (noise)"
done

# 7. even with glog asked to be verbose (Ceres then logs every iteration), nothing reaches stderr
GLOG_v=10 GLOG_logtostderr=1 GLOG_minloglevel=0 "$BIN" fit --model gpi --data "$T/a.csv" --input p --output y \
  --threads 1 --out "$T/v.json" > /dev/null 2> "$T/verbose.err" || fail "verbose glog fit"
glog_lines "$T/verbose.err" > /dev/null && fail "glog lines on stderr with GLOG_v=10: $(head -2 "$T/verbose.err")"

# 8. a record whose sensor clips (the lowest third of a.csv's output read as its limit) is
#    fitted as censored data and says so; --censor-passes 0 fits it to the limit; 11 is refused
$PY - "$T/a.csv" "$T/clipped.csv" <<'PYEOF'
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n")[1:] if r]
ys = sorted(float(r[2]) for r in rows)
limit = ys[len(ys) // 3]
with open(sys.argv[2], "w") as f:
    f.write("t_s,p,y\n")
    for i, (t, p, y) in enumerate(rows):
        noise = 0.02 * (((i * 7919) % 101) / 50.0 - 1.0)  # deterministic, +-0.02
        f.write(f"{t},{p},{max(float(y) + noise, limit)!r}\n")
PYEOF
"$BIN" fit --model pi --data "$T/clipped.csv" --input p --output y --threads 1 --out "$T/c.json" \
  > "$T/c.txt" 2>&1 || fail "fit of a clipped record"
grep -q "fitted as censored data (2 refit(s)" "$T/c.txt" || fail "no censored-fit warning: $(grep warning "$T/c.txt")"
"$BIN" fit --model pi --data "$T/clipped.csv" --input p --output y --threads 1 --censor-passes 0 --out "$T/c0.json" \
  > "$T/c0.txt" 2>&1 || fail "fit of a clipped record with --censor-passes 0"
grep -q "fitted to the limit there" "$T/c0.txt" || fail "no as-recorded warning: $(grep warning "$T/c0.txt")"
"$BIN" fit --model pi --data "$T/clipped.csv" --input p --output y --censor-passes 11 --out "$T/c11.json" \
  > /dev/null 2> "$T/c11.err" && fail "--censor-passes 11 accepted"
grep -q "censor-passes" "$T/c11.err" || fail "--censor-passes 11: $(cat "$T/c11.err")"
[ -e "$T/c11.json" ] && fail "--censor-passes 11 wrote a model"

# 9. a validation record that clips is scored as censored, by fit --validate-data and by
#    evaluate, and they say so with the same count; --censor-passes 0 / --uncensored score it as
#    recorded, with a larger RMS
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/clipped.csv" \
  --out "$T/v9.json" --report "$T/v9r.json" > "$T/v9.txt" 2>&1 || fail "fit with a clipped validation record"
grep -q "^validate:.*samples at its limit where the model predicts beyond it scored as censored" "$T/v9.txt" \
  || fail "fit --validate-data: no censored note: $(grep validate: "$T/v9.txt")"
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/clipped.csv" \
  --censor-passes 0 --out "$T/v90.json" > "$T/v90.txt" 2>&1 || fail "fit --censor-passes 0 with a clipped validation record"
grep -q "scored as censored" "$T/v90.txt" && fail "--censor-passes 0 still scores the validation record as censored"
"$BIN" evaluate -m "$T/v9.json" -d "$T/clipped.csv" -i p -y y --json > "$T/e9.json" || fail "evaluate on a clipped record"
"$BIN" evaluate -m "$T/v9.json" -d "$T/clipped.csv" -i p -y y > "$T/e9.txt" || fail "evaluate (text) on a clipped record"
grep -q "^note: the output clips" "$T/e9.txt" || fail "evaluate: no censored note: $(cat "$T/e9.txt")"
"$BIN" evaluate -m "$T/v9.json" -d "$T/clipped.csv" -i p -y y --uncensored --json > "$T/e9u.json" \
  || fail "evaluate --uncensored"
$PY - "$T/v9r.json" "$T/e9.json" "$T/e9u.json" <<'PYEOF' || fail "censored validation figures"
import json, sys
fit_doc, cens, unc = (json.load(open(f)) for f in sys.argv[1:])
v = fit_doc["validate_files"][0]
c = cens["metrics"]
u = unc["metrics"]
assert v["censored_samples"] > 100, v
assert c["censored_samples"] == v["censored_samples"], (c, v)
assert abs(c["rms"] - v["rms"]) <= 1e-12 * max(1.0, v["rms"]), (c["rms"], v["rms"])
assert u["censored_samples"] == 0 and u["rms"] > 1.05 * c["rms"], (u, c)
PYEOF
# ... and the HTML reports say so: the validation row, the fit's own clipped record, evaluate's page
"$BIN" fit --model pi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/clipped.csv" \
  --out "$T/v9h.json" --report "$T/v9.html" > /dev/null 2>&1 || fail "fit --report html, clipped validation"
grep -q "clipped samples censored" "$T/v9.html" || fail "fit report: no censored validation row"
"$BIN" fit --model pi --data "$T/clipped.csv" --input p --output y --threads 1 --out "$T/c9.json" \
  --report "$T/c9.html" > /dev/null 2>&1 || fail "fit --report html of a clipped record"
grep -q "scored as censored, no error, as the fit treated them" "$T/c9.html" || fail "fit report: no censored note"
"$BIN" evaluate -m "$T/v9.json" -d "$T/clipped.csv" -i p -y y --report "$T/e9.html" > /dev/null \
  || fail "evaluate --report html"
grep -q "are scored as censored, no error" "$T/e9.html" || fail "evaluate report: no censored note"
"$BIN" evaluate -m "$T/v9.json" -d "$T/clipped.csv" -i p -y y --uncensored --report "$T/e9u.html" > /dev/null \
  || fail "evaluate --uncensored --report html"
grep -q "scored as censored" "$T/e9u.html" && fail "evaluate --uncensored report: censored note"
# a report regenerated from the fit's JSON scores the record as the fit did: censored by default,
# as recorded after --censor-passes 0 (the document's data.censored)
for passes in 2 0; do
  "$BIN" fit --model pi --data "$T/clipped.csv" --input p --output y --threads 1 --censor-passes $passes --force \
    --out "$T/r$passes.json" --report "$T/r$passes.report.json" > /dev/null 2>&1 || fail "fit --censor-passes $passes --report json"
  "$BIN" report "$T/r$passes.report.json" --out "$T/r$passes.html" > /dev/null 2>&1 || fail "report from the fit's JSON ($passes)"
done
grep -q "as the fit treated them" "$T/r2.html" || fail "regenerated report: no censored note"
grep -q "as the fit treated them" "$T/r0.html" && fail "regenerated report of a --censor-passes 0 fit scores censored"
$PY -c "import json,sys; d=[json.load(open(f))['data']['censored'] for f in sys.argv[1:]]; assert d == [True, False], d" \
  "$T/r2.report.json" "$T/r0.report.json" || fail "data.censored in the fit documents"

# a stuck output sensor in a record trained on in seconds: the advised stretch is said in seconds too, in the
# fewest digits that read back as its samples (4.35s, not 4.3500000000000005s: the stamps are i * 0.01), open where
# it runs to the record's end, and --train in those seconds trains on the same samples as --train in those
# indices; --json carries it as a range. Where the time column repeats the stretch's first stamp, no range in
# seconds reads back as it: said so, not a range that holds a flagged sample.
$PY - "$T/a.csv" "$T/stuck.csv" "$T/stuck_dup.csv" <<'PYEOF' || fail "stuck record"
import sys
rows = [r.split(",") for r in open(sys.argv[1]).read().split("\n")[1:] if r]
for name, dup in ((sys.argv[2], False), (sys.argv[3], True)):
    with open(name, "w") as f:
        f.write("t_s,p,y\n")
        for i, (t, p, y) in enumerate(rows):
            t = rows[434][0] if dup and i == 435 else t
            f.write(f"{t},{p},{rows[365][2] if 365 <= i < 435 else y}\n")  # frozen while p rises by 38 % of its span
PYEOF
for r in 0s:15s 0s:; do
  "$BIN" fit --model gpi --data "$T/stuck.csv" --input p --output y --time-column t_s --train $r --threads 1 \
    --force --out "$T/stuck.json" --json > "$T/stuck_fit_$r.json" 2> /dev/null
done
grep -q "the output sensor is stuck there" "$T/stuck_fit_0s:15s.json" \
  || fail "stuck output not named: $(head -c 600 "$T/stuck_fit_0s:15s.json")"
grep -q "train on samples 435:1500 (--train 435:1500," "$T/stuck_fit_0s:15s.json" || fail "stuck: no advice 435:1500"
grep -q "the sensor faults' --train 435:1500 above, in seconds: --train 4.35s:15s\"" "$T/stuck_fit_0s:15s.json" \
  || fail "stuck: the advice in seconds: $(grep -o "the sensor faults[^\"]*" "$T/stuck_fit_0s:15s.json")"
grep -q "the sensor faults' --train 435:1800 above, in seconds: --train 4.35s:\"" "$T/stuck_fit_0s:.json" \
  || fail "stuck: the advice in seconds to the end: $(grep -o "the sensor faults[^\"]*" "$T/stuck_fit_0s:.json")"
for r in 4.35s:15s 435:1500 4.35s: 435:; do
  "$BIN" fit --model gpi --data "$T/stuck.csv" --input p --output y --time-column t_s --train $r --threads 1 \
    --force --out "$T/stuck_r.json" --json > "$T/stuck_$r.json" 2> /dev/null
done
$PY - "$T" <<'PYEOF' || fail "stuck: ranges"
import json, sys
t = sys.argv[1]
d = {r: json.load(open(f"{t}/stuck_{r}.json")) for r in ("fit_0s:15s", "fit_0s:", "4.35s:15s", "435:1500", "4.35s:", "435:")}
assert d["fit_0s:15s"]["fault_free_train"] == [435, 1500], d["fit_0s:15s"]["fault_free_train"]
assert d["fit_0s:"]["fault_free_train"] == [435, 1800], d["fit_0s:"]["fault_free_train"]
n = {r: d[r]["train"]["n"] for r in ("4.35s:15s", "435:1500", "4.35s:", "435:")}
assert n == {"4.35s:15s": 1065, "435:1500": 1065, "4.35s:": 1365, "435:": 1365}, n
assert all(d[r]["fault_free_train"] is None for r in n), [d[r]["fault_free_train"] for r in n]
PYEOF
"$BIN" fit --model gpi --data "$T/stuck_dup.csv" --input p --output y --time-column t_s --train 0s:15s --threads 1 \
  --force --out "$T/stuck.json" > "$T/stuck_dup.txt" 2>&1
grep -q "the sensor faults' --train 435:1500 above has no range in seconds (the time column repeats a stamp" \
  "$T/stuck_dup.txt" || fail "stuck, a repeated stamp: $(grep "sensor faults'" "$T/stuck_dup.txt")"
grep -q "in seconds: --train" "$T/stuck_dup.txt" && fail "stuck, a repeated stamp: a range in seconds"

# trained on one rising branch (fit: "validate on a record with loops"): each validation record says whether it
# has them: a.csv's 6 triangles do, the first rise of b.csv does not
head -n 151 "$T/b.csv" > "$T/b_rise.csv"
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --train 0:150 --threads 1 --validate-data "$T/a.csv" \
  --validate-data "$T/b_rise.csv" --force --out "$T/rise.json" > "$T/rise.txt" 2>&1
grep -q "^warning: the training input never reverses" "$T/rise.txt" || fail "one branch: no fit warning"
grep -q "^warning: $T/a.csv: its input reverses 11 times (by more than 10 % of its span there): it scores the loops the training input did not hold" \
  "$T/rise.txt" || fail "one branch: a.csv's loops not said: $(grep "$T/a.csv: its input" "$T/rise.txt")"
grep -q "^warning: $T/b_rise.csv: its input never reverses (by more than 10 % of its span there), as the training input never reverses: it does not score the inner loops" \
  "$T/rise.txt" || fail "one branch: b_rise.csv's lack of loops not said: $(grep "b_rise.csv: its input" "$T/rise.txt")"
"$BIN" fit --model gpi --data "$T/a.csv" --input p --output y --threads 1 --validate-data "$T/b_rise.csv" --force \
  --out "$T/all.json" > "$T/all.txt" 2>&1
grep -q "its input never reverses\|its input reverses" "$T/all.txt" && fail "trained on loops: a validation's reversals said"

if [ $fails -ne 0 ]; then echo "fit_cli: $fails failures"; exit 1; fi
echo "fit_cli: ok"
