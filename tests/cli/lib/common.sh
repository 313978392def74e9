# The CLI test scripts' common start, sourced after their `set` line: BIN (the hysteron binary,
# the script's first argument), T (a temporary directory removed on exit), PY (apt's python3)
# and fail MESSAGE, which prints it and counts it in `fails` (the script exits with $fails);
# expect_error "what" "part of the message" command...: exit 1 with the message on stderr
# (stdout in $T/out.txt, stderr in $T/err.txt).
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
PY=/usr/bin/python3
expect_error() {
  local what=$1 part=$2
  shift 2
  "$@" > "$T/out.txt" 2> "$T/err.txt"
  local rc=$?
  [ $rc -eq 1 ] || fail "$what: exit $rc, expected 1 ($(cat "$T/err.txt"))"
  grep -qF -- "$part" "$T/err.txt" || fail "$what: stderr lacks '$part': $(cat "$T/err.txt")"
}

# gpi_record_pair: $T/gpi.json (a gpi) and two records of it, $T/a.csv and $T/b.csv (different
# amplitudes; columns t_s (10 ms), p, y), for the tests that fit one record and validate on another.
gpi_record_pair() {
  cat > "$T/gpi.json" <<'JSON'
{"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1, "alpha": 2}
JSON
  $PY - "$T" <<'PYEOF'
import sys
for name, amps in (("a", (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)), ("b", (0.55, 0.35, 0.45, 0.15))):
    with open(f"{sys.argv[1]}/{name}_x.csv", "w") as f:
        f.write("pressure\n")
        for a in amps:
            for k in range(300):
                f.write(f"{a * (1 - abs(2 * k / 300 - 1))!r}\n")
PYEOF
  local r
  for r in a b; do
    "$BIN" simulate --model "$T/gpi.json" --input "$T/${r}_x.csv" --output "$T/${r}_raw.csv" || fail "simulate $r"
    $PY - "$T/${r}_raw.csv" "$T/$r.csv" <<'PYEOF'
import sys
rows = [x for x in open(sys.argv[1]).read().split("\n")[1:] if x]
with open(sys.argv[2], "w") as f:
    f.write("t_s,p,y\n")
    for i, r in enumerate(rows):
        f.write(f"{i * 0.01!r},{r}\n")
PYEOF
  done
}
