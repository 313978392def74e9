#!/usr/bin/env python3
"""Issue 11's targets, checked on the CSV of the documented sweep (bench/sweep_documented.sh).

Usage: /usr/bin/python3 bench/issue11_targets.py out/sweep/sweep.csv

The sweep's nominal rows are the demo's runs (seed 1, --model auto, 10 learning periods), so
one CSV holds every figure the targets name:
  - nominal rig: gpi-pid compensated RMS <= 0.3 mm and max <= 1.0 mm; mpi-openloop compensated
    max <= 1.29 mm (triangle) and <= 1.38 mm (sine), the paper's; mpi-pwm compensated RMS <= 0.5 mm;
  - learning on every periodic reference of the nominal rig: RMS <= 0.1 mm and max <= 0.3 mm;
  - every variant: the run finished, the pressure command stayed in 0..its limit (the CSV's
    command_limit_mpa: the rig's muscle.max_pressure, and regulator.max_command for the regulator
    experiments; 0.6 MPa on the nominal rig, and in CSVs written before the column), compensated RMS
    <= 1.5x its nominal value (2x for `worst`) and below the baseline's on the same rig.
Prints one line per target (value, limit, met or MISSED) and the count of misses; exit status
1 if any target is missed, 0 if all are met, 2 on a malformed CSV. The sweep's wall time (the
1-minute target) is printed by bench/sweep_documented.sh, not checked here.
"""
import csv
import sys

PRESSURE_MAX = 0.6  # [MPa] the limit of a CSV without command_limit_mpa (the fixed limit before it)


def main(path):
    try:
        rows = list(csv.DictReader(open(path, newline="")))
    except OSError as e:
        print(f"issue11_targets: cannot read {path}: {e}", file=sys.stderr)
        return 2
    need = {"experiment", "variant", "reference", "kind", "max_mm", "rms_mm", "rms_vs_nominal",
            "min_command_mpa", "max_command_mpa", "status"}
    if not rows or not need <= set(rows[0]):
        print(f"issue11_targets: {path} is not a sweep CSV (columns {sorted(need)} needed)", file=sys.stderr)
        return 2
    by = {(r["experiment"], r["variant"], r["reference"], r["kind"]): r for r in rows}

    def value(exp, var, ref, kind, col):
        r = by.get((exp, var, ref, kind))
        if r is None or r[col] == "":
            return None
        return float(r[col])

    lines, misses = [], 0

    ratio_runs = ratio_met = 0

    def check(what, v, limit, ratio=False):
        nonlocal misses, ratio_runs, ratio_met
        ok = v is not None and v <= limit
        misses += not ok
        ratio_runs += ratio
        ratio_met += ratio and ok
        if ratio and ok:
            return  # the variants' ratios: only the misses are listed
        shown = "none" if v is None else f"{v:.3f}"
        lines.append(f"{'met   ' if ok else 'MISSED'} {what}: {shown} (limit {limit:g})")

    check("gpi-pid nominal sine compensated RMS [mm]", value("gpi-pid", "nominal", "sine", "compensated", "rms_mm"), 0.3)
    check("gpi-pid nominal sine compensated max [mm]", value("gpi-pid", "nominal", "sine", "compensated", "max_mm"), 1.0)
    check("mpi-openloop nominal triangle compensated max [mm]",
          value("mpi-openloop", "nominal", "triangle", "compensated", "max_mm"), 1.29)
    check("mpi-openloop nominal sine compensated max [mm]",
          value("mpi-openloop", "nominal", "sine", "compensated", "max_mm"), 1.38)
    for ref in ("sine", "triangle"):
        check(f"mpi-pwm nominal {ref} compensated RMS [mm]", value("mpi-pwm", "nominal", ref, "compensated", "rms_mm"), 0.5)
    learning = sorted({(e, r) for (e, v, r, k) in by if v == "nominal" and k == "learning"})
    if not learning:
        lines.append("MISSED no learning run on the nominal rig")
        misses += 1
    for exp, ref in learning:
        check(f"{exp} nominal {ref} learning RMS [mm]", value(exp, "nominal", ref, "learning", "rms_mm"), 0.1)
        check(f"{exp} nominal {ref} learning max [mm]", value(exp, "nominal", ref, "learning", "max_mm"), 0.3)

    runs = bad_status = bad_command = 0
    for (exp, var, ref, kind), r in sorted(by.items()):
        runs += 1
        if r["status"] != "ok":
            bad_status += 1
            lines.append(f"MISSED {exp} {var} {ref} {kind}: status {r['status']}")
        lo, hi = r["min_command_mpa"], r["max_command_mpa"]
        top = float(r["command_limit_mpa"]) if r.get("command_limit_mpa") else PRESSURE_MAX
        if lo != "" and hi != "" and not (0.0 <= float(lo) and float(hi) <= top):
            bad_command += 1
            lines.append(f"MISSED {exp} {var} {ref} {kind}: command {lo}..{hi} MPa outside 0..{top:g}")
        if kind != "compensated" or var == "nominal":
            continue
        limit = 2.0 if var == "worst" else 1.5
        check(f"{exp} {var} {ref} compensated RMS / nominal", value(exp, var, ref, kind, "rms_vs_nominal"), limit,
              ratio=True)
        base = value(exp, var, ref, "baseline", "rms_mm")
        comp = value(exp, var, ref, kind, "rms_mm")
        if base is None or comp is None or not comp < base:
            misses += 1
            lines.append(f"MISSED {exp} {var} {ref}: compensated RMS {comp} not below the baseline's {base}")
    misses += bad_status + bad_command
    for line in lines:
        print(line)
    print(f"{runs} runs: {bad_status} not ok, {bad_command} with a command outside 0..its limit; "
          f"compensated within its ratio limit (1.5x nominal, 2x for worst) on {ratio_met} of {ratio_runs} variant "
          f"runs")
    print(f"{misses} target(s) missed")
    return 1 if misses else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
