#!/usr/bin/env bash
# How the simulator scales: the sorting swarm (CACHECONS on full physics, the standard
# densities) on each contact engine, then the tile-map field with the game's robots, each
# N in its own process so its peak memory is its own. Prints Markdown table rows for
# BENCHMARKS.md.
#
#   scripts/bench-swarm.sh                       # 4 to 100,000 robots (about fifteen minutes)
#   ROBOTS="4 64 256" STEPS=100 scripts/bench-swarm.sh
#   ENGINES=disc FIELD=0 scripts/bench-swarm.sh  # one engine, no tile-map field
#   RAYON_NUM_THREADS=1 scripts/bench-swarm.sh   # the sorting swarm on one thread
#   PARALLEL_PHYSICS=1 scripts/bench-swarm.sh    # rapier's threads inside each physics step
set -euo pipefail
cd "$(dirname "$0")/.."

robots="${ROBOTS:-4 64 256 1024 4096 10000 100000}"
engines="${ENGINES:-disc rapier}"
features=()
if [ "${PARALLEL_PHYSICS:-0}" != 0 ]; then
    features=(--features colony-sim/parallel-physics)
fi
cargo build --release -q "${features[@]}" -p colony-lab --example swarm_scale -p colony-sim --example field_scale

# The run lengths the targets are stated over (issue 32): 1,000 control steps at 1,024
# robots, 150 at 10,000; a few seconds' worth elsewhere, and 5 steps at 100,000.
steps_for() {
    case $1 in
        4) s=5000 ;;
        64) s=3000 ;;
        256 | 1024) s=1000 ;;
        4096) s=300 ;;
        10000) s=150 ;;
        100000) s=5 ;;
        *) s=$((200000 / $1)); if [ "$s" -lt 5 ]; then s=5; fi ;;
    esac
    echo "${STEPS:-$s}"
}

echo "Build: ${features[*]:-default features}"
echo "Machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u '+%Y-%m-%d %H:%M UTC')"
echo
echo "| engine | robots | pucks | arena | setup | control steps/s | x real time | peak memory | step per body per physics step | contacts per body | pucks asleep | the engine alone: per body, share of the step, stages | final PC |"
echo "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---:|"
for n in $robots; do
    for engine in $engines; do
        target/release/examples/swarm_scale --engine "$engine" --robots "$n" --steps "$(steps_for "$n")"
    done
done
if [ "${FIELD:-1}" = 0 ]; then exit 0; fi
echo
echo "| robots | map | setup | control steps/s | x real time | peak memory | check |"
echo "|---:|---|---:|---:|---:|---:|---|"
for n in $robots; do
    # The tile-map field (rapier underneath, the game's maps) stops at 10,000 robots.
    if [ "$n" -gt 10000 ]; then continue; fi
    target/release/examples/field_scale --robots "$n" --steps "$(steps_for "$n")"
done
