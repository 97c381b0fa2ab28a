#!/bin/bash
# Device run (NVIDIA H200 machine): this radsplat against `radsplat-before`, interleaved,
# RUNS runs each (default 5), on Sponza sun 1000x1000 (a 1.0 P 12, a 1.0 P 8, defaults)
# and the conference room 160x120 (defaults, a 0.5 P 16), with --stats (command_ms).
# Writes results.txt and ab.tgz (stats) under $OUT. Needs what prepare_host_costs.sh builds.
set -u
REPO=$PWD; R=$OUT/results.txt; T0=$(date +%s); RUNS=${RUNS:-5}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
(cd .dev && tar xJf bundle.tar.xz)
mkdir -p /work/shared && ln -sfn "$REPO/.dev/scenes" /work/shared/scenes
export RADSPLAT_ASSET_PATH=/work/shared/scenes
B=$REPO/.dev/radsplat; OLD=$REPO/.dev/radsplat-before; W=/tmp/w; mkdir -p $W
TIMEFORMAT='%R %U %S'
tm() { local label=$1; shift; local t; t=$( { time "$@" >$W/$label.out 2>$W/$label.err ; } 2>&1 ) || { echo "FAIL $label"; tail -5 $W/$label.err; }; echo "$label $t" | tee -a $R; }
for s in .dev/sp/notex.toml .dev/conf/notex.toml; do sed -i "s#/work/shared/scenes#$RADSPLAT_ASSET_PATH#" $s; done
$B render .dev/sp/notex.toml -o $W/warm.exr --size 64x64 --quiet; $OLD render .dev/sp/notex.toml -o $W/warm.exr --size 64x64 --quiet
$B render .dev/conf/notex.toml -o $W/warm.exr --size 64x48 --quiet; $OLD render .dev/conf/notex.toml -o $W/warm.exr --size 64x48 --quiet
pts=("sp|a1.0-P12|-a 1.0 --plane-resolution 12" "sp|a1.0-P8|-a 1.0 --plane-resolution 8" "sp|defaults|" "conf|defaults|--size 160x120" "conf|a0.5-P16|--size 160x120 -a 0.5 --plane-resolution 16")
for i in $(seq $RUNS); do for p in "${pts[@]}"; do
  sc=${p%%|*}; rest=${p#*|}; l=${rest%%|*}; f=${rest#*|}
  tm before-$sc-$l $OLD render .dev/$sc/notex.toml -o $W/b-$sc-$l.exr --stats $W/stats-before-$sc-$l-$i.json --quiet $f
  tm after-$sc-$l $B render .dev/$sc/notex.toml -o $W/a-$sc-$l.exr --stats $W/stats-after-$sc-$l-$i.json --quiet $f
done; done
for p in "${pts[@]}"; do sc=${p%%|*}; rest=${p#*|}; l=${rest%%|*}
  $B compare $W/a-$sc-$l.exr $W/b-$sc-$l.exr --json $W/cmp-$sc-$l.json > /dev/null && echo "same pixels $sc $l: $(grep -o '"relative_rmse": [0-9.e-]*' $W/cmp-$sc-$l.json | head -1)" | tee -a $R
done
(cd $W && tar czf $OUT/ab.tgz *.json)
echo "done in $(( $(date +%s) - T0 )) s" | tee -a $R
