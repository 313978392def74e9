#!/usr/bin/python3
"""hysteron's CLI against a numpy GPI forward on 1,000,000 samples (issue 13, item 8).

    /usr/bin/python3 bench/numpy_compare.py [--bin build/hysteron] [--repeats 5]
                                            [--naive-repeats 3] [--samples 1000000] [--dir DIR]

Run through bench/numpy_compare.sh. Both sides read the same input file and write their output
the same way:

* CSV: numpy reads with np.loadtxt (the fastest numpy reader measured here: 0.28 s for 1M rows,
  against 0.36 s np.fromstring(sep='\\n'), 0.46 s np.fromfile(sep='\\n'), 2.1 s np.genfromtxt) and
  writes the two columns hysteron writes (input,output) with '\\n'.join of repr() (shortest
  round-trip digits, like hysteron's to_chars; 2.3 s, the fastest found: np.savetxt(fmt='%.17g',
  delimiter=',') takes 4.0 s, np.char 4.2 s; its time is printed once for reference);
  hysteron runs `simulate` (CSV -> CSV) then `invert` (that CSV -> CSV) as two processes.
* .mat: numpy reads with scipy.io.loadmat and writes with scipy.io.savemat (MAT v5, uncompressed);
  both variables (input, output) as hysteron does; hysteron runs `simulate` (.mat -> .mat) then
  `invert` (.mat -> .mat).

The numpy GPI forward (tanh envelope, 10 operators, the model file of bench/io_speed.sh) in three
versions, all giving the same output:

* naive: a Python loop over samples, numpy over the operators (what a competent numpy user
  writes first: y = max(u - r, min(u + r, y)); out = q u + p . y);
* scan: fully vectorised, any input: the play's step y -> clamp(y, u - r, u + r) is a clamp, clamps
  compose into clamps, so the whole record is a parallel prefix scan (Hillis-Steele,
  log2(N) passes over an operators x N array), O(N log N) work;
* runs: the best for this input: on a monotone run of u the play is a running max (rising) or
  min (falling) against the value at the run's start, so a Python loop over the monotone runs
  (here about 130) with numpy over run x operators; it degrades to the naive loop on noisy input
  (every sample a turning point).

The envelope is np.tanh (hysteron uses its own tanh, within a few ulp): outputs agree with the
CLI's to about 1e-15 (checked and printed).

Times are wall clock, medians of the repeats, each a complete run (read + model + write; for
hysteron two process starts). Stage times of the numpy side are printed too.

At the end, the floor: two process starts (`hysteron --version`) plus the forward and inverse model
passes alone (hysteron's Python module next to the binary, build/python), i.e. what simulate +
invert would take with free I/O, and the largest ratio to the naive numpy forward it allows.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.io as sio

MODEL = ('{"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, '
         '"rho": 0.3, "tau": 1.5, "alpha": 0.05}\n')
C = (1.2, 0.8, 0.1, 0.05)
Q, N_OPS, RHO, TAU, ALPHA = 0.5, 10, 0.3, 1.5, 0.05
R = ALPHA * np.arange(1, N_OPS + 1)
P = RHO * np.exp(-TAU * R)


def envelope(x):
    return C[0] * np.tanh(C[1] * x + C[2]) + C[3]


def gpi_naive(x):
    u = envelope(x)
    y = np.zeros(N_OPS)
    out = np.empty_like(u)
    for k in range(u.size):
        uk = u[k]
        y = np.maximum(uk - R, np.minimum(uk + R, y))
        out[k] = Q * uk + P @ y
    return out


def gpi_scan(x):
    u = envelope(x)
    lo = u[None, :] - R[:, None]  # step k: y -> clamp(y, lo_k, hi_k)
    hi = u[None, :] + R[:, None]
    s = 1
    n = u.size
    while s < n:
        # F_k <- F_k o F_{k-s}: clamp(clamp(y, lo1, hi1), lo2, hi2) = clamp(y, lo', hi')
        # with lo' = clamp(lo1, lo2, hi2), hi' = clamp(hi1, lo2, hi2)
        lo1, hi1 = lo[:, :-s], hi[:, :-s]
        lo2, hi2 = lo[:, s:], hi[:, s:]
        new_lo = np.minimum(np.maximum(lo1, lo2), hi2)
        new_hi = np.minimum(np.maximum(hi1, lo2), hi2)
        lo[:, s:] = new_lo
        hi[:, s:] = new_hi
        s *= 2
    y = np.minimum(np.maximum(0.0, lo), hi)  # from the virgin state y = 0
    return Q * u + P @ y


def gpi_runs(x):
    u = envelope(x)
    n = u.size
    out = np.empty_like(u)
    if n == 0:
        return out
    y = np.maximum(u[0] - R, np.minimum(u[0] + R, np.zeros(N_OPS)))  # first sample: any state
    out[0] = Q * u[0] + P @ y
    # after it |y - u| <= r, so on a rising run y_k = max(y_s, u_k - r), on a falling one
    # y_k = min(y_s, u_k + r), y_s = the state before the run
    d = np.sign(np.diff(u))
    d[d == 0] = 1  # a flat step changes nothing either way
    starts = np.flatnonzero(np.diff(d)) + 1  # index into d of each direction change
    bounds = np.concatenate(([0], starts, [d.size])) + 1  # runs of u indices [b0, b1)
    for a, b in zip(bounds[:-1], bounds[1:]):
        seg = u[a:b]
        if d[a - 1] > 0:
            ys = np.maximum(y[:, None], seg[None, :] - R[:, None])
        else:
            ys = np.minimum(y[:, None], seg[None, :] + R[:, None])
        out[a:b] = Q * seg + P @ ys
        y = ys[:, -1]
    return out


FORWARDS = {"naive": gpi_naive, "scan": gpi_scan, "runs": gpi_runs}


def read_csv(path):
    return np.loadtxt(path, skiprows=1, dtype=np.float64)


def write_csv(path, x, y):
    # the columns hysteron writes (input,output), shortest round-trip digits like its to_chars
    with open(path, "w") as f:
        f.write("input,output\n")
        f.write("\n".join(map("{!r},{!r}".format, x.tolist(), y.tolist())))
        f.write("\n")


def write_csv_savetxt(path, x, y):
    with open(path, "w") as f:
        f.write("input,output\n")
        np.savetxt(f, np.column_stack((x, y)), fmt="%.17g", delimiter=",")


def read_mat(path):
    return sio.loadmat(path)["input"].ravel()


def write_mat(path, x, y):
    sio.savemat(path, {"input": x.reshape(-1, 1), "output": y.reshape(-1, 1)})


def numpy_run(fmt, forward, src, dst):
    """One complete numpy run; returns (total, read, model, write) seconds."""
    t0 = time.perf_counter()
    x = read_csv(src) if fmt == "csv" else read_mat(src)
    t1 = time.perf_counter()
    y = FORWARDS[forward](x)
    t2 = time.perf_counter()
    if fmt == "csv":
        write_csv(dst, x, y)
    else:
        write_mat(dst, x, y)
    t3 = time.perf_counter()
    return t3 - t0, t1 - t0, t2 - t1, t3 - t2


def run_cli(args):
    t0 = time.perf_counter()
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def floor(a, j, x, results):
    """The least time any simulate + invert through two CLI processes can take on this machine:
    two process starts (`hysteron --version`: dynamic loading, no work) plus the forward and the
    inverse model pass alone (hysteron's Python module, in process, the same model and input),
    with no reading, writing or checking at all. Against it, the largest ratio to the naive numpy
    forward that any I/O could reach."""
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(a.bin)), "python"))
    try:
        import hysteron
    except ImportError as e:
        print(f"\nfloor: skipped (no hysteron Python module next to {a.bin}: {e})")
        return
    starts = [run_cli([a.bin, "--version"]) for _ in range(21)]
    fwd, inv = [], []
    for _ in range(a.repeats):
        m = hysteron.Model(j("gpi.json"))
        t0 = time.perf_counter()
        y = m.simulate(x)
        t1 = time.perf_counter()
        hysteron.Inverse(j("gpi.json"), limits=(0.0, 0.6)).simulate(y)
        t2 = time.perf_counter()
        fwd.append(t1 - t0)
        inv.append(t2 - t1)
    start, f, i = statistics.median(starts), statistics.median(fwd), statistics.median(inv)
    fl = 2 * start + f + i
    print(f"\nfloor of simulate + invert (medians): 2 process starts 2 x {start * 1e3:.1f} ms + forward "
          f"{f * 1e3:.1f} ms + inverse {i * 1e3:.1f} ms = {fl * 1e3:.1f} ms, with no I/O at all")
    for fmt, target in (("csv", 20), ("mat", 100)):
        npt = results[("naive", fmt)]
        print(f"  {fmt:3}: naive numpy {npt:.3f} s / floor = at most {npt / fl:.1f}x possible "
              f"(target {target}x needs simulate + invert <= {npt / target * 1e3:.1f} ms; "
              f"measured {results[('hysteron', fmt)] * 1e3:.1f} ms)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="build/hysteron")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--naive-repeats", type=int, default=3)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--dir", default=None)
    a = ap.parse_args()
    tmp = a.dir or tempfile.mkdtemp(prefix="numpy_compare.")
    j = lambda name: os.path.join(tmp, name)
    with open(j("gpi.json"), "w") as f:
        f.write(MODEL)
    k = np.arange(a.samples)
    x = 0.3 + 0.25 * np.sin(2e-4 * k) * np.cos(3e-6 * k)  # the input of bench/io_speed.sh
    with open(j("x.csv"), "w") as f:
        f.write("input\n")
        np.savetxt(f, x, fmt="%.17g")
    sio.savemat(j("x.mat"), {"input": x.reshape(-1, 1)})

    # correctness: the three numpy forwards against each other and against the CLI
    ref = gpi_runs(x)
    subprocess.run([a.bin, "simulate", "--model", j("gpi.json"), "--input", j("x.csv"),
                    "--output", j("cli.csv")], check=True, stderr=subprocess.DEVNULL)
    cli = np.loadtxt(j("cli.csv"), skiprows=1, delimiter=",")[:, 1]
    scan = gpi_scan(x)
    m = min(a.samples, 20000)
    naive = gpi_naive(x[:m])
    print(f"samples: {a.samples}; input: {j('x.csv')} ({os.path.getsize(j('x.csv')) / 1e6:.1f} MB), "
          f"{j('x.mat')} ({os.path.getsize(j('x.mat')) / 1e6:.1f} MB)")
    print(f"max |runs - scan| = {np.max(np.abs(ref - scan)):.3g}, "
          f"max |runs - naive| (first {m}) = {np.max(np.abs(ref[:m] - naive)):.3g}, "
          f"max |numpy - hysteron| = {np.max(np.abs(ref - cli)):.3g} (output range {ref.min():.3f}..{ref.max():.3f})")
    d = np.sign(np.diff(envelope(x)))
    d[d == 0] = 1
    print(f"monotone runs in the input: {np.count_nonzero(np.diff(d)) + 1}")
    t0 = time.perf_counter()
    write_csv_savetxt(j("np.csv"), x, ref)
    t1 = time.perf_counter()
    write_csv(j("np.csv"), x, ref)
    t2 = time.perf_counter()
    print(f"CSV writers (one run): np.savetxt %.17g {t1 - t0:.3f} s, join of repr {t2 - t1:.3f} s (used)")

    print(f"\nbinary: {a.bin}; wall clock, medians of {a.repeats} runs ({a.naive_repeats} for naive)")
    results = {}
    for fmt in ("csv", "mat"):
        sim = [a.bin, "simulate", "--model", j("gpi.json"), "--input", j("x." + fmt),
               "--output", j("y." + fmt)]
        inv = [a.bin, "invert", "--model", j("gpi.json"), "--input", j("y." + fmt), "--column", "output",
               "--output", j("xr." + fmt), "--limits", "0,0.6"]
        ts, ti, tt = [], [], []
        for _ in range(a.repeats):
            s = run_cli(sim)
            i = run_cli(inv)
            ts.append(s)
            ti.append(i)
            tt.append(s + i)
        results[("hysteron", fmt)] = statistics.median(tt)
        print(f"hysteron {fmt:3}: simulate {statistics.median(ts):.3f} s + invert {statistics.median(ti):.3f} s; "
              f"simulate+invert {statistics.median(tt):.3f} s")
        for fw in ("naive", "scan", "runs"):
            reps = a.naive_repeats if fw == "naive" else a.repeats
            rs = [numpy_run(fmt, fw, j("x." + fmt), j("np." + fmt)) for _ in range(reps)]
            med = [statistics.median(r[i] for r in rs) for i in range(4)]
            results[(fw, fmt)] = med[0]
            print(f"numpy {fw:5} {fmt:3}: total {med[0]:.3f} s (read {med[1]:.3f}, forward {med[2]:.3f}, "
                  f"write {med[3]:.3f})")
    print("\nratio = numpy GPI forward (read + model + write) / hysteron simulate + invert")
    print("| numpy forward | CSV numpy | CSV hysteron | CSV ratio | .mat numpy | .mat hysteron | .mat ratio |")
    print("|---|---|---|---|---|---|---|")
    for fw in ("naive", "scan", "runs"):
        row = [fw]
        for fmt in ("csv", "mat"):
            npt, hy = results[(fw, fmt)], results[("hysteron", fmt)]
            row += [f"{npt:.3f} s", f"{hy:.3f} s", f"{npt / hy:.1f}x"]
        print("| " + " | ".join(row) + " |")
    floor(a, j, x, results)
    if not a.dir:
        for name in os.listdir(tmp):
            os.remove(j(name))
        os.rmdir(tmp)


if __name__ == "__main__":
    sys.exit(main())
