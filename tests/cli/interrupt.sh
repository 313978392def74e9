#!/usr/bin/env bash
# Interrupted and failed commands leave whole outputs, never a mix of two runs nor temporary files:
# a demo interrupted (SIGINT) after its first experiment leaves the previous demo byte-identical;
# a report interrupted while gnuplot runs leaves no hysteron-plot-* directory; fit -o --report
# whose report fails (gnuplot failing) leaves the old model and report.
# Usage: bash interrupt.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
PY=/usr/bin/python3
fail() { echo "FAIL: $*" >&2; exit 1; }

# ---- demo: SIGINT once the first experiment has finished (its table printed) ----------------
"$BIN" demo --seed 1 --learning-periods 1 --out "$T/dm" > /dev/null
cp -a "$T/dm" "$T/dm_before"
$PY - "$BIN" "$T/dm" <<'PYEOF'
import signal, subprocess, sys
binary, out = sys.argv[1:3]
p = subprocess.Popen([binary, "demo", "--seed", "2", "--learning-periods", "1", "--out", out],
                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
# the first experiment's table ends with its first blank line; the second experiment then runs
for line in p.stdout:
    if line.strip() == "":
        break
else:
    sys.exit(f"demo ended (status {p.wait()}) before its first table")
if p.poll() is not None:
    sys.exit("demo ended before the signal")
p.send_signal(signal.SIGINT)
rc = p.wait()
if rc != -signal.SIGINT:
    sys.exit(f"demo: exit status {rc}, expected death by SIGINT")
print("demo: interrupted after its first experiment")
PYEOF
diff -r "$T/dm_before" "$T/dm" > "$T/diff" || { head -5 "$T/diff"; fail "the interrupted demo changed the previous one"; }
[ -z "$(find "$T/dm" -name '.*.tmp-*')" ] || fail "the interrupted demo left temporary files"
echo "demo interrupted: the previous demo byte-identical"

# ---- report: SIGINT while gnuplot runs leaves no temporary directory ------------------------
mkdir "$T/tmpd"
$PY - "$BIN" "$T/dm/gpi-pid" "$T/rp.html" "$T/tmpd" <<'PYEOF'
import glob, os, signal, subprocess, sys, time
binary, d, html, tmpd = sys.argv[1:5]
env = dict(os.environ, TMPDIR=tmpd)
for attempt in range(5):
    p = subprocess.Popen([binary, "report", d, "-o", html], env=env, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)
    while p.poll() is None and not glob.glob(os.path.join(tmpd, "hysteron-plot-*", "plot.gp")):
        time.sleep(0.001)
    if p.poll() is not None:
        print("report finished before a plot was seen; retrying")
        continue
    os.killpg(p.pid, signal.SIGINT)  # as Ctrl-C in a terminal: hysteron and gnuplot
    rc = p.wait()
    if rc != -signal.SIGINT:
        sys.exit(f"report: exit status {rc}, expected death by SIGINT")
    time.sleep(0.2)  # gnuplot, signalled too, has exited
    left = os.listdir(tmpd)
    if left:
        sys.exit(f"report: temporary paths left in TMPDIR: {left}")
    print("report: interrupted during a plot, no temporary directory left")
    break
else:
    sys.exit("report: could not interrupt a plot in 5 attempts")
PYEOF
[ ! -e "$T/rp.html" ] || fail "the interrupted report wrote its page"

# ---- fit -o --report: the report failing leaves the old model and report ---------------------
cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
$PY - "$T/x.csv" <<'PYEOF'
import sys
with open(sys.argv[1], "w") as f:
    f.write("pressure\n")
    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1):
        for k in range(300):
            f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/data.csv"
"$BIN" fit --data "$T/data.csv" --input input --output output --train 0:600 --out "$T/m.json" --report "$T/r.html" > /dev/null
cp "$T/m.json" "$T/m_before.json"
cp "$T/r.html" "$T/r_before.html"
rc=0
HYSTERON_GNUPLOT=/bin/false "$BIN" fit --data "$T/data.csv" --input input --output output --train 0:1200 \
  --out "$T/m.json" --report "$T/r.html" > /dev/null 2> "$T/err" || rc=$?
[ "$rc" -ne 0 ] || fail "fit: a failing gnuplot did not fail the command"
grep -q gnuplot "$T/err" || { cat "$T/err"; fail "fit: the error does not name gnuplot"; }
cmp -s "$T/m.json" "$T/m_before.json" || fail "fit: the model was replaced though its report failed"
cmp -s "$T/r.html" "$T/r_before.html" || fail "fit: the report was changed"
[ -z "$(find "$T" -maxdepth 1 -name '.*.tmp-*')" ] || fail "fit: temporary files left"
echo "fit with a failing report: the old model and report kept"
