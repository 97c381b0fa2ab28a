#!/bin/sh
# Error/time fronts of radsplat and rpict on one scene (fronts.py, see README.md here), in
# the virtual environment run.sh makes.
exec env PEERS_SCRIPT=fronts.py "$(dirname "$0")/run.sh" "$@"
