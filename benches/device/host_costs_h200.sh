#!/bin/bash
# Device run (NVIDIA H200 machine, the device tool; see README.md here): what the host
# changes of stop 41 bring on a real GPU, and the conference room's radsplat side.
#  1. Sponza sun 1000x1000, the peers harness's radsplat points (three runs each, --stats:
#     command_ms, gpu_waits), against a 1024-spp reference rendered here (seed 1);
#     the binary before the host changes (`radsplat-before`) on three points, interleaved.
#  2. Conference room 160x120, the harness's radsplat points (three runs each) and two
#     references (seeds 1 and 2) sized to about a minute each from a 4096-spp timing run.
#     (CONF_REFS=0: no references, when an earlier run brought them back).
#  3. Glossy Spheres 96x72 frames 0..11, temporal and per frame (issue 18).
#  4. Determinism: Sponza defaults and the Cornell box rendered twice, bytes compared.
# rpict is not run here: its Sponza times are those of the first device run
# (docs/data/peers/sponza-sun-1000x1000-h200-run2-results.txt), its conference images and
# times are this machine's (rpict is single-threaded and its images do not depend on it).
# Writes results.txt, sponza.tgz (stats and compare JSON), conference.tgz (EXRs, stats)
# under $OUT. Needs what prepare_host_costs.sh builds (.dev, .gl carried).
set -u
REPO=$PWD
R=$OUT/results.txt
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s] $*" | tee -a $R; }
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
(cd .dev && tar xJf bundle.tar.xz)
mkdir -p /work/shared && ln -sfn "$REPO/.dev/scenes" /work/shared/scenes
export RADSPLAT_ASSET_PATH=/work/shared/scenes
nvidia-smi -L; nproc
B=$REPO/.dev/radsplat
OLD=$REPO/.dev/radsplat-before
W=/tmp/w; mkdir -p $W/sp $W/conf
TIMEFORMAT='%R %U %S'
tm() { # label cmd...: appends "label wall user sys" to $R
  local label=$1; shift
  local t; t=$( { time "$@" >$W/$label.out 2>$W/$label.err ; } 2>&1 ) || { echo "FAIL $label"; tail -5 $W/$label.err; }
  echo "$label $t" | tee -a $R
}
for s in .dev/sp/notex.toml .dev/conf/notex.toml; do sed -i "s#/work/shared/scenes#$RADSPLAT_ASSET_PATH#" $s; done
el "warm-up (pipeline caches of both binaries)"
$B render .dev/sp/notex.toml -o $W/warm.exr --size 64x64 --quiet
$OLD render .dev/sp/notex.toml -o $W/warm.exr --size 64x64 --quiet

el "Sponza: before/after on three points, interleaved"
SC=.dev/sp/notex.toml
ab=("a1.0-P8|-a 1.0 --plane-resolution 8" "a1.0-P12|-a 1.0 --plane-resolution 12" "defaults|")
for i in 1 2 3; do for p in "${ab[@]}"; do l=${p%%|*}; f=${p#*|}
  tm before-$l $OLD render $SC -o $W/sp/before-$l.exr --stats $W/sp/stats-before-$l-$i.json --quiet $f
  tm rs-$l $B render $SC -o $W/sp/rs-$l.exr --stats $W/sp/stats-$l-$i.json --quiet $f
done; done
el "Sponza: the other points"
pts=("split-sphere-a0.2|--record-radius split-sphere -a 0.2" "a1.0-P16|-a 1.0 --plane-resolution 16" "a0.7-P12|-a 0.7 --plane-resolution 12" "a0.5-P16|-a 0.5 --plane-resolution 16" "a0.3-P16|-a 0.3 --plane-resolution 16" "a0.3-P24|-a 0.3 --plane-resolution 24" "a0.15-P24|-a 0.15 --plane-resolution 24" "a0.1-P32|-a 0.1 --plane-resolution 32")
for i in 1 2 3; do for p in "${pts[@]}"; do l=${p%%|*}; f=${p#*|}
  tm rs-$l $B render $SC -o $W/sp/rs-$l.exr --stats $W/sp/stats-$l-$i.json --quiet $f
done; done
$B render $SC -o $W/sp/again.exr --quiet && cmp $W/sp/rs-defaults.exr $W/sp/again.exr && echo "DETERMINISM sponza defaults: identical bytes" | tee -a $R
el "Sponza reference (1024 spp, seed 1) and errors"
tm refA $B reference $SC --spp 1024 --seed 1 -o $W/sp/refA.exr --quiet
echo "refA sha256 $(sha256sum < $W/sp/refA.exr | cut -c1-64)" | tee -a $R   # same as the first run's?
for p in "${ab[@]}" "${pts[@]}"; do l=${p%%|*}
  $B compare $W/sp/rs-$l.exr $W/sp/refA.exr --downsample 4 --json $W/sp/cmp-rs-$l.json > /dev/null
  [ -e $W/sp/before-$l.exr ] && $B compare $W/sp/before-$l.exr $W/sp/refA.exr --downsample 4 --json $W/sp/cmp-before-$l.json > /dev/null
done
(cd $W/sp && tar czf $OUT/sponza.tgz *.json)

el "Conference room 160x120: radsplat points"
CS=.dev/conf/notex.toml
cpts=("defaults|" "split-sphere-a0.2|--record-radius split-sphere -a 0.2" "a0.5-P16|-a 0.5 --plane-resolution 16" "a0.3-P24|-a 0.3 --plane-resolution 24" "a0.15-P24|-a 0.15 --plane-resolution 24" "a0.15-P32|-a 0.15 --plane-resolution 32" "a0.1-P32|-a 0.1 --plane-resolution 32")
for i in 1 2 3; do for p in "${cpts[@]}"; do l=${p%%|*}; f=${p#*|}
  tm conf-$l $B render $CS --size 160x120 -o $W/conf/rs-$l.exr --stats $W/conf/stats-$l-$i.json --quiet $f
done; done
if [ "${CONF_REFS:-1}" = 1 ]; then
el "Conference references (light samples 1, as the harness)"
tm conf-ref4096 $B reference $CS --size 160x120 --light-samples 1 --spp 4096 --seed 1 -o $W/conf/ref4096.exr --quiet
t=$(awk '$1 == "conf-ref4096" {print $2}' $R)
spp=$(python3 -c "import math; t=float('$t'); n=4096*60/max(t,0.1); print(max(4096, min(262144, 2**int(math.log2(n)))))")
el "reference spp: $spp"
tm conf-refA timeout 150 $B reference $CS --size 160x120 --light-samples 1 --spp $spp --seed 1 -o $W/conf/refA.exr --quiet
tm conf-refB timeout 150 $B reference $CS --size 160x120 --light-samples 1 --spp $spp --seed 2 -o $W/conf/refB.exr --quiet
echo "conference reference spp $spp" >> $R
fi
(cd $W/conf && tar czf $OUT/conference.tgz *.exr *.json)
el "Glossy Spheres 96x72, frames 0..11: temporal and per frame"
tm spheres-temporal timeout 60 $B animate scenes/spheres-glossy.toml --frames 0..11 --size 96x72 -o $W/sph-####.exr --stats $W/sph-temporal.json --quiet
tm spheres-off timeout 60 $B animate scenes/spheres-glossy.toml --frames 0..11 --size 96x72 --temporal off -o $W/sphoff-####.exr --stats $W/sph-off.json --quiet
cp $W/sph-temporal.json $W/sph-off.json $OUT/ 2>/dev/null
el "Cornell box twice"
$B render scenes/cornell-box.toml --size 128x128 -o $W/c1.exr --quiet
$B render scenes/cornell-box.toml --size 128x128 -o $W/c2.exr --quiet
cmp $W/c1.exr $W/c2.exr && echo "DETERMINISM cornell: identical bytes" | tee -a $R
el "done"
