#!/usr/bin/env bash
# `bench latency` with its rclpy case, recorded in benches/results/latency.json. Makes
# target/ros-venv (rclpy with Fast DDS from pip) if it is missing, then runs the bench in a
# private network namespace (needs root for `unshare -n`).
# Usage: benches/latency.sh [NAME [ARGS...]]: records benches/results/NAME.json (default
# latency), ARGS added to the bench's command (e.g. `latency-refine-off --refine off`).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/ros-venv
if ! "$venv/bin/python" -c "import rclpy, sensor_msgs.msg, numpy" 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q ros-rclpy ros-rmw-fastrtps-cpp ros-sensor-msgs ros-std-msgs numpy
fi
cargo build --release --locked
name=${1:-latency}
shift || true
exec benches/record.sh "$name" unshare -n tests/peers/private_net.sh \
    target/release/physskin bench latency --json --rclpy-python "$venv/bin/python" "$@"
