#!/usr/bin/env bash
# Peer comparison: hysteron's LM (Ceres, analytic forward-sensitivity Jacobian) against
# scipy.optimize.least_squares ('trf', finite differences) on the same GPI
# (8 parameters, n = 10) and the same 10,001 samples of the piezo record:
# ../shared/data/piezo-sine/piezo_150V_1Hz.csv rows 0, 5, 10, ..., 50000
# (every 5th row from the first), input = column 3 [V], output = column 2 [um].
#
# Usage: bench/compare_scipy.sh [HYSTERON_CLI]   (default: build/hysteron)
# The scipy half takes 7-12 min on a loaded 2-core machine.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cli="${1:-$root/build/hysteron}"
data="$root/../shared/data/piezo-sine/piezo_150V_1Hz.csv"
if [[ ! -f "$data" ]]; then echo "compare_scipy: $data not found (../shared/data is absent); skipped"; exit 0; fi
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
awk -F, 'BEGIN{print "input,output"} (NR-1)%5==0 {print $4","$3}' "$data" > "$tmp/piezo10k.csv"
# hysteron on one thread (as scipy), and with its starts on every hardware thread (default)
"$cli" fit --model gpi --n 10 --data "$tmp/piezo10k.csv" --input input --output output --threads 1 \
  --out "$tmp/model.json" --json --force > "$tmp/hysteron.json" || true
"$cli" fit --model gpi --n 10 --data "$tmp/piezo10k.csv" --input input --output output \
  --out "$tmp/model2.json" --json --force > "$tmp/hysteron2.json" || true
/usr/bin/python3 "$root/bench/peer_scipy.py" "$tmp/piezo10k.csv" --n 10 > "$tmp/scipy.json"
/usr/bin/python3 - "$tmp/hysteron.json" "$tmp/scipy.json" "$tmp/hysteron2.json" <<'PY'
import json, sys
h = json.load(open(sys.argv[1])); s = json.loads(open(sys.argv[2]).read()); h2 = json.load(open(sys.argv[3]))
print(f"{'tool':<10} {'time [s]':>10} {'rms [um]':>10}  status")
print(f"{'hysteron':<10} {h['time_s']:>10.4f} {h['train']['rms']:>10.5f}  {h['status']} ({h['total_iterations']} LM iterations, {h['starts']} starts, 1 thread)")
print(f"{'hysteron':<10} {h2['time_s']:>10.4f} {h2['train']['rms']:>10.5f}  {h2['status']} (the same starts on every hardware thread)")
print(f"{'scipy':<10} {s['time_s']:>10.4f} {s['rms']:>10.5f}  status {s['status']} ({s['nfev']} evaluations, {s['njev']} Jacobians)")
print(f"speed-up (1 thread each): {s['time_s'] / h['time_s']:.1f}x   rms ratio hysteron/scipy: {h['train']['rms'] / s['rms']:.4f}")
PY
