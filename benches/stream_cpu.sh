#!/usr/bin/env bash
# The node's CPU share on one camera's stream (issue 70's target: at most 25 % of one core):
# `physskin node` (default parameters, 60 Hz) and benches/peers/stream_cpu_peer.py (rclpy
# publishing a 6000-point view of a resting ball at 30 Hz) in a private network namespace; the
# node's CPU time over 30 s after a 5 s warm-up, from /proc. Recorded in
# benches/results/stream-cpu.json. Makes target/ros-venv if it is missing; needs root.
# Usage: benches/stream_cpu.sh [NODE ARGS...] (e.g. `-p tracking.enabled:=false`)
set -euo pipefail
cd "$(dirname "$0")/.."
source benches/ros_venv.sh
name=${STREAM_CPU_NAME:-stream-cpu}
node_args=("$@")
exec benches/record.sh "$name" unshare -n tests/peers/private_net.sh bash -c '
    extra=(); [ $# -gt 0 ] && extra=(--ros-args "$@")
    target/release/physskin node --domain-id 61 "${extra[@]}" > target/stream-cpu-node.log 2>&1 &
    node=$!
    ROS_DOMAIN_ID=61 target/ros-venv/bin/python benches/peers/stream_cpu_peer.py $node 30 5
    rc=$?
    kill -INT $node; wait $node
    exit $rc' stream-cpu "${node_args[@]}"
