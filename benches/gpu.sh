#!/usr/bin/env sh
# The GPU machine's figures in one run: the crowd against full detail and the discrete levels on
# the grid and on the 10,000-body walk-through (both draw paths), the 100k-vertex man -> camel
# object with and without frames built ahead, the crowd demo, and the GPU tests (BENCHMARKS.md,
# "Crowds"). From the project root:
#
#   benches/gpu.sh [BIN [OUT]]     BIN: the release binaries (default target/release),
#                                  OUT: the reports and logs (default out/gpu)
#
# On a GPU machine with no Rust toolchain, pack the binaries here and run it there:
#
#   ../shared/tools/device-pack --tests suite,memory --examples crowd benches
#   bash .dev/run sh benches/gpu.sh bin "$OUT"      (with .gl and .dev carried along)
#
# The assets are built on that machine by the packed `morphlod` (about a minute on 16 cores).
# CROWD (default 1000), WALKERS (default 10000) and FRAMES (default 120; the object's sweeps take
# twice that) shorten a trial run on a software rasteriser. Every command's output goes to
# OUT/NAME.txt, its rows to OUT/NAME.json; a failing command is reported and the others still
# run.
set -u
bin=${1:-target/release}
out=${2:-out/gpu}
crowd=${CROWD:-1000}
frames=${FRAMES:-120}
m="$bin/morphlod"
mkdir -p "$out"
failed=0

# run NAME COMMAND...: runs one command, its output to OUT/NAME.txt, its wall time to the log.
run() {
    name=$1
    shift
    start=$(date +%s)
    if "$@" > "$out/$name.txt" 2>&1; then
        echo "$name: $(($(date +%s) - start)) s"
    else
        echo "$name: FAILED after $(($(date +%s) - start)) s (see $out/$name.txt)"
        failed=$((failed + 1))
    fi
}

# The assets: the body's 32 sampled frames (its weight animation), the same with one shared
# sequence (the discrete levels are cut from it), the 16-frame man -> camel supermesh.
[ -s "$out/body.mlod" ] || run build-body "$m" build assets/makehuman_body.glb \
    --animation morph --frames 32 -o "$out/body.mlod"
[ -s "$out/body_shared.mlod" ] || run build-body-shared "$m" build assets/makehuman_body.glb \
    --animation morph --frames 32 --sequence shared -o "$out/body_shared.mlod"
[ -s "$out/walker.mlod" ] || run build-walker "$m" build assets/makehuman_walker.glb \
    --animation walk --weights morph --frames 16 -o "$out/walker.mlod"
[ -s "$out/walker_shared.mlod" ] || run build-walker-shared "$m" build \
    assets/makehuman_walker.glb --animation walk --weights morph --frames 16 --sequence shared \
    -o "$out/walker_shared.mlod"
[ -s "$out/mc16.mlod" ] || run build-mc16 "$m" build assets/man.off assets/camel.off \
    --frames 16 -o "$out/mc16.mlod"

levels="--levels 0.5,0.25,0.1,0.03,0.01"
walkers=${WALKERS:-10000}
shared="--levels-from $out/body_shared.mlod"
crowd() {
    name=$1
    shift
    run "$name" "$m" bench "$out/body.mlod" --crowd "$crowd" --frames "$frames" $shared \
        --json "$out/$name.json" "$@"
}
# The crowd against full detail and the export's levels, then against levels down to 1 %.
crowd crowd-export-levels
crowd crowd-levels-1pc --skip-full $levels
# The same two without the tail lists, the crowd every body of which switches every frame,
# and the base-vertex path (for adapters without INDIRECT_FIRST_INSTANCE).
crowd crowd-no-tails --skip-full $levels --tail-triangles 0
crowd crowd-period30 --skip-full $levels --period 30
crowd crowd-base-vertex --skip-full $levels --crowd-path base-vertex
# The walk through a crowd of WALKERS (default 10,000; issue 50), the discrete levels chosen by
# error down to what the farthest body needs, on both draw paths.
for crowd_path in first-instance base-vertex; do
    run "walk-$walkers-$crowd_path" "$m" bench "$out/body.mlod" --crowd "$walkers" \
        --scene walk-through --frames "$frames" --skip-full $shared --crowd-path "$crowd_path" \
        --json "$out/walk-$walkers-$crowd_path.json"
done
# The same walk through WALKERS skinned walkers (issue 51), against the engine way (the
# discrete levels skinned and instanced).
run "walk-$walkers-skinned" "$m" bench "$out/walker.mlod" --crowd "$walkers" \
    --scene walk-through --frames "$frames" --skip-full --levels-from "$out/walker_shared.mlod" \
    --json "$out/walk-$walkers-skinned.json"
# The shared-sequence asset: no frame switches.
run crowd-shared "$m" bench "$out/body_shared.mlod" --crowd "$crowd" --frames "$frames" \
    --skip-full $levels --json "$out/crowd-shared.json"

# The 100k-vertex object, frames built ahead against none, alternating.
sweep=$((2 * frames))
for pair in 1 2; do
    for ahead in auto never; do
        run "mc16-$ahead-$pair" "$m" bench "$out/mc16.mlod" --frames "$sweep" \
            --build-ahead "$ahead" --json "$out/mc16-$ahead-$pair.json"
    done
done

# The demo (800 walkers and 200 faces at the default mix), with and without culling, and the
# GPU tests, where packed.
if [ -x "$bin/crowd" ]; then
    run crowd-demo "$bin/crowd" --headless --instances "$crowd" --frames "$frames" \
        --out "$out/crowd-demo"
    run crowd-demo-no-culling "$bin/crowd" --headless --instances "$crowd" --frames "$frames" \
        --out "$out/crowd-demo" --no-culling
fi
for t in suite memory; do
    # device-pack leaves the test binaries in its unpacked bundle's tests/ (tests/suite is
    # a folder of sources here).
    test_bin=""
    for f in "$bin/$t" "tests/$t" "/tmp/devtree/tests/$t"; do
        [ -z "$test_bin" ] && [ -f "$f" ] && [ -x "$f" ] && test_bin=$f
    done
    [ -z "$test_bin" ] && continue
    if [ "$t" = suite ]; then
        run test-suite "$test_bin" --test-threads 4 crowd:: gpu_ lod_object:: image_oracle:: \
            textured:: skin_gpu::
    else
        run test-memory "$test_bin"
    fi
done

# The summary lines of every bench.
grep -H -E "^(lod|full|discrete) +[0-9]|CPU set\+prepare|frame switches, |mean of frames" "$out"/*.txt
echo "$failed command(s) failed; reports in $out"
[ "$failed" -eq 0 ]
