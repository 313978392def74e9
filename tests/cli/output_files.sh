#!/usr/bin/env bash
# Output files and corrupt .mat input through the CLI (issue 13, items 1 and 2): an output that is
# an input is refused before anything is read or written; devices, FIFOs, symlinks, modes,
# read-only files and hard links; temporary files removed on SIGINT/SIGTERM/SIGHUP; full disks
# fail with the old file intact; truncated and hostile .mat files are refused.
# Usage: bash output_files.sh <hysteron-binary> <source-dir>
set -euo pipefail
BIN=$1
T=$(mktemp -d)
MNT="$T/small"
cleanup() {
  if mountpoint -q "$MNT" 2> /dev/null; then umount -l "$MNT" || true; fi
  rm -rf "$T"
}
trap cleanup EXIT
PY=/usr/bin/python3
fail() { echo "FAIL: $*" >&2; exit 1; }

# expect_fail "what" "message part" cmd...: exit status 1 and the message on stderr
expect_fail() {
  local what=$1 part=$2
  shift 2
  local rc=0
  "$@" > "$T/out" 2> "$T/err" || rc=$?
  [ "$rc" -eq 1 ] || { cat "$T/err"; fail "$what: exit $rc, expected 1"; }
  grep -qF -- "$part" "$T/err" || { cat "$T/err"; fail "$what: message lacks '$part'"; }
}
no_temp_files() {  # no .NAME.tmp-* file left in the directory
  local left
  left=$(find "$1" -maxdepth 1 -name '.*.tmp-*' | head -1)
  [ -z "$left" ] || fail "temporary file left: $left"
}

cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05}
JSON
$PY - "$T/x.csv" "$T/d.csv" <<'PYEOF'
import math, sys
with open(sys.argv[1], "w") as f:
    f.write("x\n")
    for k in range(500):
        f.write(f"{0.8 * math.sin(0.03 * k)!r}\n")
with open(sys.argv[2], "w") as f:
    f.write("x,y\n")
    for k in range(400):
        x = 0.8 * math.sin(0.03 * k)
        f.write(f"{x!r},{math.tanh(x) + 0.01 * math.sin(0.5 * k)!r}\n")
PYEOF
cp "$T/d.csv" "$T/d.orig"
cp "$T/gpi.json" "$T/gpi.orig"
cp "$T/x.csv" "$T/x.orig"
ln -s d.csv "$T/dlink.csv"
ln "$T/d.csv" "$T/dhard.csv"

# ---- an output that is an input: refused, nothing written ------------------------------------
FIT=(fit -d "$T/d.csv" -i x -y y --model pi --n 3)
expect_fail "fit -o = data" "--out $T/d.csv and --data $T/d.csv are the same file" "$BIN" "${FIT[@]}" -o "$T/d.csv"
expect_fail "fit -o = data via symlink" "are the same file" "$BIN" "${FIT[@]}" -o "$T/dlink.csv"
expect_fail "fit -o = data via hard link" "are the same file" "$BIN" "${FIT[@]}" -o "$T/dhard.csv"
expect_fail "fit --report = data" "--report $T/d.csv and --data" "$BIN" "${FIT[@]}" -o "$T/m.json" --report "$T/d.csv"
expect_fail "fit -o X --report X" "--report $T/m.json and --out $T/m.json are the same file" \
  "$BIN" "${FIT[@]}" -o "$T/m.json" --report "$T/m.json"
[ ! -e "$T/m.json" ] || fail "fit wrote a model although its outputs collide"
expect_fail "fit -o = --validate-data" "--validate-data" "$BIN" "${FIT[@]}" -o "$T/x.csv" --validate-data "$T/x.csv"
expect_fail "simulate -o = model" "--output $T/gpi.json and --model $T/gpi.json are the same file" \
  "$BIN" simulate -m "$T/gpi.json" -i "$T/x.csv" -o "$T/gpi.json"
expect_fail "simulate -o = input" "--output $T/x.csv and --input" "$BIN" simulate -m "$T/gpi.json" -i "$T/x.csv" -o "$T/x.csv"
expect_fail "invert -o = input" "are the same file" "$BIN" invert -m "$T/gpi.json" -i "$T/d.csv" -c y -o "$T/dlink.csv"
expect_fail "evaluate --report = model" "--report $T/gpi.json and --model" \
  "$BIN" evaluate -m "$T/gpi.json" -d "$T/d.csv" -i x -y y --report "$T/gpi.json"
expect_fail "evaluate --report = data" "--report $T/d.csv and --data" \
  "$BIN" evaluate -m "$T/gpi.json" -d "$T/d.csv" -i x -y y --report "$T/d.csv"
"$BIN" "${FIT[@]}" -o "$T/m.json" --report "$T/rep.json" --force > /dev/null 2>&1 || true
if [ -f "$T/rep.json" ]; then
  cp "$T/rep.json" "$T/rep.orig"
  expect_fail "report rep.json -o rep.json" "--out $T/rep.json and INPUT $T/rep.json are the same file" \
    "$BIN" report "$T/rep.json" -o "$T/rep.json"
  cmp -s "$T/rep.json" "$T/rep.orig" || fail "report overwrote its input"
  expect_fail "report -o = --data" "--data" "$BIN" report "$T/rep.json" -o "$T/d.csv" -d "$T/d.csv" -i x -y y
else
  fail "fit wrote no report to test report with"
fi
cmp -s "$T/d.csv" "$T/d.orig" || fail "the data file was changed"
cmp -s "$T/gpi.json" "$T/gpi.orig" || fail "the model file was changed"
cmp -s "$T/x.csv" "$T/x.orig" || fail "the input file was changed"
no_temp_files "$T"
echo "same-file refusals: ok"

SIM=(simulate -m "$T/gpi.json" -i "$T/x.csv")

# ---- devices and FIFOs: written in place ----------------------------------------------------
if [ "$(id -u)" -eq 0 ]; then
  mknod "$T/null" c 1 3
  "$BIN" "${SIM[@]}" -o "$T/null"
  "$BIN" "${SIM[@]}" -o "$T/null.mat" 2> /dev/null || true  # (a .mat on a device: matio may need to seek)
  [ -c "$T/null" ] || fail "the device node $T/null was replaced"
  "$BIN" "${SIM[@]}" -o /dev/null
  [ -c /dev/null ] || fail "/dev/null was replaced"
  echo "device node: ok"
else
  echo "not root: device-node case (mknod) skipped"
fi
mkfifo "$T/fifo.csv"
cat "$T/fifo.csv" > "$T/fifo.got" &
"$BIN" "${SIM[@]}" -o "$T/fifo.csv"
wait
[ -p "$T/fifo.csv" ] || fail "the FIFO was replaced"
[ "$(wc -l < "$T/fifo.got")" -eq 501 ] || fail "the FIFO reader got $(wc -l < "$T/fifo.got") lines"
"$BIN" "${SIM[@]}" -o /dev/stdout > "$T/stdout.csv"  # a regular file behind /dev/stdout: written, not replaced
[ "$(head -1 "$T/stdout.csv")" = "input,output" ] && [ "$(wc -l < "$T/stdout.csv")" -eq 501 ] || fail "/dev/stdout"
"$BIN" "${SIM[@]}" -o /dev/stdout | cat > "$T/piped.csv"
[ "$(wc -l < "$T/piped.csv")" -eq 501 ] || fail "/dev/stdout into a pipe"
echo "FIFO and /dev/stdout: ok"

# ---- symlinks, modes, read-only files, hard links -------------------------------------------
mkdir "$T/real"
echo old > "$T/real/y.csv"
ln -s real/y.csv "$T/ylink.csv"
"$BIN" "${SIM[@]}" -o "$T/ylink.csv"
[ -L "$T/ylink.csv" ] || fail "the symlink was replaced by a file"
head -1 "$T/real/y.csv" | grep -qx 'input,output' || fail "the symlink's target was not written"
echo old > "$T/secret.csv"
chmod 600 "$T/secret.csv"
"$BIN" "${SIM[@]}" -o "$T/secret.csv"
[ "$(stat -c %a "$T/secret.csv")" = 600 ] || fail "mode 600 became $(stat -c %a "$T/secret.csv")"
echo "keep me" > "$T/ro.csv"
chmod 444 "$T/ro.csv"
expect_fail "read-only output" "$T/ro.csv: is read-only (mode 444)" "$BIN" "${SIM[@]}" -o "$T/ro.csv"
[ "$(cat "$T/ro.csv")" = "keep me" ] || fail "the read-only file was changed"
echo old > "$T/h1.csv"
ln "$T/h1.csv" "$T/h2.csv"
"$BIN" "${SIM[@]}" -o "$T/h1.csv"
[ "$(stat -c %h "$T/h1.csv")" -eq 2 ] || fail "the hard link was broken"
cmp -s "$T/h1.csv" "$T/h2.csv" || fail "the hard links differ"
no_temp_files "$T"
echo "symlink, mode, read-only, hard links: ok"

# ---- signals: the temporary file is removed, the old file stays ----------------------------
mkdir "$T/sig"
$PY - "$T/big.csv" <<'PYEOF'
import math, sys
with open(sys.argv[1], "w") as f:
    f.write("x\n")
    f.write("".join(f"{math.sin(0.001 * k) * (1 + 0.1 * math.sin(0.37 * k))!r}\n" for k in range(1500000)))
PYEOF
for sig in INT TERM HUP; do
  "$BIN" "${SIM[@]}" -o "$T/sig/out.mat"  # the old file (from the small input)
  cp "$T/sig/out.mat" "$T/sig/old.mat"
  $PY - "$BIN" "$T/gpi.json" "$T/big.csv" "$T/sig" "$sig" <<'PYEOF'
import glob, os, signal, subprocess, sys, time
binary, model, data, d, name = sys.argv[1:6]
sig = getattr(signal, "SIG" + name)
for attempt in range(5):
    p = subprocess.Popen([binary, "simulate", "-m", model, "-i", data, "-o", os.path.join(d, "out.mat")],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while p.poll() is None and not glob.glob(os.path.join(d, ".out.mat.tmp-*")):
        time.sleep(0.002)
    if p.poll() is not None:
        print(f"SIG{name}: the write finished before the temporary file was seen; retrying")
        continue
    p.send_signal(sig)
    rc = p.wait()
    if rc != -sig:
        sys.exit(f"SIG{name}: exit status {rc}, expected death by the signal ({-sig})")
    left = glob.glob(os.path.join(d, ".*.tmp-*"))
    if left:
        sys.exit(f"SIG{name}: temporary files left: {left}")
    print(f"SIG{name}: killed during the write, no temporary file left")
    break
else:
    sys.exit(f"SIG{name}: could not interrupt a write in 5 attempts")
PYEOF
  cmp -s "$T/sig/out.mat" "$T/sig/old.mat" || fail "SIG$sig: the old output was changed"
done

# ---- full disks: non-zero exit, the old file byte-identical ---------------------------------
expect_fail "/dev/full (CSV)" "/dev/full" "$BIN" "${SIM[@]}" -o /dev/full
mkdir "$MNT"
if mount -t tmpfs -o size=64k tmpfs "$MNT" 2> /dev/null; then
  "$BIN" "${SIM[@]}" -o "$MNT/out.csv"
  "$BIN" "${SIM[@]}" -o "$MNT/out.mat"
  cp "$MNT/out.csv" "$T/full_old.csv"
  cp "$MNT/out.mat" "$T/full_old.mat"
  expect_fail "full tmpfs (CSV)" "$MNT/out.csv" "$BIN" simulate -m "$T/gpi.json" -i "$T/big.csv" -o "$MNT/out.csv"
  expect_fail "full tmpfs (.mat)" "$MNT/out.mat" "$BIN" simulate -m "$T/gpi.json" -i "$T/big.csv" -o "$MNT/out.mat"
  cmp -s "$MNT/out.csv" "$T/full_old.csv" || fail "full disk: the old CSV was changed"
  cmp -s "$MNT/out.mat" "$T/full_old.mat" || fail "full disk: the old .mat was changed"
  no_temp_files "$MNT"
  echo "full tmpfs: ok"
else
  echo "cannot mount a 64 KiB tmpfs (not root or no permission): full-disk case on the atomic path skipped"
fi

# ---- corrupt and hostile .mat input ---------------------------------------------------------
"$BIN" "${SIM[@]}" -o "$T/good.mat"
"$BIN" simulate -m "$T/gpi.json" -i "$T/good.mat" -c input -o "$T/ok.csv"
size=$(stat -c %s "$T/good.mat")
head -c $((size - 1)) "$T/good.mat" > "$T/cut1.mat"
head -c $((size / 2)) "$T/good.mat" > "$T/half.mat"
expect_fail "a .mat cut by one byte" "truncated" "$BIN" simulate -m "$T/gpi.json" -i "$T/cut1.mat" -c input -o "$T/o.csv"
expect_fail "a .mat cut in half" "truncated" "$BIN" simulate -m "$T/gpi.json" -i "$T/half.mat" -c output -o "$T/o.csv"
[ ! -e "$T/o.csv" ] || fail "an output was written from a truncated .mat"
echo "corrupt .mat: ok"
echo "output_files: ok"
