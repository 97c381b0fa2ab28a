#!/bin/bash
# Device run (see README.md here): the nave (scenes/nave.toml) and its west view
# (benches/variants/nave-west.toml), 160x160, with the peers harness's settings (fronts.py):
# radsplat on the GPU, three runs a point; rpict on the machine's CPU, every point at once
# (one core each); two references (seeds 1 and 2, SPP samples per pixel, default 4096) on
# the GPU; every image compared there against reference A (rpict's as -ab 1 minus -ab 0).
# Writes, per scene S, results-S.txt (`label wall user sys`) and json-S.tgz (radsplat's
# stats, every compare JSON, and rpict's times as times.txt) under $OUT, for
# `fronts_h200.py` (README.md here). Needs what prepare_nave.sh builds (.dev, .gl carried).
# Without nvidia-smi (a dry run here) it runs on whatever adapter wgpu finds.
set -u
REPO=$PWD
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s] $*"; }
if command -v nvidia-smi > /dev/null; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
    nvidia-smi -L
fi
nproc
B=$REPO/.dev/radsplat
export RAYPATH=.:$REPO/.dev/rlib
SPP=${SPP:-4096}
TIMEFORMAT='%R %U %S'
for S in ${SCENES:-nave nave-west}; do
    D=$REPO/.dev/$S
    W=/tmp/w-nave/$S; rm -rf "$W"; mkdir -p "$W"
    R=$OUT/results-$S.txt; : > "$R"
    SC=$W/notex.toml
    sed "s#$(cat "$REPO/.dev/repo_path")#$REPO#g" "$D/notex.toml" > "$SC"
    read -r -a VIEW < <(sed 's/^rview //' "$D/view.vf")
    XY=$(sed -n 's/^resolution = \[\([0-9]*\), *\([0-9]*\)\]/\1 \2/p' "$SC" | head -1)
    [ -n "$XY" ] || XY="160 160"
    read -r X Y <<< "$XY"
    RP=("$REPO/.dev/bin/rpict" "${VIEW[@]}" -x "$X" -y "$Y" -pa 0 -pj 0 -ps 1 -pt 0 -dt 0 -dc 1
        -dj 0 -ds 0.05 -dr 0 -lr 1)
    rp() { # label flags...: one rpict point, its time to $W/times.txt and $R
        local label=$1; shift
        local t; t=$( { time "${RP[@]}" "$@" "$D/scene.oct" > "$W/rp-$label.hdr" 2> "$W/rp-$label.err" ; } 2>&1 )
        echo "rpict-$label $t" | tee -a "$W/times.txt" >> "$R"
    }
    tm() { # label cmd...: appends "label wall user sys" to $R
        local label=$1; shift
        local t; t=$( { time "$@" > "$W/$label.out" 2> "$W/$label.err" ; } 2>&1 ) || { echo "FAIL $label"; tail -5 "$W/$label.err"; }
        echo "$label $t" | tee -a "$R"
    }
    el "$S: rpict on the CPU, every point at once"
    rp ab0 -ab 0 & pids=$!
    rp defaults -ab 1 -af "$W/d.amb" & pids="$pids $!"
    rp aa0.4-ad128 -ab 1 -aa 0.4 -ad 128 -as 64 -ar 16 -af "$W/a.amb" & pids="$pids $!"
    rp aa0.3-ad256 -ab 1 -aa 0.3 -ad 256 -as 128 -ar 32 -af "$W/b.amb" & pids="$pids $!"
    rp aa0.15-ad768 -ab 1 -aa 0.15 -ad 768 -as 384 -ar 96 -af "$W/c.amb" & pids="$pids $!"
    rp aa0.1-ad1024 -ab 1 -aa 0.1 -ad 1024 -as 512 -ar 128 -af "$W/e.amb" & pids="$pids $!"
    wait $pids   # the GPU runs below then have the CPU to themselves
    el "$S: radsplat points"
    "$B" render "$SC" -o "$W/warm.exr" --size 64x64 --quiet
    pts=("defaults|" "a0.5-P16|-a 0.5 --plane-resolution 16" "a0.3-P16|-a 0.3 --plane-resolution 16"
         "a0.2-P24|-a 0.2 --plane-resolution 24" "a0.15-P24|-a 0.15 --plane-resolution 24"
         "a0.15-P32|-a 0.15 --plane-resolution 32" "a0.1-P32|-a 0.1 --plane-resolution 32")
    for p in "${pts[@]}"; do
        l=${p%%|*}; f=${p#*|}
        # shellcheck disable=SC2086
        for i in 1 2 3; do tm "rs-$l" "$B" render "$SC" -o "$W/rs-$l.exr" --stats "$W/stats-$l.json" --quiet $f; done
    done
    "$B" render "$SC" -o "$W/rs-defaults-again.exr" --quiet && cmp "$W/rs-defaults.exr" "$W/rs-defaults-again.exr" \
        && echo "DETERMINISM $S defaults: identical bytes" | tee -a "$R"
    el "$S: references ($SPP spp)"
    tm refA "$B" reference "$SC" --spp "$SPP" --seed 1 -o "$W/refA.exr" --quiet
    tm refB "$B" reference "$SC" --spp "$SPP" --seed 2 -o "$W/refB.exr" --quiet
    "$B" compare "$W/refB.exr" "$W/refA.exr" --downsample 4 --json "$W/cmp-refAB.json" > /dev/null
    for p in "${pts[@]}"; do
        l=${p%%|*}
        "$B" compare "$W/rs-$l.exr" "$W/refA.exr" --downsample 4 --json "$W/cmp-rs-$l.json" > /dev/null
    done
    for l in defaults aa0.4-ad128 aa0.3-ad256 aa0.15-ad768 aa0.1-ad1024; do
        "$B" compare "$W/rp-$l.hdr" "$W/refA.exr" --minus "$W/rp-ab0.hdr" --downsample 4 \
            --json "$W/cmp-$l.json" > /dev/null
    done
    (cd "$W" && tar czf "$OUT/json-$S.tgz" ./*.json times.txt)
done
el "done"
cat "$OUT"/results-*.txt
