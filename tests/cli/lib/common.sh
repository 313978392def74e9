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
