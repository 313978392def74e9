#!/usr/bin/env python3
"""Fits every model kind (and auto) on the measured records of ../shared/data, on the
records as published and transformed as a user's sensor may differ (an offset, a flipped
sign, absolute instead of gauge pressure), and prints the README's real-data tables.
Validation RMS in % of the measured span; the reference PI is bench/reference_pi.py
(numpy + scipy nnls, independent of the C++ code).
  Festo muscle: fit on test8, validate on test9 and test10 (input pressure col 1 [kPa], output force col 0 [N]).
  Piezo: input voltage col 3, output displacement col 2; fit on rows 21286:33143 (the sine's 2nd to
         3.4th period; the step from rest at row 16286 excites a ~0.15 s dynamic transient that is
         not rate-independent hysteresis), validate on 33143:50001 (simulated from row 0).
Usage: bench/real_data_table.py [HYSTERON_CLI]   (default: build/hysteron)
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
cli = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build", "hysteron")
data = os.path.join(root, "..", "shared", "data")
if not os.path.isdir(data):
    print(f"real_data_table: {data} not found; skipped")
    sys.exit(0)
tmp = tempfile.mkdtemp()
festo = [os.path.join(data, "pam-force-pressure", f"festo10mm_20cm_test{i}.csv") for i in (8, 9, 10)]
piezo = os.path.join(data, "piezo-sine", "piezo_150V_1Hz.csv")

# (name, files, input col, output col, x transform, y transform, fit args)
records = [
    ("Festo test8 -> test9 / test10", festo, 1, 0, None, None, []),
    ("  same, force negated, absolute pressure", festo, 1, 0, lambda x: x + 101.325, lambda y: -y, []),
    ("piezo 21286:33143 -> 33143:50001", [piezo], 3, 2, None, None, ["--train", "21286:33143", "--validate", "33143:50001"]),
    ("  same, sensor offset -100 um, x1000 (nm)", [piezo], 3, 2, None, lambda y: 1000 * (y - 100), ["--train", "21286:33143", "--validate", "33143:50001"]),
]
kinds = [("pi", ["--model", "pi"]), ("gpi", ["--model", "gpi"]), ("gpi free", ["--model", "gpi", "--free-weights"]),
         ("mpi-deadzone", ["--model", "mpi-deadzone"]), ("mpi-asym", ["--model", "mpi-asym"]), ("auto", ["--model", "auto"])]


def prepared(files, i, o, fx, fy):
    out = []
    for f in files:
        d = np.genfromtxt(f, delimiter=",")
        x, y = d[:, i], d[:, o]
        x = fx(x) if fx else x
        y = fy(y) if fy else y
        p = os.path.join(tmp, f"{len(os.listdir(tmp))}.csv")
        np.savetxt(p, np.c_[x, y], delimiter=",", fmt="%.17g")
        out.append(p)
    return out


rows, times = [], []
for name, files, i, o, fx, fy, extra in records:
    fs = prepared(files, i, o, fx, fy)
    val = [a for f in fs[1:] for a in ("--validate-data", f)]
    ref = json.loads(subprocess.run([sys.executable, os.path.join(root, "bench", "reference_pi.py"), fs[0], "0", "1"] +
                                    extra + [a.replace("--validate-data", "--validate-data") for a in val],
                                    capture_output=True, text=True, check=True).stdout)
    cells = [" / ".join(f"{v:.3f}" for v in ref["validate"])]
    trow = []
    for kname, args in kinds:
        p = subprocess.run([cli, "fit", *args, "--data", fs[0], "--input", "0", "--output", "1", *extra, *val,
                            "--out", os.path.join(tmp, "m.json"), "--json", "--force"], capture_output=True, text=True)
        r = json.loads(p.stdout)
        v = r.get("validate_files") or [r.get("validate")]
        cell = " / ".join(f"{e['rms_percent_span']:.3f}" for e in v)
        if kname == "auto":
            cell += f" ({r['model_kind']})"
        if r["status"] != "converged":
            cell += f" ({r['status']})"
        cells.append(cell)
        trow.append(f"{r['time_s']:.2f}")
    rows.append(f"| {name.strip()} | " + " | ".join(cells) + " |")
    times.append(f"| {name.strip()} | " + " | ".join(trow) + " |")

print("Validation RMS [% of span]:\n")
print("| record | reference PI (NNLS script) | " + " | ".join(k for k, _ in kinds) + " |")
print("|---|" + "---|" * (len(kinds) + 1))
print("\n".join(rows))
print("\nFit time [s] (wall, default threads):\n")
print("| record | " + " | ".join(k for k, _ in kinds) + " |")
print("|---|" + "---|" * len(kinds))
print("\n".join(times))
