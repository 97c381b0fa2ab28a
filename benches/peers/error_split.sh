#!/bin/sh
# Splits images' indirect error into edge and interior blocks (error_split.py), in the
# virtual environment run.sh makes (with OpenEXR for the EXR layers).
exec env PEERS_SCRIPT=error_split.py "$(dirname "$0")/run.sh" "$@"
