#!/usr/bin/env bash
# `bench latency` with its rclpy case, recorded in benches/results/latency.json. Makes
# target/ros-venv (rclpy with Fast DDS from pip) if it is missing, then runs the bench in a
# private network namespace (needs root for `unshare -n`).
# Usage: benches/latency.sh [NAME [ARGS...]]: records benches/results/NAME.json (default
# latency), ARGS added to the bench's command (e.g. `latency-refine-off --refine off`).
set -euo pipefail
cd "$(dirname "$0")/.."
source benches/ros_venv.sh
name=${1:-latency}
shift || true
exec benches/record.sh "$name" unshare -n tests/peers/private_net.sh \
    target/release/physskin bench latency --json --rclpy-python "$venv/bin/python" "$@"
