#!/bin/sh
# Instructions executed by one `radsplat render` under callgrind, lavapipe's JIT-compiled
# shaders included: a measure of a build's cost that repeats to 0.004 %, where this
# machine's wall times swing by 15-20 % from run to run (docs/results.md, "Instructions
# counted instead of timed").
#
#     benches/paired/instructions.sh BINARY SCENE [render flags...]
#
# Prints the total, then the ten costliest functions (lavapipe's shaders show as `???`
# addresses; the hemisphere-plane shader is the largest). The first run under valgrind
# compiles every shader afresh, because valgrind's CPU lacks AVX-512 and Mesa keys its
# shader cache on the CPU's features; so this renders twice and reports the second run.
# After a change of shaders, call it twice: pipelines that the first render's threads were
# still building when it ended are never cached, and the second render compiles them (its
# count then includes LLVM; docs/results.md, stop 75).
# It counts instructions, not time: memset's `rep stosb` counts once per iteration, so
# lavapipe's zeroing of workgroup memory weighs far more here than on the clock. Needs
# valgrind (`apt-get install -y valgrind`) and RADSPLAT_ASSET_PATH for scenes outside the
# repository. One render of nave-west takes about 45 s.
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 BINARY SCENE [render flags...]" >&2
    exit 2
fi
binary=$1
scene=$2
shift 2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for run in 1 2; do
    valgrind --tool=callgrind --smc-check=all --callgrind-out-file="$dir/out.$run" \
        "$binary" render "$scene" -o "$dir/image.exr" --quiet "$@" 2> "$dir/log.$run"
done
grep -o 'Collected : [0-9]*' "$dir/log.2" | sed 's/Collected : /instructions: /'
callgrind_annotate "$dir/out.2" 2>/dev/null | grep -E '^ *[0-9,]+ \(' | sed -n '2,11p'
