#!/bin/bash
# Device run (NVIDIA H200 machine, the device tool; see README.md here): radsplat on a real
# GPU. Sponza sun 1000x1000 with the peers harness's settings (radsplat on the GPU, three runs
# each; rpict on the machine's CPU, every point at once), two 1024-spp references (seeds 1
# and 2) and every radsplat image against reference A; determinism on the NVIDIA driver; the
# GPU test binaries. Writes results.txt, json.tgz (stats, compare JSON), tests.txt and
# testlogs.tgz under $OUT. Needs what prepare.sh builds (.dev, .gl carried).
set -u
REPO=$PWD
R=$OUT/results.txt
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s] $*"; }
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
(cd .dev && tar xJf bundle.tar.xz && unxz -k sp/scene.oct.xz)
mkdir -p /work/shared /work && ln -sfn "$REPO/.dev/scenes" /work/shared/scenes
[ -e /work/main ] || ln -sfn "$REPO" /work/main     # the test binaries' CARGO_MANIFEST_DIR
mkdir -p target/release && cp .dev/radsplat target/release/radsplat   # CARGO_BIN_EXE_radsplat
export RADSPLAT_ASSET_PATH=/work/shared/scenes RAYPATH=.:$REPO/.dev/rlib
nvidia-smi -L; nproc
B=$REPO/.dev/radsplat
W=/tmp/w; mkdir -p $W
TIMEFORMAT='%R %U %S'
tm() { # label cmd...: appends "label wall user sys" to $R
  local label=$1; shift
  local t; t=$( { time "$@" >$W/$label.out 2>$W/$label.err ; } 2>&1 ) || { echo "FAIL $label"; tail -5 $W/$label.err; }
  echo "$label $t" | tee -a $R
}
el "smoke: Cornell box twice, bytes compared"
tm smoke1 $B render scenes/cornell-box.toml --size 128x128 -o $W/c1.exr
tm smoke2 $B render scenes/cornell-box.toml --size 128x128 -o $W/c2.exr
cmp $W/c1.exr $W/c2.exr && echo "DETERMINISM cornell: identical bytes" | tee -a $R
# rpict on the CPU, every point at once (each single-threaded; 16 cores)
RP=(.dev/bin/rpict -vtv -vp -12 2 0 -vd 12 1 0 -vu 0 1 0 -vv 60 -vh 60 -x 1000 -y 1000 -pa 0 -pj 0 -ps 1 -pt 0 -dt 0 -dc 1 -dj 0.0 -ds 0.05 -dr 0 -lr 1)
rp() { local label=$1; shift; local t; t=$( { time "${RP[@]}" "$@" .dev/sp/scene.oct > $W/rp-$label.hdr 2>$W/rp-$label.err ; } 2>&1 ); echo "rpict-$label $t" >> $R; }
rp ab0 -ab 0 & p1=$!
rp defaults -ab 1 -af $W/d.amb & p2=$!
rp aa0.4-ad128 -ab 1 -aa 0.4 -ad 128 -as 64 -ar 16 -af $W/a.amb & p3=$!
rp aa0.3-ad256 -ab 1 -aa 0.3 -ad 256 -as 128 -ar 32 -af $W/b.amb & p4=$!
rp aa0.15-ad768 -ab 1 -aa 0.15 -ad 768 -as 384 -ar 96 -af $W/c.amb & p5=$!
rp aa0.1-ad1024 -ab 1 -aa 0.1 -ad 1024 -as 512 -ar 128 -af $W/e.amb & p6=$!
el "radsplat points"
SC=.dev/sp/notex.toml
sed -i "s#/work/shared/scenes#$RADSPLAT_ASSET_PATH#" $SC
$B render $SC -o $W/warm.exr --size 64x64 --quiet
pts=("defaults|" "split-sphere-a0.2|--record-radius split-sphere -a 0.2" "a1.0-P8|-a 1.0 --plane-resolution 8" "a1.0-P12|-a 1.0 --plane-resolution 12" "a1.0-P16|-a 1.0 --plane-resolution 16" "a0.7-P12|-a 0.7 --plane-resolution 12" "a0.5-P16|-a 0.5 --plane-resolution 16" "a0.3-P16|-a 0.3 --plane-resolution 16" "a0.3-P24|-a 0.3 --plane-resolution 24" "a0.15-P24|-a 0.15 --plane-resolution 24" "a0.1-P32|-a 0.1 --plane-resolution 32")
for p in "${pts[@]}"; do
  l=${p%%|*}; f=${p#*|}
  for i in 1 2 3; do tm rs-$l $B render $SC -o $W/rs-$l.exr --stats $W/stats-$l.json --quiet $f; done
done
$B render $SC -o $W/rs-defaults-again.exr --quiet && cmp $W/rs-defaults.exr $W/rs-defaults-again.exr && echo "DETERMINISM sponza defaults: identical bytes" | tee -a $R
el "references"
tm refA $B reference $SC --spp 1024 --seed 1 -o $W/refA.exr --quiet
tm refB $B reference $SC --spp 1024 --seed 2 -o $W/refB.exr --quiet
$B compare $W/refA.exr $W/refB.exr --downsample 4 --json $W/cmp-refAB.json > /dev/null
for p in "${pts[@]}"; do l=${p%%|*}; $B compare $W/rs-$l.exr $W/refA.exr --downsample 4 --json $W/cmp-rs-$l.json > /dev/null; done
(cd $W && tar czf $OUT/json.tgz *.json)
split -b 15M $W/refA.exr $OUT/refA.exr.part-   # rpict's errors are computed here (fronts_h200.py)
el "tests"
mkdir -p $W/t
# (a subshell's `wait` waits for its own children only: the tests, not rpict)
(cd /work/main && for t in .dev/tests/*; do n=$(basename $t); ( timeout 170 $t --test-threads 4 > $W/t/$n.log 2>&1; echo "exit $?" >> $W/t/$n.log ) & done; wait)
for f in $W/t/*.log; do echo "== $f"; grep -E "^test .*(FAILED|ignored)|test result|panicked|exit " $f | head -30; done > $OUT/tests.txt 2>&1
(cd $W/t && tar czf $OUT/testlogs.tgz *.log)
el "waiting for rpict"
wait $p1 $p2 $p3 $p4 $p5 $p6
el "done"
cat $R
