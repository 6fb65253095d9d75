#!/usr/bin/env bash
# Environment steps per second (issue 19's figures in BENCHMARKS.md): colony's Python
# environments, single and batched, beside PettingZoo's MPE and VMAS on CPU, in one run on
# one machine, with the Rust cores stepped alone so the Python-Rust crossing is told apart.
# Everything is installed in a virtual environment under target/ (torch, for VMAS, is
# several GB); the colony package is built in release.
#
#   scripts/bench-envs.sh [--seconds S] [--batch WORLDS] [--peers mpe,vmas]
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/bench-envs
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check \
    numpy==2.4.6 gymnasium==1.4.0 pettingzoo==1.27.0 mpe2==1.1.1 vmas==1.5.2 torch==2.15.0 maturin==1.16.0
PATH="$PWD/$venv/bin:$PATH" "$venv/bin/pip" install --quiet --disable-pip-version-check \
    --force-reinstall --no-deps --no-build-isolation ./crates/py

cargo build --release --quiet -p colony-py --example env_speed
rust=$(target/release/examples/env_speed | awk '{printf "%s%s=%s", (NR > 1 ? "," : ""), $1, $2}')
"$venv/bin/python" crates/py/bench/env_speed.py --rust "$rust" "$@"
