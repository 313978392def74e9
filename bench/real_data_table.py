#!/usr/bin/env python3
"""Fits every model kind (and auto) on the measured records of ../shared/data, on the
records as published and transformed as a user's sensor may differ (an offset, a flipped
sign of the output or of the input, absolute instead of gauge pressure), and prints the README's real-data tables.
Validation RMS in % of the measured span; the reference PI is bench/reference_pi.py
(numpy + scipy nnls, independent of the C++ code).
  Festo muscle: fit on test8, validate on test9 and test10 (input pressure col 1 [kPa], output force col 0 [N]).
  Piezo: input voltage col 3, output displacement col 2; fit on rows 21286:33143 (the sine's 2nd to
         3.4th period; the step from rest at row 16286 excites a ~0.15 s dynamic transient that is
         not rate-independent hysteresis), validate on 33143:50001 (simulated from row 0).
  rate-pi needs the sample time: Festo from its time column (col 2, stamped to 1 ms, mean step 1.887 ms, passed as
         --time-column), piezo --sample-time 0.0002 (5 kHz, ../shared/data/README.md).
Usage: bench/real_data_table.py [HYSTERON_CLI] [--runs N]   (default: build/hysteron, 1 run;
       with N > 1 every fit runs N times and the time table gives median (min-max))
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
args = sys.argv[1:]
runs = 1
if "--runs" in args:
    k = args.index("--runs")
    runs = int(args[k + 1])
    del args[k:k + 2]
cli = args[0] if args else os.path.join(root, "build", "hysteron")
# ../shared/data next to the checkout, or $HYSTERON_SHARED_DATA (a worktree elsewhere; as the tests)
data = os.environ.get("HYSTERON_SHARED_DATA") or os.path.join(root, "..", "shared", "data")
if not os.path.isdir(data):
    print(f"real_data_table: {data} not found; skipped")
    sys.exit(0)
tmp = tempfile.mkdtemp()
festo = [os.path.join(data, "pam-force-pressure", f"festo10mm_20cm_test{i}.csv") for i in (8, 9, 10)]
piezo = os.path.join(data, "piezo-sine", "piezo_150V_1Hz.csv")

# (name, files, input col, output col, x transform, y transform, fit args, rate-pi sample-time args)
# The prepared files hold x, y and the record's time as column 2.
festo_dt = ["--time-column", "2"]
piezo_dt = ["--sample-time", "0.0002"]
records = [
    ("Festo test8 -> test9 / test10", festo, 1, 0, None, None, [], festo_dt),
    ("  same, force negated, absolute pressure", festo, 1, 0, lambda x: x + 101.325, lambda y: -y, [], festo_dt),
    ("  same, pressure negated", festo, 1, 0, lambda x: -x, None, [], festo_dt),
    ("piezo 21286:33143 -> 33143:50001", [piezo], 3, 2, None, None, ["--train", "21286:33143", "--validate", "33143:50001"], piezo_dt),
    ("  same, sensor offset -100 um, x1000 (nm)", [piezo], 3, 2, None, lambda y: 1000 * (y - 100), ["--train", "21286:33143", "--validate", "33143:50001"], piezo_dt),
]
time_col = {1: 2}  # input col 1 (Festo): time in col 2; input col 3 (piezo): time in col 1
time_col[3] = 1
kinds = [("pi", ["--model", "pi"]), ("gpi", ["--model", "gpi"]), ("gpi free", ["--model", "gpi", "--free-weights"]),
         ("mpi-deadzone", ["--model", "mpi-deadzone"]), ("mpi-asym", ["--model", "mpi-asym"]), ("preisach", ["--model", "preisach"]), ("kp", ["--model", "kp"]),
         ("bouc-wen", ["--model", "bouc-wen"]), ("maxwell-slip", ["--model", "maxwell-slip"]),
         ("rate-pi", ["--model", "rate-pi"]), ("auto", ["--model", "auto"])]


def prepared(files, i, o, fx, fy):
    out = []
    for f in files:
        d = np.genfromtxt(f, delimiter=",")
        x, y, t = d[:, i], d[:, o], d[:, time_col[i]]
        x = fx(x) if fx else x
        y = fy(y) if fy else y
        p = os.path.join(tmp, f"{len(os.listdir(tmp))}.csv")
        np.savetxt(p, np.c_[x, y, t], delimiter=",", fmt="%.17g")
        out.append(p)
    return out


rows, times = [], []
for name, files, i, o, fx, fy, extra, dt in records:
    fs = prepared(files, i, o, fx, fy)
    val = [a for f in fs[1:] for a in ("--validate-data", f)]
    ref = json.loads(subprocess.run([sys.executable, os.path.join(root, "bench", "reference_pi.py"), fs[0], "0", "1"] +
                                    extra + [a.replace("--validate-data", "--validate-data") for a in val],
                                    capture_output=True, text=True, check=True).stdout)
    cells = [" / ".join(f"{v:.3f}" for v in ref["validate"])]
    trow = []
    for kname, args in kinds:
        # auto needs the sample time too (it fits rate-pi among the candidates)
        rate = dt if kname in ("rate-pi", "auto") else []
        ts = []
        for _ in range(runs):
            p = subprocess.run([cli, "fit", *args, "--data", fs[0], "--input", "0", "--output", "1", *rate, *extra, *val,
                                "--out", os.path.join(tmp, "m.json"), "--json", "--force"], capture_output=True, text=True)
            r = json.loads(p.stdout)
            ts.append(r["time_s"])
        v = r.get("validate_files") or [r.get("validate")]
        cell = " / ".join(f"{e['rms_percent_span']:.3f}" for e in v)
        if kname == "auto":
            cell += f" ({r['model_kind']})"
        if r["status"] != "converged":
            cell += f" ({r['status']})"
        cells.append(cell)
        ts.sort()
        trow.append(f"{ts[len(ts) // 2]:.2f}" + (f" ({ts[0]:.2f}-{ts[-1]:.2f})" if runs > 1 else ""))
    rows.append(f"| {name.strip()} | " + " | ".join(cells) + " |")
    times.append(f"| {name.strip()} | " + " | ".join(trow) + " |")

print("Validation RMS [% of span]:\n")
print("| record | reference PI (NNLS script) | " + " | ".join(k for k, _ in kinds) + " |")
print("|---|" + "---|" * (len(kinds) + 1))
print("\n".join(rows))
print(f"\nFit time [s] (wall, default threads{'' if runs == 1 else f', median (min-max) of {runs} runs'}):\n")
print("| record | " + " | ".join(k for k, _ in kinds) + " |")
print("|---|" + "---|" * len(kinds))
print("\n".join(times))
