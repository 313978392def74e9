#!/usr/bin/env bash
# Usage errors (issue 13 item 7): exit code 1 as documented, the unknown name
# reported (not a later "--model is required"), a close match suggested, and
# strict integers (--seed -1 used to become 2^64 - 1).
# Usage: bash usage.sh <hysteron-binary> <source-dir>
set -uo pipefail
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0

# expect <description> <exit code> <substring of stderr> -- command...
expect() {
  local what=$1 code=$2 needle=$3
  shift 4
  "$@" > "$T/stdout" 2> "$T/stderr"
  local rc=$?
  if [ $rc -ne "$code" ]; then
    echo "FAIL: $what: exit $rc, expected $code"; cat "$T/stderr"; fails=$((fails + 1)); return
  fi
  if ! grep -qF -- "$needle" "$T/stderr"; then
    echo "FAIL: $what: stderr lacks '$needle':"; cat "$T/stderr"; fails=$((fails + 1)); return
  fi
  echo "ok: $what"
}

expect "unknown option before missing required" 1 "unknown option --foo" -- "$BIN" simulate --foo
expect "mistyped option suggested" 1 "did you mean --model?" -- "$BIN" simulate --modle m.json --input x.csv
expect "mistyped option with =value" 1 "did you mean --output?" -- "$BIN" fit --outptu=x.csv
expect "mistyped command suggested" 1 'unknown command "fitt" (did you mean fit?)' -- "$BIN" fitt
expect "unrelated command lists the commands" 1 "commands: simulate, invert, fit" -- "$BIN" frobnicate
# a mistyped value of a fixed set: the closest name, as for a command or an option (sweep's experiment had it)
expect "mistyped experiment suggested" 1 "gpi-pd not in {gpi-pid,mpi-openloop,mpi-pwm} (did you mean gpi-pid?)" -- \
  "$BIN" experiment gpi-pd
expect "mistyped sweep experiment suggested" 1 "unknown experiment 'gpi-pd' (did you mean gpi-pid?)" -- \
  "$BIN" sweep gpi-pd --vary load.mass=35
expect "mistyped fit kind suggested" 1 "--model: gpii not in {auto,pi,gpi," -- "$BIN" fit --model gpii -d x.csv -i 0 -y 1 -o m.json
expect "mistyped fit kind: the closest" 1 "(did you mean gpi?)" -- "$BIN" fit --model gpii -d x.csv -i 0 -y 1 -o m.json
expect "mistyped experiment kind suggested" 1 "(did you mean mpi-asym?)" -- "$BIN" experiment gpi-pid --model mpi-asim
expect "mistyped sweep kind suggested" 1 "(did you mean maxwell-slip?)" -- "$BIN" sweep gpi-pid --model maxwel-slip
expect "unrelated kind: no suggestion, the set" 1 "--model: spline not in {auto," -- "$BIN" fit --model spline
if grep -qF "did you mean" "$T/stderr"; then echo "FAIL: spline: a suggestion: $(cat "$T/stderr")"; fails=$((fails + 1)); fi
# --jobs: its range in words, not CLI11's validator names (UINT:INT>=0:UINT in [1 - 1024])
"$BIN" sweep --help > "$T/sweep_help" 2>&1
if grep -qF -- "-j,--jobs UINT " "$T/sweep_help" && grep -qF "an integer in 1..1024" "$T/sweep_help" &&
  ! grep -qE "INT>=0|\[1 - 1024\]" "$T/sweep_help"; then
  echo "ok: --jobs help"
else
  echo "FAIL: --jobs help: $(grep -F -- --jobs "$T/sweep_help")"; fails=$((fails + 1))
fi
expect "fit --n 10.5: the range" 1 "--n: 10.5 is not an integer in 1..200" -- "$BIN" fit --n 10.5
expect "fit --starts 0: the range" 1 "--starts: 0 is not an integer in 1..54" -- "$BIN" fit --starts 0
expect "fit --dead-zones 51: the range" 1 "--dead-zones: 51 is not an integer in 0..50" -- "$BIN" fit --dead-zones 51
expect "jobs 0: the range" 1 "--jobs: 0 is not an integer in 1..1024" -- "$BIN" sweep gpi-pid --vary load.mass=35 --jobs 0
expect "jobs 1025: the range" 1 "--jobs: 1025 is not an integer in 1..1024" -- \
  "$BIN" sweep gpi-pid --vary load.mass=35 --jobs 1025
expect "negative seed refused" 1 "--seed: -1 is not an integer" -- "$BIN" experiment gpi-pid --seed -1
expect "fractional seed refused" 1 "--seed: 1.5 is not an integer" -- "$BIN" fit --seed=1.5
# the bound said is the option's own: fit's seed is 32-bit, the rig's noise seed 64-bit
expect "fit seed beyond 32 bits: its bound" 1 "--seed: 4294967296 is not an integer in 0..4294967295" -- \
  "$BIN" fit --seed 4294967296
expect "experiment seed beyond 64 bits: its bound" 1 \
  "--seed: 18446744073709551616 is not an integer in 0..18446744073709551615" -- \
  "$BIN" experiment gpi-pid --seed 18446744073709551616
expect "missing value is a usage error (1, not CLI11's 10x)" 1 "--model" -- "$BIN" simulate --model
expect "no command" 1 "" -- "$BIN"
# Negative numbers and "-" are values, not options.
printf 'x\n0\n0.1\n0.2\n' > "$T/x.csv"
cat > "$T/pi.json" <<'JSON'
{"model": "pi", "r": [0, 0.1], "p": [1, 0.5]}
JSON
if "$BIN" invert --model "$T/pi.json" --input "$T/x.csv" --limits=-1,1 --output - > "$T/y.csv" 2> "$T/err" &&
   "$BIN" simulate --model - --input "$T/x.csv" --output - < "$T/pi.json" > "$T/y.csv" 2> "$T/err"; then
  echo "ok: negative number as a value"
else
  echo "FAIL: negative number as a value:"; cat "$T/err"; fails=$((fails + 1))
fi
"$BIN" fit --help > /dev/null 2>&1 || { echo "FAIL: --help exits non-zero"; fails=$((fails + 1)); }
# --version: the project's version from CMakeLists.txt on stdout, exit 0 (it used to be a usage error)
want="hysteron $(sed -n 's/^project(hysteron VERSION \([0-9.]*\).*/\1/p' "$2/CMakeLists.txt")"
got=$("$BIN" --version 2> "$T/err"); rc=$?
if [ $rc -eq 0 ] && [ "$got" = "$want" ]; then echo "ok: --version"
else echo "FAIL: --version: exit $rc, printed '$got', expected '$want'"; cat "$T/err"; fails=$((fails + 1)); fi
[ $fails -eq 0 ] || { echo "$fails failure(s)"; exit 1; }
echo "all usage checks passed"
