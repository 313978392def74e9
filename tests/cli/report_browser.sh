#!/usr/bin/env bash
# hysteron report on a small fit report and a small experiment directory, both
# opened in headless Chromium: the screenshot must not be blank and every plot
# must be in the DOM. Skipped (exit 0) only if chromium is missing.
# Usage: bash report_browser.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
PY=/usr/bin/python3
CHROME=${CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$CHROME" ]; then
  echo "report_browser: $CHROME not found: skipped"
  exit 0
fi
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

cat > "$T/model.json" <<'JSON'
{"schema": 1, "model": "gpi", "envelope": "tanh", "c": [40, 3, 0, 0], "q": 1, "n": 5,
 "rho": 0.4, "tau": 2, "alpha": 3, "units": {"input": "MPa", "output": "mm"}}
JSON
# identification-like input: decaying triangle 0..0.6 MPa
$PY - "$T/x.csv" <<'PYEOF'
import sys
with open(sys.argv[1], "w") as f:
    f.write("t,pressure\n")
    n = 3000
    for k in range(n):
        ph = (k % 500) / 500.0
        amp = 0.6 - 0.1 * (k // 500)
        x = amp * (2 * ph if ph < 0.5 else 2 - 2 * ph)
        f.write(f"{k * 0.01:.2f},{x!r}\n")
PYEOF
"$BIN" simulate --model "$T/model.json" --input "$T/x.csv" --column pressure --output "$T/y.csv"

# a fit report in the documented format (as `hysteron fit --report` writes it)
$PY - "$T" <<'PYEOF'
import csv, json, math, sys
d = sys.argv[1]
rows = list(csv.DictReader(open(f"{d}/y.csv")))
with open(f"{d}/data.csv", "w") as f:
    f.write("pressure_kpa_ignored,pressure,length\n")
    for i, r in enumerate(rows):
        f.write(f"0,{r['input']},{float(r['output']) + 0.05 * math.sin(0.3 * i)!r}\n")
model = json.load(open(f"{d}/model.json"))
del model["units"]
fit = {"format": "hysteron-fit-report", "schema": 1, "status": "converged", "message": "test",
       "model_kind": "gpi", "initial_cost": 10.0, "final_cost": 0.5, "iterations": 12,
       "total_iterations": 20, "num_starts": 2, "time_s": 0.1, "covariance_note": "",
       "model": model,
       "parameters": [{"name": "c0", "value": 40, "std_error": 0, "held": True},
                      {"name": "q", "value": 1, "std_error": 0.01, "held": False}],
       "train": {"rms": math.sqrt(sum((0.05 * math.sin(0.3 * i)) ** 2 for i in range(2000)) / 2000), "max": 0.05,
                 "mae": 0.03, "rms_percent_span": 0.1, "r2": 0.999, "n": 2000},
       "data": {"input": {"file": "data.csv", "column": "pressure"},
                "output": {"file": "data.csv", "column": "length"},
                "input_axis": {"label": "Pressure", "unit": "MPa"},
                "output_axis": {"label": "Contraction", "unit": "mm"},
                "initial_state": "virgin", "train": [0, 2000]}}
json.dump(fit, open(f"{d}/fit.json", "w"))

# a small experiment directory in the format of ExperimentResult::write
e = f"{d}/exp"
import os
os.makedirs(e)
with open(f"{e}/identification.csv", "w") as f:
    f.write("t_s,pressure_command_mpa,pressure_mpa,contraction_mm\n")
    for i, r in enumerate(rows):
        f.write(f"{i * 0.01!r},{r['input']},{r['input']},{r['output']}\n")
errs = {}
for v in ("compensated", "faithful", "baseline"):
    with open(f"{e}/tracking_{v}_sine.csv", "w") as f:
        f.write("t_s,reference_mm,measured_mm,actual_mm,pressure_command_mpa,pressure_mpa,pwm_duty\n")
        for i in range(2000):
            t = i * 0.005
            ref = 50 + 45 * math.sin(2 * math.pi * 0.2 * t)
            m = ref + {"compensated": 0.5, "faithful": 1.5, "baseline": 4}[v] * math.sin(2 * math.pi * 0.4 * t)
            f.write(f"{t!r},{ref!r},{m!r},{m!r},0.3,0.3,0\n")
    errs[v] = {"max_error_mm": 1.0, "mae_mm": 0.5, "rms_error_mm": 0.6, "description": f"{v} loop",
               "saturated_samples": 0}
metrics = {"rms": 0.1, "max": 0.2, "mae": 0.1, "rms_percent_span": 0.5, "r2": 0.99, "n": 100}
res = {"experiment": "gpi-pid", "title": "browser test", "seed": 1, **errs,
       "published": {"source": "Table 5", "max_error_mm": 2.659, "mae_mm": 0.7358, "rms_error_mm": 0.8701},
       "identification": {"model": "gpi", "status": "converged", "train": metrics, "validate": metrics,
                          "fit_time_s": 1.0, "train_end": 1500, "parameters": model},
       "best_model": {"model": "gpi", "validate_second_run": metrics, "parameters": model},
       "units": {"pressure": "MPa", "contraction": "mm", "time": "s"}, "wall_time_s": 2.0}
json.dump(res, open(f"{e}/result.json", "w"))
json.dump(model, open(f"{e}/model.json", "w"))
json.dump(model, open(f"{e}/best_model.json", "w"))
PYEOF

"$BIN" report "$T/fit.json" --out "$T/fit.html"
"$BIN" report "$T/exp" --out "$T/exp.html"

chrome() {
  local profile
  profile=$(mktemp -d -p "$T")
  timeout 60 "$CHROME" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync --disable-dev-shm-usage \
    --user-data-dir="$profile" "$@" 2> "$T/chrome.log"
}

chrome --window-size=1200,3000 --screenshot="$T/exp.png" "file://$T/exp.html" > /dev/null
chrome --dump-dom "file://$T/exp.html" > "$T/exp.dom"
chrome --dump-dom "file://$T/fit.html" > "$T/fit.dom"

# the screenshot: a PNG decoded by hand (zlib + row filters); not blank
$PY - "$T/exp.png" <<'PYEOF'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
pos, idat, hdr = 8, b"", None
while pos < len(data):
    n, typ = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if typ == b"IHDR": hdr = struct.unpack(">IIBBBBB", body)
    elif typ == b"IDAT": idat += body
    pos += 12 + n
w, h, depth, ctype, _, _, interlace = hdr
assert depth == 8 and ctype in (2, 6) and interlace == 0, hdr
bpp = 3 if ctype == 2 else 4
raw = zlib.decompress(idat)
stride = w * bpp
prev = bytearray(stride)
colours, nonwhite = set(), 0
for y in range(h):
    f = raw[y * (stride + 1)]
    line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c
            pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    if y % 3 == 0:
        for x in range(0, w, 2):
            px = bytes(line[x * bpp:x * bpp + 3])
            colours.add(px)
            if px != b"\xff\xff\xff": nonwhite += 1
    prev = line
sampled = (h // 3 + 1) * (w // 2)
print(f"screenshot {w}x{h}: {len(colours)} distinct colours, {100 * nonwhite / sampled:.1f} % not white")
assert len(colours) >= 20, "screenshot looks blank (too few colours)"
assert nonwhite > 0.01 * sampled, "screenshot looks blank (almost all white)"
PYEOF

# every plot in the DOM: 6 figures for the experiment (Figs. 4, 5/9, residuals, 11, 12, 13), 3 for the fit
$PY - "$T/exp.dom" 6 "$T/fit.dom" 3 <<'PYEOF'
import sys
args = sys.argv[1:]
for path, want in zip(args[::2], args[1::2]):
    dom = open(path).read()
    svgs, figs = dom.count("<svg"), dom.count("<figure")
    print(f"{path}: {svgs} <svg>, {figs} <figure>")
    assert svgs == int(want) and figs == int(want), f"{path}: expected {want} plots"
    assert "hysteron 0." in dom and "Contraction [mm]" in dom, f"{path}: header or axis labels missing"
    assert "<img" not in dom or "data:" in dom, f"{path}: external image"
PYEOF
grep -q "2.659" "$T/exp.dom"
echo "report_browser: ok"
