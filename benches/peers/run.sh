#!/bin/sh
# Creates benches/peers/.venv with pyradiance (Radiance binaries in a PyPI wheel) on first
# use, then runs compare_peers.py with the given arguments. See README.md here.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet pyradiance
fi
exec "$venv/bin/python" "$here/compare_peers.py" "$@"
