#!/bin/bash
# Builds what a device run of sponza_h200.sh needs under .dev/ (ignored by git: add `/.dev/`
# and `/.gl/` to .git/info/exclude) and the Vulkan loader packages under .gl/, on this
# (x86-64) machine: radsplat stripped, the GPU test binaries, Sponza and the Cornell box from
# RADSPLAT_ASSET_PATH, Radiance's rpict/oconv from the peers' venv, Sponza's frozen octree.
# Then call the device tool: command `bash benches/device/sponza_h200.sh`, carry .gl and .dev.
set -eu
repo=$(cd "$(dirname "$0")/../.." && pwd); cd "$repo"
: "${RADSPLAT_ASSET_PATH:?set RADSPLAT_ASSET_PATH (../shared/scenes)}"
cargo build --release
cargo test --release --no-run 2>&1 | sed -n 's/.*Executable tests\/\([a-z_]*\)\.rs (\(.*\))/\1 \2/p' > /tmp/testbins.txt
rm -rf .dev && mkdir -p .dev/bin .dev/rlib .dev/tests .dev/pack
benches/peers/run.sh --help > /dev/null  # makes benches/peers/.venv with pyradiance
pr=$(benches/peers/.venv/bin/python -c "import pyradiance, os; print(os.path.dirname(pyradiance.__file__))")
cp "$pr/bin/rpict" "$pr/bin/oconv" .dev/bin/ && cp -r "$pr/lib/." .dev/rlib/
strip -o .dev/pack/radsplat target/release/radsplat
mkdir -p .dev/pack/tests
for t in gpu_records gpu_cache gpu_direct gpu_visibility light_maps radiance_projection \
         radiance_records temporal temporal_radiance reference glossy; do
    strip -o ".dev/pack/tests/$t" "$(awk -v t=$t '$1 == t {print $2}' /tmp/testbins.txt)"
done
mkdir -p .dev/pack/scenes
cp -r "$RADSPLAT_ASSET_PATH/dabrovic-sponza" "$RADSPLAT_ASSET_PATH/cornell-box" .dev/pack/scenes/
target/release/radsplat export-rad scenes/sponza-sun.toml .dev/sp --size 1000x1000
RAYPATH=.:.dev/rlib .dev/bin/oconv -f .dev/sp/scene.rad > /tmp/sponza-frozen.oct  # -f: self-contained
rm .dev/sp/scene.rad && xz -6 -T2 -c /tmp/sponza-frozen.oct > .dev/sp/scene.oct.xz
(cd .dev/pack && tar cf - radsplat tests scenes | xz -6 -T2 > ../bundle.tar.xz) && rm -rf .dev/pack
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
apt-get $o update > /dev/null
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
du -sh .dev .gl
