"""The rclpy case of `physskin bench latency`: once rclpy's publisher and subscription have both
matched the node's, publish a cloud and time its first deformed cloud at this subscriber.

usage: latency_peer.py POINTS_TOPIC DEFORMED_TOPIC CLOUD_FILE FRAME REPEATS

"Matched" means rclpy's publisher and subscription both count the node's endpoints and a
deformed cloud of the object already running in FRAME has arrived.

CLOUD_FILE holds the points as little-endian float32 x, y, z (the bench writes the same cloud
as its in-process case). Repeat r sends the first N - 2 - r points, so the node rebuilds the
object in FRAME and its answer is told from the clouds of the object it replaces (which has N
or N - 1 points after the in-process case, or N - 1 - r after the previous repeat). Prints one JSON line: {"latency_ms": [...], "match_ms": ..., "first_data_ms": ...}. Exit 1 on a timeout."""
import json
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from sensor_msgs.msg import PointCloud2, PointField


def cloud(points, frame):
    msg = PointCloud2()
    msg.header.frame_id = frame
    msg.height, msg.width = 1, len(points)
    msg.fields = [
        PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
        for i, n in enumerate("xyz")
    ]
    msg.is_bigendian = False
    msg.point_step, msg.row_step = 12, 12 * len(points)
    msg.data = points.astype("<f4").tobytes()
    msg.is_dense = True
    return msg


def spin_until(node, done, timeout_s):
    deadline = time.monotonic() + timeout_s
    while not done():
        if time.monotonic() > deadline:
            return False
        rclpy.spin_once(node, timeout_sec=0.001)
    return True


def main():
    points_topic, deformed_topic, cloud_file, frame, repeats = sys.argv[1:6]
    points = np.fromfile(cloud_file, dtype="<f4").reshape(-1, 3)
    rclpy.init()
    node = rclpy.create_node("physskin_latency_peer")
    qos = lambda depth: QoSProfile(  # noqa: E731
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
    )
    arrivals = []
    pub = node.create_publisher(PointCloud2, points_topic, qos(5))
    sub = node.create_subscription(
        PointCloud2,
        deformed_topic,
        lambda m: arrivals.append((m.header.frame_id, m.width, time.monotonic())),
        qos(50),
    )
    started = time.monotonic()
    matched = lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0  # noqa: E731
    if not spin_until(node, matched, 30):
        print("publisher and subscription did not both match the node within 30 s", file=sys.stderr)
        return 1
    match_ms = (time.monotonic() - started) * 1e3
    # rclpy's counts are Fast DDS's view only; the node's writer matches rclpy's reader up to
    # ~300 ms later (measured), and samples it writes before then never reach this reader. The
    # node already steps an object, so its first cloud here proves that direction matched too.
    if not spin_until(node, lambda: len(arrivals) > 0, 30):
        print("no deformed cloud of the running object within 30 s of matching", file=sys.stderr)
        return 1
    first_data_ms = (time.monotonic() - started) * 1e3 - match_ms
    latencies = []
    for repeat in range(int(repeats)):
        count = len(points) - 2 - repeat
        msg = cloud(points[:count], frame)
        arrivals.clear()
        sent = time.monotonic()
        pub.publish(msg)
        ours = lambda: any(f == frame and w == count for f, w, _ in arrivals)  # noqa: E731
        if not spin_until(node, ours, 30):
            print(f"no deformed cloud in {frame} within 30 s (repeat {repeat})", file=sys.stderr)
            return 1
        at = next(t for f, w, t in arrivals if f == frame and w == count)
        latencies.append((at - sent) * 1e3)
        # Let the node step the object before the next rebuild.
        spin_until(node, lambda: False, 0.3)
    print(json.dumps({"latency_ms": latencies, "match_ms": match_ms, "first_data_ms": first_data_ms}))
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
