#!/usr/bin/env bash
# The real-GPU figures of BENCHMARKS.md "On a real GPU: NVIDIA H200": the `speed` example
# (issue 13: Sponza CameraMain 1920×1080 reflections, hi-Z and two-level, GPU timestamps), what
# that time depends on (probe resolution, probe count, ray order, ray count), `probes render`'s
# per-part times, and `filtered_glossy` at roughness 0.3 (issue 14) at 320×180 and 1920×1080.
#
# Runs wherever the first wgpu adapter is the GPU to be measured. It needs the release binaries
# (`probes`, and the `speed` and `filtered_glossy` examples) in BIN (default target/release,
# built here if missing) and the shared scenes in PROBE_SCENES_DIR (default ../shared/scenes).
# Writes one log per run to ${1:-h200-figures}/. About 11 minutes on an H200 machine with 16
# cores (the 1920×1080 path-traced references are most of it); hours on lavapipe.
set -uo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
out="${1:-h200-figures}"
bin="${BIN:-target/release}"
scenes="${PROBE_SCENES_DIR:-../shared/scenes}"
export PROBE_SCENES_DIR="$scenes"
if [ ! -x "$bin/probes" ] || [ ! -x "$bin/examples/speed" ] || [ ! -x "$bin/examples/filtered_glossy" ]; then
    cargo build --release -p probe-cli --bin probes -p probe-trace-gpu --example speed \
        -p probe-eval --example filtered_glossy
fi
mkdir -p "$out/work"
sponza="$scenes/sponza/Sponza_basecolor.gltf"
run() {
    local name=$1
    shift
    "$@" >"$out/$name.txt" 2>&1
    echo "$name: exit $?"
}
# A freshly started H200 machine ran its first one or two GPU processes 3.4-5.6x slower:
# two throwaway processes first.
run warm_up_1 "$bin/examples/speed" 128 960 540 8x2x4 5
run warm_up_2 "$bin/examples/speed" 128 960 540 8x2x4 5
# Issue 13: the speed example, 10 calls each after a warm-up call (median, and the spread),
# pixels in rows, 8x8 tiles and Z-order.
for res in 128 256; do
    for order in rows tiles morton; do
        run "order_${res}_$order" env SPEED_ORDER=$order "$bin/examples/speed" $res 1920 1080 8x2x4 10
    done
done
# What the time depends on: half the probes, a random ray order, a quarter of the rays.
run speed_256_32probes "$bin/examples/speed" 256 1920 1080 8x2x2 5
run speed_128_shuffled env SPEED_SHUFFLE=1 "$bin/examples/speed" 128 1920 1080 8x2x4 5
run speed_128_960x540 "$bin/examples/speed" 128 960 540 8x2x4 5
# `probes render`: the final image's parts (Cornell 640×360, Sponza CameraMain 1920×1080).
w="$out/work"
run render_cornell bash -c "'$bin/probes' place builtin:cornell --method grid --grid 3x3x3 --out '$w/c.json' &&
    '$bin/probes' bake builtin:cornell --probes '$w/c.json' --res 128 --out '$w/cb' &&
    '$bin/probes' render '$w/cb' --select grid --component final --split --width 640 --height 360 --out '$w/c_final.exr'"
# Rows against tiles in `probes render`: set OLD_PROBES to a `probes` built before TileOrder
# (63b70ea); the two alternate over three rounds.
if [ -n "${OLD_PROBES:-}" ]; then
    run render_tiles bash -c "'$bin/probes' bake '$sponza' --probes docs/tracer/sponza_region_grid.json --res 128 --out '$w/sb' &&
        for round in 1 2 3; do for b in '$OLD_PROBES' '$bin/probes'; do
            \$b render '$w/sb' --select grid --camera CameraMain --width 1920 --height 1080 --out '$w/g.exr' &&
            \$b render '$w/sb' --select grid --camera CameraMain --component final --width 1920 --height 1080 --out '$w/f.exr'
        done; done"
fi
run render_sponza bash -c "'$bin/probes' bake '$sponza' --probes docs/tracer/sponza_region_grid.json --res 128 --out '$w/sb' &&
    '$bin/probes' render '$w/sb' --select grid --camera CameraMain --component final --split --width 1920 --height 1080 --out '$w/s_final.exr'"
# Issue 14: filtered against 16 stochastic rays at roughness 0.3.
run glossy_sponza_320 "$bin/examples/filtered_glossy" "$sponza" docs/tracer/sponza_region_grid.json 64 320x180 CameraMain "$w" sponza_320 0.3
run glossy_sponza_1080 "$bin/examples/filtered_glossy" "$sponza" docs/tracer/sponza_region_grid.json 64 1920x1080 CameraMain "$w" sponza_1080 0.3
# Sub-lobes (BENCHMARKS.md "Sub-lobes"; not yet run on a real GPU): 2 and 4 cones per pixel.
run glossy_sponza_1080_sectors2 env FILTERED_SPLIT=2 "$bin/examples/filtered_glossy" "$sponza" docs/tracer/sponza_region_grid.json 64 1920x1080 CameraMain "$w" sponza_1080_s2 0.3
run glossy_sponza_1080_sectors4 env FILTERED_SPLIT=4 "$bin/examples/filtered_glossy" "$sponza" docs/tracer/sponza_region_grid.json 64 1920x1080 CameraMain "$w" sponza_1080_s4 0.3
run glossy_cornell_256 "$bin/examples/filtered_glossy" builtin:cornell grid:3x3x3 64 256x256 default "$w" cornell_256 0.1 0.3 0.6
run glossy_cornell_1080 "$bin/examples/filtered_glossy" builtin:cornell grid:3x3x3 64 1920x1080 default "$w" cornell_1080 0.3
