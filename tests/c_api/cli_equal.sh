#!/usr/bin/env bash
# The C program's inverse trajectory equals the CLI's (`hysteron invert`), for every
# model kind: bit for bit, or at most 1e-12 apart.
# Usage: bash cli_equal.sh <hysteron-binary> <hysteron_c_test_shared> <tests/c_api dir>
set -euo pipefail
BIN=$1; CTEST=$2; DIR=$3
PY=/usr/bin/python3
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

$PY - "$T/x.csv" <<'PYEOF'
import math, sys
with open(sys.argv[1], "w") as f:
    f.write("x\n")
    for k in range(5000):
        x = 0.8 * math.sin(0.013 * k) * math.exp(-k / 3000) + 0.15 * math.sin(0.17 * k) + 0.02 * math.sin(1.3 * k)
        f.write(f"{x!r}\n")
PYEOF

for m in gpi pi dz asym asym_mirrored; do
  "$BIN" simulate --model "$DIR/$m.json" --input "$T/x.csv" --column x --output "$T/y_$m.csv"
  # desired outputs, one per line, for the C program
  $PY -c 'import csv,sys; [print(r["output"]) for r in csv.DictReader(open(sys.argv[1]))]' "$T/y_$m.csv" > "$T/y_$m.txt"
  "$BIN" invert --model "$DIR/$m.json" --input "$T/y_$m.csv" --column output --output "$T/cli_$m.csv" 2> /dev/null
  "$CTEST" invert "$DIR/$m.json" "$T/y_$m.txt" "$T/c_$m.txt"
  $PY - "$T/cli_$m.csv" "$T/c_$m.txt" "$m" <<'PYEOF'
import csv, sys
cli = [float(r["input"]) for r in csv.DictReader(open(sys.argv[1]))]
c = [float(l) for l in open(sys.argv[2])]
what = sys.argv[3]
if len(cli) != len(c) or not c:
    sys.exit(f"{what}: CLI has {len(cli)} samples, the C program {len(c)}")
diff = max(abs(a - b) for a, b in zip(cli, c))
same = sum(a == b for a, b in zip(cli, c))
print(f"{what}: C ABI vs CLI inverse over {len(c)} samples: {same} bit-identical, max |difference| {diff:.3g}")
if not diff <= 1e-12:
    sys.exit(f"{what}: C ABI and CLI differ by {diff}")
PYEOF
done
echo "cli_equal: ok"
