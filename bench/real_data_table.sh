#!/usr/bin/env bash
# Fits every model on the measured records of ../shared/data and prints the
# validation table of docs/identification.md.
#   Festo muscle: fit on test8, validate on test9 and test10 (input pressure col 1 [kPa], output force col 0 [N]).
#   Piezo: input voltage col 3, output displacement col 2; the sine starts at row 16286 with a
#          step from rest (0 V) to -87 V that the actuator follows with a transient lasting
#          ~0.15 s (dynamics, not rate-independent hysteresis: about half of any model's
#          squared error on 16286:33143 comes from it), so the fit uses rows 21286:33143 (the
#          sine's 2nd to 3.4th period; the model is still simulated from row 0) and validates
#          on 33143:50001.
#   Models: pi, gpi (Eq. 8, 8 parameters), gpi --free-weights, mpi-deadzone, mpi-asym.
# Usage: bench/real_data_table.sh [HYSTERON_CLI]   (default: build/hysteron)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cli="${1:-$root/build/hysteron}"
d="$root/../shared/data"
if [[ ! -d "$d" ]]; then echo "real_data_table: $d not found; skipped"; exit 0; fi
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
f="$d/pam-force-pressure/festo10mm_20cm_test"
echo "| record | model | status | fit time [s] | train RMS [% span] | validation RMS [% span] |"
echo "|---|---|---|---|---|---|"
models=(pi gpi "gpi --free-weights" mpi-deadzone mpi-asym)
for m in "${models[@]}"; do
  # shellcheck disable=SC2086
  "$cli" fit --model $m --data "${f}8.csv" --input 1 --output 0 --validate-data "${f}9.csv" --validate-data "${f}10.csv" \
    --out "$tmp/m.json" --json --force > "$tmp/r.json" || true
  /usr/bin/python3 - "$tmp/r.json" "$m" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
v = " / ".join(f"{e['rms_percent_span']:.3f}" for e in r["validate_files"])
print(f"| Festo test8 -> test9 / test10 | {sys.argv[2]} | {r['status']} | {r['time_s']:.3f} | {r['train']['rms_percent_span']:.3f} | {v} |")
PY
done
for m in "${models[@]}"; do
  # shellcheck disable=SC2086
  "$cli" fit --model $m --data "$d/piezo-sine/piezo_150V_1Hz.csv" --input 3 --output 2 --train 21286:33143 --validate 33143:50001 \
    --out "$tmp/m.json" --json --force > "$tmp/r.json" || true
  /usr/bin/python3 - "$tmp/r.json" "$m" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"| piezo sine 21286:33143 -> 33143:50001 | {sys.argv[2]} | {r['status']} | {r['time_s']:.3f} | {r['train']['rms_percent_span']:.3f} | {r['validate']['rms_percent_span']:.3f} |")
PY
done
