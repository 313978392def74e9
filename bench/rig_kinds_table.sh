#!/usr/bin/env bash
# The comparison of every model kind on the simulated rig (docs/models.md, "Comparison on the
# simulated rig"): major loop -> minor loops and across rates (see rig_kinds_table.py).
# Usage: bench/rig_kinds_table.sh [PYTHON_MODULE_DIR]   (default: build/python)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exec /usr/bin/python3 "$root/bench/rig_kinds_table.py" "${1:-$root/build/python}"
