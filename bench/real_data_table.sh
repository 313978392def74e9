#!/usr/bin/env bash
# The README's real-data tables: every model kind, auto and the reference PI on the
# measured records of ../shared/data, as published and transformed (see real_data_table.py).
# Usage: bench/real_data_table.sh [HYSTERON_CLI]   (default: build/hysteron)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exec /usr/bin/python3 "$root/bench/real_data_table.py" "${1:-$root/build/hysteron}" "${@:2}"
