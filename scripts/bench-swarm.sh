#!/usr/bin/env bash
# How the simulator scales: the sorting swarm (CACHECONS on full physics, the standard
# densities) and the tile-map field with the game's robots, each N in its own process so
# its peak memory is its own. Prints Markdown table rows for BENCHMARKS.md.
#
#   scripts/bench-swarm.sh                       # 4 to 10,000 robots (about ten minutes)
#   ROBOTS="4 64 256" STEPS=100 scripts/bench-swarm.sh
#   RAYON_NUM_THREADS=1 scripts/bench-swarm.sh   # the sorting swarm on one thread
#   PARALLEL_PHYSICS=1 scripts/bench-swarm.sh    # rapier's threads inside each physics step
set -euo pipefail
cd "$(dirname "$0")/.."

robots="${ROBOTS:-4 64 256 1024 4096 10000}"
features=()
if [ "${PARALLEL_PHYSICS:-0}" != 0 ]; then
    features=(--features colony-sim/parallel-physics)
fi
cargo build --release -q "${features[@]}" -p colony-sort --example swarm_scale -p colony-sim --example field_scale

# Enough steps for a few seconds at each size, at least 50.
steps_for() {
    local n=$1
    local s=$((200000 / n))
    if [ "$s" -lt 50 ]; then s=50; fi
    if [ "$s" -gt 5000 ]; then s=5000; fi
    echo "${STEPS:-$s}"
}

echo "Build: ${features[*]:-default features}"
echo "Machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u '+%Y-%m-%d %H:%M UTC')"
echo
echo "| robots | pucks | arena | setup | control steps/s | x real time | peak memory | check |"
echo "|---:|---:|---|---:|---:|---:|---:|---|"
for n in $robots; do
    target/release/examples/swarm_scale --robots "$n" --steps "$(steps_for "$n")"
done
echo
echo "| robots | map | setup | control steps/s | x real time | peak memory | check |"
echo "|---:|---|---:|---:|---:|---:|---|"
for n in $robots; do
    target/release/examples/field_scale --robots "$n" --steps "$(steps_for "$n")"
done
