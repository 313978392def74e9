#!/usr/bin/env python3
"""One row per rig variant of a `hysteron sweep --out table.csv` file, one column per
experiment and reference: the compensated RMS error [mm] (its ratio to the same experiment's
nominal value) / the learning RMS after its last period ("-": no learning run). The table of
docs/plant.md, "Variants outside the documented set". Failed runs are listed below it.

    build/hysteron sweep all --grid bench/variants_outside.json --jobs 2 --out out/outside.csv
    /usr/bin/python3 bench/sweep_compact.py out/outside.csv
"""
import csv
import sys


def main(path):
    rows = list(csv.DictReader(open(path, newline="")))
    columns, variants, cell, failed = [], [], {}, []
    for r in rows:
        if r["status"] != "ok":
            failed.append(r)
            continue
        col = (r["experiment"], r["reference"])
        if col not in columns:
            columns.append(col)
        if r["variant"] not in variants:
            variants.append(r["variant"])
        cell[(r["variant"], col, r["kind"])] = r
    print("| variant | " + " | ".join(f"{e} {ref}" for e, ref in columns) + " |")
    print("|---" * (len(columns) + 1) + "|")
    for v in variants:
        out = []
        for col in columns:
            c = cell.get((v, col, "compensated"))
            if c is None:
                out.append("failed")
                continue
            learning = cell.get((v, col, "learning"))
            ratio = float(c["rms_vs_nominal"])
            out.append(f"{float(c['rms_mm']):.3f} ({ratio:.2f}x) / "
                       + (f"{float(learning['rms_mm']):.3f}" if learning else "-"))
        print(f"| {v} | " + " | ".join(out) + " |")
    for r in failed:
        print(f"failed: {r['experiment']} {r['variant']} {r['reference']}: {r['error']}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
