#!/usr/bin/env bash
# Per-sample cost of every model kind: Model::step and Inverse::step in ns per sample
# (bench/bench_kinds.cpp: one amplitude-varying sine of 4000 samples in [0, 0.6], hand-set
# plausible parameters; the inverse is fed the model's output and checked to give the input
# back). Runs the BM_Kind benchmarks with 5 repetitions and prints a markdown table of the
# medians, the inverse / model ratio, the inverse's slowest sample (each sample timed alone,
# fastest of 3 passes, largest over the samples; median over the repetitions) and the
# coefficient of variation over the repetitions.
#
#   bench/kinds_speed.sh [HYSTERON_BENCH_BINARY] [EXTRA BENCHMARK ARGS...]   # default build/hysteron-bench
#
# About 15-25 s on the shared 2-core VM. Single figures move by up to 50 % between runs
# when other jobs load the machine: compare within one table.
set -euo pipefail
BIN=${1:-build/hysteron-bench}
shift || true
PY=/usr/bin/python3
[ -x "$BIN" ] || { echo "no executable $BIN (make build)" >&2; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

ARGS=(--benchmark_filter='^BM_Kind(Step|Inverse)/' --benchmark_repetitions=5
      --benchmark_report_aggregates_only=true --benchmark_format=json "$@")
"$BIN" "${ARGS[@]}" > "$T/out.json"

commit=$(git -C "$(dirname "$0")" rev-parse --short HEAD 2>/dev/null || echo unknown)
# the code the table measures: the core layer and the benchmark
dirty=$(cd "$(dirname "$0")/.." && git status --porcelain --untracked-files=no -- src/core include/hysteron/models.hpp \
        include/hysteron/inverse.hpp include/hysteron/operators.hpp include/hysteron/envelope.hpp bench/bench_kinds.cpp \
        2>/dev/null | head -c1)
echo "command: $BIN ${ARGS[*]}"
echo "commit: $commit${dirty:+ (the core layer or bench_kinds.cpp modified in the working tree)}; $(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo
$PY - "$T/out.json" <<'PYEOF'
import json, re, sys

doc = json.load(open(sys.argv[1]))
rows, order, errors = {}, [], []
for b in doc["benchmarks"]:
    name = re.sub(r"/min_time:[0-9.]+", "", b.get("run_name", b["name"]))
    which, _, case = name.partition("/")
    if b.get("error_occurred"):
        errors.append(f"{name}: {b.get('error_message', 'error')}")
        continue
    if b.get("run_type") != "aggregate" or b.get("aggregate_name") not in ("median", "cv"):
        continue
    if b["aggregate_name"] == "median" and "worst_ns" in b:
        rows.setdefault(case, {})["inverse_worst"] = b["worst_ns"]
    if case not in order:
        rows.setdefault(case, {})
        order.append(case)
    key = ("model" if which == "BM_KindStep" else "inverse") + "_" + b["aggregate_name"]
    # "ns/sample" is a rate counter in seconds per sample; the cv aggregate is a fraction
    rows[case][key] = b["ns/sample"] * (1e9 if b["aggregate_name"] == "median" else 100.0)

analytical = {"pi", "gpi", "mpi-deadzone", "maxwell-slip"}
print("| model | size | model step [ns/sample] | inverse step [ns/sample] | inverse / model | inverse: slowest sample [ns] | inverse | cv model / inverse [%] |")
print("|---|---|---|---|---|---|---|---|")
for case in order:
    kind, _, size = case.partition("/")
    r = rows[case]
    m, i = r.get("model_median"), r.get("inverse_median")
    how = "analytical" if kind in analytical else "Newton in a bracket" if kind == "mpi-asym" else "bracketing"
    fmt = lambda v: "-" if v is None else f"{v:.1f}" if v < 1000 else f"{v:.0f}"
    ratio = "-" if m is None or i is None else f"{i / m:.1f}"
    cv = f"{r.get('model_cv', float('nan')):.0f} / {r.get('inverse_cv', float('nan')):.0f}"
    print(f"| {kind} | {size or '-'} | {fmt(m)} | {fmt(i)} | {ratio} | {fmt(r.get('inverse_worst'))} | {how} | {cv} |")
if errors:
    print("\nFAILED:", *errors, sep="\n  ", file=sys.stderr)
    sys.exit(1)
PYEOF
