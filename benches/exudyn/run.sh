#!/usr/bin/env bash
# lash against Exudyn on the MR2120 clearance model, side by side in one run.
#
#   bash benches/exudyn/run.sh [options of compare.py]        the comparison (see compare.py --help)
#   bash benches/exudyn/run.sh single MODEL.json [options]    one Exudyn run (see mr2120_exudyn.py --help)
#
# Creates benches/exudyn/.venv on first use and installs exudyn, numpy and matplotlib into it from
# PyPI. Needs python3 (3.11 for the exudyn 1.13 wheels) with the venv module, and cargo.
# Environment: PYTHON (default python3), EXUDYN_SPEC (default "exudyn>=1.13,<1.14").
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import exudyn, numpy, matplotlib" 2>/dev/null; then
    echo "setting up $venv (exudyn, numpy, matplotlib from PyPI)" >&2
    "${PYTHON:-python3}" -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet "${EXUDYN_SPEC:-exudyn>=1.13,<1.14}" numpy matplotlib
fi
if [ "${1:-}" = "single" ]; then
    shift
    exec "$venv/bin/python" -W ignore::DeprecationWarning "$here/mr2120_exudyn.py" "$@"
fi
exec "$venv/bin/python" -W ignore::DeprecationWarning "$here/compare.py" "$@"
