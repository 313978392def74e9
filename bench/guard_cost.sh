#!/bin/bash
# The limit-cycle guard's cost per sample (docs/control.md, section 2): the generated C of
# gpi-pid's compensated loop with its guard, and the same loop with the guard removed from
# result.json, side by side: 5 alternating runs of tests/export/bench_loop.c (3 repetitions each).
# Usage: bash bench/guard_cost.sh [BUILD_DIR] [WORK_DIR]   (needs gcc)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
H=$(cd "${1:-build}" && pwd)/hysteron
W=${2:-out/guard_cost}
rm -rf "$W" && mkdir -p "$W"
cd "$W"
"$H" experiment gpi-pid --learning-periods 0 --model mpi-asym --out run > /dev/null
/usr/bin/python3 - <<'PY'
import json
j = json.load(open("run/result.json"))
c = j["compensated"]["controller"]
assert "guard" in c["pid"], "the compensated loop has no guard"
del c["pid"]["guard"]
c.pop("guard_cuts", None)
c.pop("guard_final_scale", None)
json.dump(j, open("run/result_noguard.json", "w"))
PY
for v in guard noguard; do
  f=run/result.json
  [ "$v" = noguard ] && f=run/result_noguard.json
  mkdir -p "$v"
  "$H" export --model run/best_model.json --loop "$f" --run compensated --out "$v/loop.c" --header "$v/loop.h" \
    --prefix lp > /dev/null
  gcc -std=c99 -O2 -I "$v" "$ROOT/tests/export/bench_loop.c" "$v/loop.c" -o "$v/bench" -lm
done
for i in 1 2 3 4 5; do
  for v in noguard guard; do echo "$v: $("$v/bench" | tr '\n' ' ')"; done
done | tee runs.txt
/usr/bin/python3 - <<'PY'
import re, statistics
t = {"guard": [], "noguard": []}
for line in open("runs.txt"):
    kind = line.split(":")[0]
    t[kind] += [float(x) for x in re.findall(r"([0-9.]+) ns per sample", line)]
a, b = statistics.median(t["noguard"]), statistics.median(t["guard"])
print(f"median ns per sample: without the guard {a:.1f}, with it {b:.1f} ({b / a:.3f}x)")
PY
