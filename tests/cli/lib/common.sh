# The CLI test scripts' common start, sourced after their `set` line: BIN (the hysteron binary,
# the script's first argument), T (a temporary directory removed on exit), PY (apt's python3)
# and fail MESSAGE, which prints it and counts it in `fails` (the script exits with $fails).
BIN=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
PY=/usr/bin/python3
