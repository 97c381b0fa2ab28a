#!/bin/sh
# Creates benches/peers/.venv with pyradiance (Radiance binaries in a PyPI wheel),
# matplotlib (fronts.py's plot) and OpenEXR (error_split.py) on first use, then runs
# compare_peers.py with the given arguments (or, as fronts.sh, fronts.py; as
# error_split.sh, error_split.py). See README.md here.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import pyradiance, matplotlib, OpenEXR" 2>/dev/null; then
    "$venv/bin/pip" install --quiet pyradiance matplotlib OpenEXR
fi
exec "$venv/bin/python" "$here/${PEERS_SCRIPT:-compare_peers.py}" "$@"
