#!/usr/bin/env bash
# The hub's loopback benchmarks: colony hub vs a raw UDP relay vs Mosquitto,
# latency (100-byte packet) and delivered throughput at fan-out 1, 10, 100,
# first with fixed-length (100-byte) packets, then with a mix of lengths
# (60 to 400 bytes). Builds colony-bench in release, runs hub-bench twice
# (it starts and stops its own Mosquitto on a free loopback port), prints the
# reports and rewrites the "## Hub on loopback" and "## Hub on loopback,
# mixed lengths" sections of BENCHMARKS.md.
#
#   scripts/bench-hub.sh                 # the full run (about six minutes on a quiet machine)
#   scripts/bench-hub.sh --duration 1    # any hub-bench option; see --help
#   MOSQUITTO=/opt/bin/mosquitto scripts/bench-hub.sh
set -euo pipefail
cd "$(dirname "$0")/.."

mosquitto="${MOSQUITTO:-}"
if [ -z "$mosquitto" ]; then
    mosquitto="$(command -v mosquitto || true)"
fi
if [ -z "$mosquitto" ] && [ -x /usr/sbin/mosquitto ]; then
    mosquitto=/usr/sbin/mosquitto
fi
if [ -z "$mosquitto" ] || [ ! -x "$mosquitto" ]; then
    echo "bench-hub: mosquitto not found (looked at \$MOSQUITTO, PATH and /usr/sbin)." >&2
    echo "bench-hub: install it with 'apt-get install mosquitto', or set MOSQUITTO=/path/to/mosquitto." >&2
    exit 1
fi

echo "bench-hub: load average: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores" >&2
cargo build --release -p colony-bench
target_dir="${CARGO_TARGET_DIR:-target}"
bench="$target_dir/release/hub-bench"
"$bench" --mosquitto "$mosquitto" --relay-gso --markdown BENCHMARKS.md "$@"
echo "bench-hub: load average: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores" >&2
"$bench" --mosquitto "$mosquitto" --relay-gso --lengths mixed --no-latency --markdown BENCHMARKS.md "$@"
