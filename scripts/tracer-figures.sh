#!/usr/bin/env bash
# The Sponza glossy images of README's "A tracer that answers": 64 probes at the cell centres
# of the atrium region (docs/tracer/sponza_region_grid.json), baked at 256² with the default
# adaptive sampling; the path-traced reference at 32 spp; the light-field tracer (hi-Z, grid
# cage), the hybrid, the shaded hits and the split (from a second bake at the same positions,
# of the reflected light: `probes bake --radiance indirect`); tone-mapped MSE, FLIP and a
# side-by-side PNG.
# Set OLD_PROBES to a `probes` binary built from 43f542d to add the "before" column (it reads
# format-2 bakes: the script gives it a copy of the bake labelled version 2; the geometry
# file's extra distance-range channels are ignored by that reader).
# Output: ${1:-tracer-figures}/. About 15 minutes on 2 cores (the two bakes are most of it).
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
out="${1:-tracer-figures}"
mkdir -p "$out"
scene=../shared/scenes/sponza/Sponza_basecolor.gltf
cargo build --release -p probe-cli --bin probes -p probe-eval --example compare_images
target="${CARGO_TARGET_DIR:-target}"
probes="$target/release/probes"
$probes bake "$scene" --probes docs/tracer/sponza_region_grid.json --res 256 --out "$out/bake"
$probes bake "$scene" --probes docs/tracer/sponza_region_grid.json --res 256 --radiance indirect \
    --out "$out/reflected"
$probes reference "$scene" --camera CameraMain --spp 32 --component glossy1 \
    --out "$out/reference.exr" --png "$out/reference.png"
renders=()
if [ -n "${OLD_PROBES:-}" ]; then
    rm -rf "$out/bake_v2" && cp -r "$out/bake" "$out/bake_v2"
    sed -i 's/"format_version": 3/"format_version": 2/' "$out/bake_v2/manifest.json"
    "$OLD_PROBES" render "$out/bake_v2" --scene "$scene" --camera CameraMain --select grid \
        --tracer hiz --out "$out/before.exr" --png "$out/before.png"
    renders+=("before=$out/before.exr")
fi
for tracer in hiz hybrid shaded split; do
    bake="$out/bake"
    if [ "$tracer" = split ]; then bake="$out/reflected"; fi
    $probes render "$bake" --scene "$scene" --camera CameraMain --select grid \
        --tracer "$tracer" --out "$out/$tracer.exr" --png "$out/$tracer.png"
    renders+=("$tracer=$out/$tracer.exr")
done
"$target/release/examples/compare_images" "$out/reference.exr" "$out/compare.png" "${renders[@]}"
