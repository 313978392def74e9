#!/usr/bin/env python3
"""Markdown table of a `hysteron sweep --out table.csv` file (docs/plant.md, "Plant variants").

One row per experiment, reference and variant: the RMS error [mm] of every variant kind (in the
order they appear), the compensated RMS over its nominal value and over the baseline's, the
range of the pressure command over every kind [MPa], the reference's scale (below 1: scaled into
the rig's reach, docs/control.md section 5; "out" = out of reach with --paper-references); "**" marks a miss of issue 11's targets
(compensated RMS above LIMIT x nominal, 2 x for the variant named "worst"; not below the
baseline; a command outside 0..0.6 MPa). Failed runs are listed with their message.

Usage: python3 bench/sweep_table.py out/sweep/sweep.csv [LIMIT=1.5]
"""
import csv
import sys


def main():
    path = sys.argv[1]
    limit = float(sys.argv[2]) if len(sys.argv) > 2 else 1.5
    rows = list(csv.DictReader(open(path, newline="")))
    kinds, keys, by_key, failed = [], [], {}, []
    for r in rows:
        if r["status"] != "ok":
            failed.append(r)
            continue
        if r["kind"] not in kinds:
            kinds.append(r["kind"])
        key = (r["experiment"], r["reference"], r["variant"])
        if key not in by_key:
            keys.append(key)
            by_key[key] = {}
        by_key[key][r["kind"]] = r
    # experiments, then references, in first-seen order; variants in table order (stable sort)
    exp_order, ref_order = {}, {}
    for e, ref, _ in keys:
        exp_order.setdefault(e, len(exp_order))
        ref_order.setdefault((e, ref), len(ref_order))
    keys.sort(key=lambda k: (exp_order[k[0]], ref_order[(k[0], k[1])]))
    print("| experiment | reference | variant | " + " | ".join(kinds) + " | comp/nom | comp/base | command [MPa] | ref scale |")
    print("|---|---|---|" + "---|" * len(kinds) + "---|---|---|---|")
    last = None
    for key in keys:
        exp, ref, var = key
        k = by_key[key]
        cells = [f"{float(k[x]['rms_mm']):.3f}" if x in k else "-" for x in kinds]
        comp, base = k.get("compensated"), k.get("baseline")
        rn = rb = ""
        if comp is not None and comp["rms_vs_nominal"]:
            v = float(comp["rms_vs_nominal"])
            lim = 2.0 if var == "worst" else limit
            rn = f"{v:.2f}" + (" **" if var != "nominal" and v > lim else "")
        if comp is not None and base is not None:
            v = float(comp["rms_mm"]) / float(base["rms_mm"])
            rb = f"{v:.2f}" + (" **" if v >= 1.0 else "")
        lo = min(float(x["min_command_mpa"]) for x in k.values() if x["min_command_mpa"])
        hi = max(float(x["max_command_mpa"]) for x in k.values() if x["max_command_mpa"])
        cmd = f"{lo:.3f}..{hi:.3f}" + (" **" if lo < 0.0 or hi > 0.6 else "")
        scale = comp.get("reference_scale", "") if comp is not None else ""
        scale = f"{float(scale):.3f}" if scale else "-"
        head = [exp, ref] if (exp, ref) != last else ["", ""]
        last = (exp, ref)
        print("| " + " | ".join(head + [var] + cells + [rn, rb, cmd, scale]) + " |")
    for r in failed:
        print(f"\nFAILED: {r['experiment']} {r['variant']}: {r['error']}")


if __name__ == "__main__":
    main()
