#!/usr/bin/env bash
# Streamed simulate/invert (issue 13, item 8): a CSV output to a file is written while the input is
# read; it must equal the non-streamed result (stdout), an input error on the last line leaves no
# output (the old file stays) and names the input's line; --compress writes compressed .mat.
# Usage: bash stream_io.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
PY=/usr/bin/python3
fail() { echo "FAIL: $*" >&2; exit 1; }

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05}
JSON
# 30000 samples: several blocks of the streamed path (8192) and a partial last one
$PY - "$T/x.csv" <<'PYEOF'
import math, sys
with open(sys.argv[1], "w") as f:
    f.write("t,input\n")
    for k in range(30000):
        f.write("%d,%.17g\n" % (k, 0.3 + 0.25 * math.sin(0.002 * k) * math.exp(-k / 20000)))
PYEOF

# streamed (file) and whole (stdout) results are byte-identical, for --relaxed too
for relaxed in "" "--relaxed"; do
  "$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/y.csv" $relaxed
  "$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output - $relaxed > "$T/y_stdout.csv"
  cmp "$T/y.csv" "$T/y_stdout.csv" || fail "simulate $relaxed: streamed output differs from stdout output"
  "$BIN" invert --model "$T/gpi.json" --input "$T/y.csv" --column output --output "$T/xi.csv" --limits 0,0.6 $relaxed 2> "$T/err"
  grep -q "of 30000 samples saturated" "$T/err" || { cat "$T/err"; fail "invert $relaxed: sample count"; }
  "$BIN" invert --model "$T/gpi.json" --input "$T/y.csv" --column output --output - --limits 0,0.6 $relaxed > "$T/xi_stdout.csv" 2> /dev/null
  cmp "$T/xi.csv" "$T/xi_stdout.csv" || fail "invert $relaxed: streamed output differs from stdout output"
done
# the rows: 30000 + header, the input column copied exactly (shortest round-trip form)
[ "$(wc -l < "$T/y.csv")" -eq 30001 ] || fail "row count"
$PY - "$T/x.csv" "$T/y.csv" "$T/xi.csv" <<'PYEOF'
import sys
xs = [l.split(",")[1].strip() for l in open(sys.argv[1]).read().splitlines()[1:]]
ys = [l.split(",") for l in open(sys.argv[2]).read().splitlines()[1:]]
assert all(float(a) == float(b[0]) for a, b in zip(xs, ys)), "input column changed"
assert all(len(r[0]) <= 24 for r in ys), "not the shortest form"
xi = [float(l.split(",")[1]) for l in open(sys.argv[3]).read().splitlines()[1:]]
err = max(abs(a - float(b)) for a, b in zip(xi, xs))
assert err < 1e-9, "inverse of the forward run does not give the input back: %g" % err
PYEOF

# an error on the last input line: exit 1, the input's file:line, the old output intact, no temp file
cp "$T/x.csv" "$T/bad.csv"
echo "30000,oops" >> "$T/bad.csv"
echo "old" > "$T/keep.csv"
rc=0
"$BIN" simulate --model "$T/gpi.json" --input "$T/bad.csv" --output "$T/keep.csv" 2> "$T/err" || rc=$?
[ "$rc" -eq 1 ] || fail "bad input: exit $rc"
grep -qF "bad.csv:30002:2" "$T/err" || { cat "$T/err"; fail "bad input: message lacks the line"; }
grep -qF "keep.csv: " "$T/err" && { cat "$T/err"; fail "bad input: blamed on the output file"; }
[ "$(cat "$T/keep.csv")" = "old" ] || fail "bad input: old output replaced"
"$BIN" simulate --model "$T/gpi.json" --input "$T/bad.csv" --output "$T/new.csv" 2> /dev/null && fail "bad input accepted"
[ ! -e "$T/new.csv" ] || fail "bad input: a new output was created"
[ -z "$(find "$T" -name '.*.tmp-*')" ] || fail "temporary file left"

# .mat output: uncompressed by default, compressed with --compress, both read back alike
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/y.mat"
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/yz.mat" --compress
"$BIN" simulate --model "$T/gpi.json" --input "$T/x.csv" --output "$T/y.csv"
$PY - "$T/y.mat" "$T/yz.mat" "$T/y.csv" <<'PYEOF'
import struct, sys
import scipy.io as sio
def first_type(p):
    with open(p, "rb") as f:
        f.seek(128)
        return struct.unpack("<I", f.read(4))[0]
assert first_type(sys.argv[1]) == 14, "default .mat output is compressed"
assert first_type(sys.argv[2]) == 15, "--compress did not compress"
a, b = sio.loadmat(sys.argv[1]), sio.loadmat(sys.argv[2])
rows = [l.split(",") for l in open(sys.argv[3]).read().splitlines()[1:]]
for m in (a, b):
    assert m["output"].shape == (30000, 1)
    assert all(m["output"][k, 0] == float(rows[k][1]) for k in range(30000)), ".mat and CSV outputs differ"
PYEOF
echo "stream_io: ok"
