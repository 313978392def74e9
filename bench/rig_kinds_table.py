#!/usr/bin/env python3
"""Every model kind on the simulated muscle rig (docs/plant.md, default parameters), the
comparison table of issue 14 item 6 (docs/models.md, "Comparison on the simulated rig").

Input: measured pressure [MPa]; output: measured contraction [mm]; the rig is driven by the
regulator at a 1 kHz control period, the records are taken at every 5th sample (200 Hz;
the experiments fit at 100 Hz, but then the major loop has 500 samples, too few for the 56
weights of preisach / kp with n = 10) in (a) and every 10th (100 Hz) in (b); rate-pi gets
that sample_time. Fits: hysteron.fit with its defaults (n = 10, 2 starts on the default
threads, seed 0; (a) also kp and preisach with n = 12). Fit time: the fit's own time_s (wall).

(a) Major loop -> minor loops, rig seed 1:
    A: the gpi-pid experiment's identification run (gpi_identification_pressure: 0.2 Hz
       triangles from 0 MPa with peaks 0.6, 0.5, ..., 0.1 MPa); fit on its major loop (the
       first 5 s, 0 -> 0.6 -> 0 MPa), validate on the rest (the smaller loops),
       the split of `hysteron experiment gpi-pid` ("... on the minor loops").
    B: nested reversals of decreasing amplitude (rig seed 2), same ramp rate as the major loop
       (0.24 MPa/s): 0 -> 0.6 -> 0.05 -> 0.55 -> 0.1 -> 0.5 -> ... -> 0.3 -> 0; validated from the
       start with the model fitted on A's major loop.
(b) Rates: one rig run (seed 3) of 0 -> 0.6 -> 0 MPa triangles at 0.05 Hz (1 period), 0.2 Hz
    (4 periods), 1 Hz (20 periods), 20 s each; every kind fitted on the whole multi-rate record,
    validated on the same rates with sines (rig seed 4, same amplitude and durations), RMS per
    rate; and fitted on the 0.2 Hz part only, validated on each rate of the sine run.
Usage: bench/rig_kinds_table.py [PYTHON_MODULE_DIR]   (default: build/python)
"""
import os
import sys
import time

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build", "python"))
import hysteron as h  # noqa: E402

TC = 1e-3     # control period [s]
EVERY_A, EVERY_B = 5, 10  # decimation: 200 Hz records in (a), 100 Hz in (b)
RATE = 0.24   # MPa/s, the major loop's ramp rate (0.6 MPa in 2.5 s)
KINDS = ["pi", "gpi", "mpi-deadzone", "mpi-asym", "preisach", "kp", "bouc-wen", "maxwell-slip", "rate-pi", "auto"]


def run(profile, seed, every):
    r = h.PamRig(seed=seed).run_pressure(np.asarray(profile, dtype=float), TC)
    return r["pressure_mpa"][::every].copy(), r["contraction_measured_mm"][::every].copy()


def ramps(points):
    """Piecewise-linear pressure through points [MPa] at RATE, sampled at TC."""
    out = [np.array([points[0]])]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(round(abs(b - a) / RATE / TC)))
        out.append(a + (b - a) * np.arange(1, n + 1) / n)
    return np.concatenate(out)


def fit(kind, x, y, train, dt, n=10):
    t0 = time.perf_counter()
    r = h.fit(x, y, model=kind, train=train, sample_time=dt, num_operators=n)
    wall = time.perf_counter() - t0
    return r, wall


def cell_status(r):
    s = r["status"]
    return "" if s == "converged" else f" ({s})"


# ---------------------------------------------------------------- (a)
DT = TC * EVERY_A
xa, ya = run(h.gpi_identification_pressure(TC), 1, EVERY_A)
train_end = int(round(5.0 / DT))
peaks = []
lo, hi = 0.05, 0.55
while hi - lo > 0.04:
    peaks += [lo, hi]
    lo, hi = round(lo + 0.05, 10), round(hi - 0.05, 10)
nested = ramps([0.0, 0.6] + peaks + [0.3, 0.0])
xb, yb = run(nested, 2, EVERY_A)
span_a = np.ptp(ya[train_end:])
span_b = np.ptp(yb)

rows_a = []
# plus kp and preisach at a finer grid (12 levels: 78 weights; 16 would need more samples)
for kind, n in [(k, 10) for k in KINDS] + [("kp", 12), ("preisach", 12)]:
    r, wall = fit(kind, xa, ya, (0, train_end), DT, n)
    name = kind + (f" ({r['model_kind']})" if kind == "auto" else "") + (f", n = {n}" if n != 10 else "")
    if r["model"] is None:
        rows_a.append(f"| {name} | {r['status']}: {r['message']} | | | | | |")
        continue
    va = h.evaluate(r["model"], xa, ya, (train_end, None))
    vb = h.evaluate(r["model"], xb, yb)
    rows_a.append(f"| {name}{cell_status(r)} | {r['train']['rms']:.3f} | {va['rms']:.3f} | {100 * va['rms'] / span_a:.2f} | "
                  f"{vb['rms']:.3f} | {100 * vb['rms'] / span_b:.2f} | {r['time_s']:.2f} |")

print(f"(a) Major loop -> minor loops (A: {len(xa)} samples, train 0:{train_end}; B: nested reversals, "
      f"{len(xb)} samples; spans A[{train_end}:] {span_a:.1f} mm, B {span_b:.1f} mm)\n")
print("| kind | train RMS [mm] | A minor loops RMS [mm] | [% span] | B nested reversals RMS [mm] | [% span] | "
      "fit time [s] |")
print("|---|---|---|---|---|---|---|")
print("\n".join(rows_a))

# ---------------------------------------------------------------- (b)
RATES = [(0.05, 1), (0.2, 4), (1.0, 20)]


def multi_rate(waveform):
    segs = [{"waveform": waveform, "amplitude": 0.6, "offset": 0.0, "period": 1.0 / f, "periods": n} for f, n in RATES]
    return h.wave_sequence(segs, TC)


def seg_ranges(n_total):
    out, k = [], 0
    for f, n in RATES:
        m = int(round(n / f / DT))
        out.append((k, k + m))
        k += m
    assert abs(k - n_total) <= 1, (k, n_total)
    return out


DT = TC * EVERY_B
pt = multi_rate("triangle")
ps = multi_rate("sine")
xt, yt = run(pt, 3, EVERY_B)
xs, ys = run(ps, 4, EVERY_B)
rt, rs = seg_ranges(len(xt)), seg_ranges(len(xs))
print(f"\n(b) Rates: triangles and sines 0 -> 0.6 -> 0 MPa at {', '.join(f'{f:g} Hz' for f, _ in RATES)} "
      f"(20 s each; train record {len(xt)} samples, validation {len(xs)})\n")
# loop width at mid pressure per rate: how much the rig's loops change with rate (branch
# from the command's direction: the measured pressure's noise is of the order of its step)
widths = []
cmd = ps[::EVERY_B]
for (a, b) in rs:
    x, y = xs[a:b], ys[a:b]
    d = np.gradient(cmd[a:b])
    up = (d > 0) & (np.abs(x - 0.3) < 0.01)
    dn = (d < 0) & (np.abs(x - 0.3) < 0.01)
    widths.append(np.mean(y[dn]) - np.mean(y[up]) if up.any() and dn.any() else float("nan"))
print("Loop width of the sine run at 0.3 MPa (falling minus rising branch): " +
      ", ".join(f"{f:g} Hz {w:.1f} mm" for (f, _), w in zip(RATES, widths)) + "\n")

rows_b, notes = [], []
r02 = rt[1]
for kind in KINDS:
    cells, chosen = [kind], []
    for train in (None, r02):
        r, wall = fit(kind, xt, yt, train, DT)
        chosen.append(str(r["model_kind"]))
        if kind == "rate-pi" and r["model"] is not None:
            notes.append(f"rate-pi fitted on the {'whole triangle run' if train is None else '0.2 Hz part'}: "
                         f"train RMS {r['train']['rms']:.3f} mm, c = {r['model']['c']:.4g} s/MPa, "
                         f"tau = {r['model']['tau']:.4g} s")
        if kind == "pi":
            notes.append(f"pi fitted on the {'whole triangle run' if train is None else '0.2 Hz part'}: "
                         f"train RMS {r['train']['rms']:.3f} mm")
        if r["model"] is None:
            cells += [r["status"]] * 3 + ["-"]
            continue
        y_sim = np.asarray(h.simulate_record(r["model"], xs), dtype=float)
        for (a, b) in rs:
            e = y_sim[a:b] - ys[a:b]
            cells.append(f"{np.sqrt(np.mean(e * e)):.3f}")
        cells[-1] += cell_status(r)
        cells.append(f"{r['time_s']:.2f}")
    if kind == "auto":
        cells[0] = f"auto ({' / '.join(chosen)})"
    rows_b.append(cells)

print("Validation RMS [mm] on the sine run, per rate; fitted on the whole triangle run (all rates) | fitted on its "
      "0.2 Hz part only:\n")
hdr = " | ".join(f"{f:g} Hz" for f, _ in RATES)
print(f"| kind | {hdr} | fit time [s] | {hdr} | fit time [s] |")
print("|---|" + "---|" * (2 * len(RATES) + 2))
for c in rows_b:
    print("| " + " | ".join(c) + " |")
print()
print("\n".join(notes))
