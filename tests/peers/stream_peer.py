"""One depth camera's stream as rclpy (Fast DDS) publishes it: noisy views of a resting ball at
30 Hz for 5 s (the CDR files ball_*.cdr in the folder argv[1], made by the Rust test, sent in
turn), then another object in the same frame for 1 s (other_*.cdr), then nothing for 1.5 s.
While the ball is seen, every deformed cloud of it must hold the same points: the object is
kept and corrected, not rebuilt from each frame. The Rust test reads the node's recording for
the statuses (one build of the ball, its refined field, object_replaced, tracking_paused).
Exit 0 on success."""
import glob
import os
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2


def frames(folder, prefix):
    paths = sorted(glob.glob(os.path.join(folder, f"{prefix}_*.cdr")))
    if not paths:
        sys.exit(f"FAIL: no {prefix}_*.cdr in {folder}")
    out = []
    for p in paths:
        with open(p, "rb") as f:
            out.append(deserialize_message(f.read(), PointCloud2))
    return out


def finite_points(cloud):
    arr = np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)
    xyz = arr[:, 0:12].copy().view("<f4").reshape(-1, 3)
    return int(np.isfinite(xyz[:, 0]).sum()), cloud.width * cloud.height


def main():
    ball, other = frames(sys.argv[1], "ball"), frames(sys.argv[1], "other")
    rclpy.init()
    node = rclpy.create_node("stream_peer")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
    clouds = []
    node.create_subscription(PointCloud2, "/physskin/deformed_points",
                             lambda c: clouds.append((time.time(), c)), reliable)
    pub = node.create_publisher(PointCloud2, "/physskin/points", sensor)
    # Wait for the node to match us before the stream's clock starts.
    deadline = time.time() + 30
    while pub.get_subscription_count() == 0 and time.time() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    sent = 0

    def stream(views, seconds):
        nonlocal sent
        start = time.time()
        while time.time() - start < seconds:
            cloud = views[sent % len(views)]
            cloud.header.stamp = node.get_clock().now().to_msg()
            pub.publish(cloud)
            sent += 1
            due = start + (sent_in(start) + 1) / 30.0
            while time.time() < due:
                rclpy.spin_once(node, timeout_sec=max(0.0, due - time.time()))

    def sent_in(start):
        return int((time.time() - start) * 30.0)

    stream(ball, 5.0)
    ball_phase_end = time.time()
    stream(other, 1.0)
    quiet = time.time() + 1.5
    while time.time() < quiet:
        rclpy.spin_once(node, timeout_sec=0.05)
    # The ball's clouds: all those received up to the end of its phase, the first second's
    # aside (its build and first frames).
    counts = [finite_points(c) for t, c in clouds if t <= ball_phase_end]
    if len(counts) < 100:
        sys.exit(f"FAIL: {len(counts)} deformed clouds while the ball was streamed for 5 s")
    sizes = {n for _, n in counts}
    if len(sizes) != 1:
        sys.exit(f"FAIL: the ball's deformed clouds changed their point count: {sorted(sizes)}")
    print(f"ball: {len(counts)} deformed clouds of {sizes.pop()} points each; {sent} frames sent")
    print("ok: stream tracked")
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
