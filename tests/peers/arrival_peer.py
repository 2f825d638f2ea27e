"""Stamp-to-arrival times of a node's deformed clouds at an rclpy (Fast DDS) subscriber, the
DDS side of the Foxglove live view's comparison (tests/foxglove.rs).

usage: arrival_peer.py TOPIC SECONDS OUT.json

Subscribes for SECONDS and writes {"stamp_ns": [...], "arrived_ns": [...]} (the wall clock,
which the node stamps its clouds with)."""
import json
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from sensor_msgs.msg import PointCloud2


def main():
    topic, seconds, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    rclpy.init()
    node = rclpy.create_node("arrival_peer")
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     history=HistoryPolicy.KEEP_LAST)
    seen = {"stamp_ns": [], "arrived_ns": []}

    def arrived(cloud):
        seen["arrived_ns"].append(time.time_ns())
        seen["stamp_ns"].append(cloud.header.stamp.sec * 1_000_000_000 + cloud.header.stamp.nanosec)

    node.create_subscription(PointCloud2, topic, arrived, qos)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.01)
    node.destroy_node()
    rclpy.shutdown()
    with open(out, "w") as f:
        json.dump(seen, f)
    return 0 if seen["stamp_ns"] else 1


if __name__ == "__main__":
    sys.exit(main())
