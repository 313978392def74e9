#!/usr/bin/env python3
"""Markdown table of the documented sweep identified on the base rig (docs/plant.md, "Identified on
the nominal rig, tracking on the changed one").

IOB.csv: `bash bench/sweep_documented.sh build DIR --identify-on-base` (DIR/sweep.csv);
RETUNED.csv: the same without the flag. One row per experiment, variant and reference: the
re-tuned compensated RMS [mm], then the identified-on-base compensated RMS ("**" where it is above
1.5x its nominal value, 2x for "worst", or not below the baseline), its ratio to nominal, and the
learning, adaptive and baseline RMS of the same runs. mpi-pwm's regulator rows are left out: its
valves never read the regulator, so they are its nominal row.

Usage: /usr/bin/python3 bench/sweep_changed_table.py IOB.csv RETUNED.csv
"""
import csv
import sys


def main():
    iob = list(csv.DictReader(open(sys.argv[1], newline="")))
    retuned = {(r["experiment"], r["variant"], r["reference"], r["kind"]): r
               for r in csv.DictReader(open(sys.argv[2], newline=""))}
    runs = {(r["experiment"], r["variant"], r["reference"], r["kind"]): r for r in iob}
    keys = []
    for r in iob:
        key = (r["experiment"], r["variant"], r["reference"])
        if key not in keys:
            keys.append(key)
    print("| experiment | variant | reference | compensated (re-tuned) | compensated | x nominal | learning | "
          "adaptive | baseline |")
    print("|---|---|---|---|---|---|---|---|---|")
    for e, v, ref in keys:
        if e == "mpi-pwm" and v.startswith("regulator"):
            continue

        def rms(kind, table=runs):
            r = table.get((e, v, ref, kind))
            return float(r["rms_mm"]) if r and r["status"] == "ok" else None

        c, b = rms("compensated"), rms("baseline")
        if c is None or b is None:
            print(f"| {e} | {v} | {ref} | failed | | | | | |")
            continue
        x = float(runs[(e, v, ref, "compensated")]["rms_vs_nominal"])
        cell = f"{c:.3f}"
        if x > (2.0 if v == "worst" else 1.5) or c >= b:
            cell = f"**{cell}**"
        fmt = lambda y: "-" if y is None else f"{y:.3f}"
        print(f"| {e} | {v} | {ref} | {fmt(rms('compensated', retuned))} | {cell} | {x:.2f} | {fmt(rms('learning'))} "
              f"| {fmt(rms('adaptive'))} | {fmt(b)} |")


if __name__ == "__main__":
    main()
