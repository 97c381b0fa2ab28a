#!/bin/bash
# Builds what a device run of nave_h200.sh needs, on this (x86-64) machine: radsplat
# stripped, Radiance's rpict/oconv from the peers' venv, and for each scene (the nave and
# its west view, both ours: nothing from outside the repository) its Radiance export and
# frozen octree, under .dev/; the Vulkan loader packages under .gl/ (the device has the
# NVIDIA driver but no loader). Both folders must be ignored (`/.dev/` and `/.gl/` in
# .git/info/exclude) and travel with the call's carry. Then call the device tool with the
# command `bash benches/device/nave_h200.sh` and carry [".dev", ".gl"].
set -eu
repo=$(cd "$(dirname "$0")/../.." && pwd); cd "$repo"
grep -qx '/.dev/' .git/info/exclude 2>/dev/null || printf '/.dev/\n/.gl/\n' >> .git/info/exclude
cargo build --release
benches/peers/run.sh --help > /dev/null  # makes benches/peers/.venv with pyradiance
pr=$(benches/peers/.venv/bin/python -c "import pyradiance, os; print(os.path.dirname(pyradiance.__file__))")
rm -rf .dev && mkdir -p .dev/bin .dev/rlib
cp "$pr/bin/rpict" "$pr/bin/oconv" .dev/bin/ && cp -r "$pr/lib/." .dev/rlib/
strip -o .dev/radsplat target/release/radsplat
echo "$repo" > .dev/repo_path   # export-rad writes absolute mesh paths: rewritten there
for s in nave:scenes/nave.toml nave-west:benches/variants/nave-west.toml; do
    name=${s%%:*}; toml=${s#*:}
    target/release/radsplat export-rad "$toml" ".dev/$name"
    RAYPATH=.:.dev/rlib .dev/bin/oconv -f ".dev/$name/scene.rad" > ".dev/$name/scene.oct"
    rm ".dev/$name/scene.rad"
done
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
apt-get $o update > /dev/null
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
du -sh .dev .gl
