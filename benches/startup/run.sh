#!/usr/bin/env bash
# Cold against warm start of `radsplat render` (issue 16's goal: cold within 3x of warm at
# the default settings, within 8x at 16x16 planes). "Cold" runs with Mesa's shader cache
# disabled (MESA_SHADER_CACHE_DISABLE=true: every pipeline is compiled, as on a fresh
# machine) and an empty pipeline-cache directory; "warm" with both caches filled by a
# first run. Runs are interleaved (cold, warm, cold, ...) so that load on the machine
# hits both alike; prints each run and the medians of wall and CPU time (user + sys, all
# threads) and their cold/warm ratios.
#
#   benches/startup/run.sh [RUNS] [extra render flags...]
#   e.g. benches/startup/run.sh 5                       # default settings, 32x32
#        benches/startup/run.sh 5 --plane-resolution 16
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-5}
shift || true
bin=target/release/radsplat
[ -x "$bin" ] || cargo build --release --quiet
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
render() {
    /usr/bin/time -f "%e %U %S" -o "$work/time" "$bin" render scenes/cornell-box.toml \
        --size 32x32 -o "$work/out.exr" --stats "$work/stats.json" --time-passes --quiet "$@"
    read -r wall user sys < "$work/time"
    compile=$(python3 -c "import json;print(round(sum(m for _,m in json.load(open('$work/stats.json'))['frame']['shader_compile_ms'])))")
    echo "$wall $(python3 -c "print($user+$sys)") $compile"
}
export RADSPLAT_CACHE_DIR="$work/pipelines"
render "$@" > /dev/null # fills the warm caches
: > "$work/cold"; : > "$work/warm"
for i in $(seq "$runs"); do
    c=$(RADSPLAT_CACHE_DIR="$work/cold-$i" MESA_SHADER_CACHE_DISABLE=true render "$@")
    w=$(render "$@")
    echo "$c" >> "$work/cold"; echo "$w" >> "$work/warm"
    echo "run $i: cold wall ${c%% *} s (CPU, compile ms: ${c#* }), warm wall ${w%% *} s (${w#* })"
done
python3 - "$work/cold" "$work/warm" "$*" <<'PY'
import statistics, sys
cold = [list(map(float, l.split())) for l in open(sys.argv[1])]
warm = [list(map(float, l.split())) for l in open(sys.argv[2])]
med = lambda rows, i: statistics.median(r[i] for r in rows)
flags = sys.argv[3] or "(defaults)"
print(f"cornell-box 32x32 {flags}: medians of {len(cold)} runs")
for i, name in [(0, "wall s"), (1, "CPU s")]:
    c, w = med(cold, i), med(warm, i)
    print(f"  {name:7} cold {c:6.2f}  warm {w:6.2f}  cold/warm {c / w:4.1f}x")
print(f"  shader compilation ms: cold {med(cold, 2):.0f}, warm {med(warm, 2):.0f}")
PY
