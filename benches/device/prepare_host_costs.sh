#!/bin/bash
# Builds what host_costs_h200.sh needs under .dev/ (ignored by git, see prepare.sh) and the
# Vulkan loader packages under .gl/: this checkout's radsplat and, as `radsplat-before`, the
# binary given in BEFORE (a release build of the commit before the host changes), both
# stripped; Sponza, the conference room and the Cornell box from RADSPLAT_ASSET_PATH; the
# harness's textureless scene files for Sponza (1000x1000) and the conference room.
# Then call the device tool: command `bash benches/device/host_costs_h200.sh`, carry .gl, .dev.
set -eu
repo=$(cd "$(dirname "$0")/../.." && pwd); cd "$repo"
: "${RADSPLAT_ASSET_PATH:?set RADSPLAT_ASSET_PATH (../shared/scenes)}"
: "${BEFORE:?set BEFORE to the radsplat binary to compare with}"
cargo build --release
rm -rf .dev && mkdir -p .dev/pack/scenes
strip -o .dev/pack/radsplat target/release/radsplat
strip -o .dev/pack/radsplat-before "$BEFORE"
cp -r "$RADSPLAT_ASSET_PATH/dabrovic-sponza" "$RADSPLAT_ASSET_PATH/conference" \
      "$RADSPLAT_ASSET_PATH/cornell-box" .dev/pack/scenes/
target/release/radsplat export-rad scenes/sponza-sun.toml .dev/sp --size 1000x1000
target/release/radsplat export-rad scenes/conference.toml .dev/conf --size 160x120
rm -f .dev/sp/scene.rad .dev/conf/scene.rad
(cd .dev/pack && tar cf - radsplat radsplat-before scenes | xz -6 -T2 > ../bundle.tar.xz) && rm -rf .dev/pack
if [ ! -d .gl ]; then
  mkdir -p .gl /tmp/amd64/partial
  o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
  apt-get $o update > /dev/null
  (cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
du -sh .dev .gl
