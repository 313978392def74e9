#!/usr/bin/python3
"""The C ABI from Python ctypes (no numpy): load each model file, invert the CLI's
simulated output, compare with `hysteron invert` (bit for bit or within 1e-12), step
the feedforward + PID controller, and check error paths (status and message).

Usage: test_ctypes.py LIBHYSTERON_C.so HYSTERON_CLI TESTS_C_API_DIR [plain|sanitize]
Exit status 77 (ctest SKIP_RETURN_CODE) under sanitize: an ASan library cannot be
dlopen'ed into an uninstrumented python.
"""
import csv
import ctypes as C
import math
import os
import subprocess
import sys
import tempfile

if len(sys.argv) < 4:
    sys.exit(__doc__)
lib_path, cli, tests_dir = sys.argv[1:4]
if len(sys.argv) > 4 and sys.argv[4] == "sanitize":
    print("c_api.ctypes: skipped: the library is built with AddressSanitizer (HYSTERON_SANITIZE=ON), "
          "which cannot be dlopen'ed into python")
    sys.exit(77)

lib = C.CDLL(lib_path)
dp = C.POINTER(C.c_double)
OK, NULL_POINTER, INVALID_ARGUMENT, PARSE, MODEL, IO = 0, 1, 2, 3, 4, 5


class FfPidParams(C.Structure):
    _fields_ = [(name, C.c_double) for name in (
        "sample_time", "pressure_min", "pressure_max", "model_scale", "lag_time_constant", "kp", "ki", "kd",
        "derivative_filter", "tracking_time", "setpoint_weight_p", "setpoint_weight_d")] + [("anti_windup", C.c_int)]


def sig(name, *args):
    f = getattr(lib, name)
    f.argtypes = list(args)
    f.restype = C.c_int
    return f


lib.hysteron_last_error.restype = C.c_char_p
lib.hysteron_last_error.argtypes = []
lib.hysteron_version_string.restype = C.c_char_p
lib.hysteron_version_string.argtypes = []
params_from_json = sig("hysteron_params_from_json", C.c_char_p, C.POINTER(C.c_void_p))
params_from_file = sig("hysteron_params_from_file", C.c_char_p, C.POINTER(C.c_void_p))
params_free = sig("hysteron_params_free", C.c_void_p)
params_kind = sig("hysteron_params_kind", C.c_void_p, C.POINTER(C.c_char_p))
inverse_create = sig("hysteron_inverse_create", C.c_void_p, C.c_double, C.c_double, C.POINTER(C.c_void_p))
inverse_free = sig("hysteron_inverse_free", C.c_void_p)
inverse_step = sig("hysteron_inverse_step", C.c_void_p, C.c_double, dp, C.POINTER(C.c_int))
inverse_invert = sig("hysteron_inverse_invert", C.c_void_p, dp, C.c_size_t, dp, C.c_size_t, C.POINTER(C.c_size_t))
inverse_reset = sig("hysteron_inverse_reset", C.c_void_p)
model_create = sig("hysteron_model_create", C.c_void_p, C.POINTER(C.c_void_p))
model_free = sig("hysteron_model_free", C.c_void_p)
model_step = sig("hysteron_model_step", C.c_void_p, C.c_double, dp)
model_simulate = sig("hysteron_model_simulate", C.c_void_p, dp, C.c_size_t, dp, C.c_size_t)
ff_pid_default = sig("hysteron_ff_pid_default_params", C.POINTER(FfPidParams))
ff_pid_create = sig("hysteron_ff_pid_create", C.c_void_p, C.POINTER(FfPidParams), C.POINTER(C.c_void_p))
ff_pid_step = sig("hysteron_ff_pid_step", C.c_void_p, C.c_double, C.c_double, C.c_double, dp)
ff_pid_free = sig("hysteron_ff_pid_free", C.c_void_p)

failures = 0


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print(f"FAIL {what}")


def expect(status, expected, needle, what):
    msg = lib.hysteron_last_error().decode()
    ok = status == expected and needle in msg
    check(ok, f"{what}: status {status} (expected {expected}), message {msg!r} (expected to contain {needle!r})")
    if ok:
        print(f"ok   {what}: {msg}")


def array(values):
    return (C.c_double * len(values))(*values)


print(f"hysteron C ABI {lib.hysteron_version_string().decode()} via ctypes")

# ---- error paths ------------------------------------------------------------------
h = C.c_void_p()
expect(params_from_json(b'{"model": "gpi", ', C.byref(h)), PARSE, "not valid JSON", "bad JSON")
check(not h.value, "no handle after a failure")
expect(params_from_json(b'{"model": "pi", "r": [0.1], "p": [1], "gain": 2}', C.byref(h)), MODEL, "gain", "unknown key")
expect(params_from_file(b"/nonexistent/m.json", C.byref(h)), IO, "/nonexistent/m.json", "missing file")
expect(params_from_json(None, C.byref(h)), NULL_POINTER, "json", "NULL json")
expect(params_from_json(b"{}", None), NULL_POINTER, "out", "NULL out")

# ---- each model kind: C ABI inverse == CLI inverse -------------------------------------
with tempfile.TemporaryDirectory() as tmp:
    xs = [0.8 * math.sin(0.013 * k) * math.exp(-k / 3000) + 0.15 * math.sin(0.17 * k) for k in range(3000)]
    with open(os.path.join(tmp, "x.csv"), "w") as f:
        f.write("x\n" + "".join(f"{v!r}\n" for v in xs))
    for kind in ("gpi", "pi", "dz", "asym"):
        model_file = os.path.join(tests_dir, f"{kind}.json")
        y_csv, x_csv = os.path.join(tmp, f"y_{kind}.csv"), os.path.join(tmp, f"x_{kind}.csv")
        subprocess.run([cli, "simulate", "--model", model_file, "--input", os.path.join(tmp, "x.csv"), "--column", "x",
                        "--output", y_csv], check=True)
        subprocess.run([cli, "invert", "--model", model_file, "--input", y_csv, "--column", "output",
                        "--output", x_csv], check=True, stderr=subprocess.DEVNULL)
        y = [float(r["output"]) for r in csv.DictReader(open(y_csv))]
        x_cli = [float(r["input"]) for r in csv.DictReader(open(x_csv))]

        params = C.c_void_p()
        st = params_from_file(model_file.encode(), C.byref(params))
        check(st == OK, f"{kind}: load: {lib.hysteron_last_error().decode()}")
        name = C.c_char_p()
        params_kind(params, C.byref(name))
        inv = C.c_void_p()
        check(inverse_create(params, -math.inf, math.inf, C.byref(inv)) == OK, f"{kind}: inverse_create")
        n = len(y)
        ya, xa, nsat = array(y), (C.c_double * n)(), C.c_size_t(99)
        check(inverse_invert(inv, ya, n, xa, n, C.byref(nsat)) == OK, f"{kind}: invert")
        x_c = list(xa)
        diff = max(abs(a - b) for a, b in zip(x_c, x_cli))
        same = sum(a == b for a, b in zip(x_c, x_cli))
        print(f"{kind} ({name.value.decode()}): ctypes inverse vs CLI over {n} samples: {same} bit-identical, "
              f"max |difference| {diff:.3g}, {nsat.value} saturated")
        check(len(x_cli) == n and diff <= 1e-12, f"{kind}: ctypes and CLI differ by {diff}")
        # per sample == batch
        inverse_reset(inv)
        xk, sat = C.c_double(), C.c_int(-1)
        worst = 0.0
        for k in range(n):
            check(inverse_step(inv, y[k], C.byref(xk), C.byref(sat)) == OK, f"{kind}: step {k}")
            worst = max(worst, abs(xk.value - x_c[k]))
        check(worst == 0.0, f"{kind}: per-sample and batch inverse differ by {worst}")
        # error paths on this handle
        held = xk.value
        expect(inverse_step(inv, math.nan, C.byref(xk), None), INVALID_ARGUMENT, "y_desired = nan", f"{kind}: NaN step")
        check(xk.value == held, f"{kind}: NaN holds the previous input")
        expect(inverse_invert(inv, ya, n, xa, n - 1, None), INVALID_ARGUMENT, f"n_y = {n} and n_x = {n - 1} differ",
               f"{kind}: wrong sizes")
        ya[7] = math.nan
        expect(inverse_invert(inv, ya, n, xa, n, None), INVALID_ARGUMENT, "y[7] = nan", f"{kind}: NaN in a batch")
        expect(inverse_step(None, 0.1, C.byref(xk), None), NULL_POINTER, "inverse is NULL", f"{kind}: NULL handle")
        inverse_free(inv)

        # forward model through the C ABI == the CLI's simulate
        model = C.c_void_p()
        check(model_create(params, C.byref(model)) == OK, f"{kind}: model_create")
        ys = (C.c_double * n)()
        check(model_simulate(model, array(xs[:n]), n, ys, n) == OK, f"{kind}: simulate")
        fdiff = max(abs(a - b) for a, b in zip(ys, y))
        check(fdiff <= 1e-12, f"{kind}: ctypes forward vs CLI simulate {fdiff}")

        # feedforward + PID, the model as plant
        cp = FfPidParams()
        ff_pid_default(C.byref(cp))
        cp.kp, cp.ki = 5.0, 1.0
        cp.pressure_min, cp.pressure_max = -1.0, 1.0
        ctl = C.c_void_p()
        check(ff_pid_create(params, C.byref(cp), C.byref(ctl)) == OK, f"{kind}: ff_pid_create: "
              f"{lib.hysteron_last_error().decode()}")
        p, meas = C.c_double(), C.c_double(0.0)
        worst = 0.0
        for k in range(n):
            ref = y[k] / 1000.0
            ff_pid_step(ctl, ref, ref, meas.value / 1000.0 if k else 0.0, C.byref(p))
            check(-1.0 <= p.value <= 1.0, f"{kind}: command {p.value} outside the limits")
            model_step(model, p.value, C.byref(meas))
        expect(ff_pid_step(ctl, 0.0, math.inf, 0.0, C.byref(p)), INVALID_ARGUMENT, "preview_m = inf",
               f"{kind}: ff_pid inf")
        cp.sample_time = -1.0
        ctl2 = C.c_void_p()
        expect(ff_pid_create(params, C.byref(cp), C.byref(ctl2)), INVALID_ARGUMENT, "sample_time",
               f"{kind}: bad sample time")
        ff_pid_free(ctl)
        model_free(model)
        params_free(params)

print(f"c_api.ctypes: {failures} failure(s)")
sys.exit(1 if failures else 0)
