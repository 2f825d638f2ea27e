"""Two physskin instances split one camera's objects (rclpy with Fast DDS as the camera and the
consumer). The labelled, organized cloud of eight objects (ids 1 to 8; CDR in the file named
by argv[1]) goes to /camera/points at 5 Hz; both nodes hear it. /cell/skin_0 runs shard 0/2,
/cell/skin_1 shard 1/2. Checks that every object's deformed cloud arrives, each from exactly
one node (ids 2, 4, 6, 8 from skin_0; 1, 3, 5, 7 from skin_1), one object per cloud, and that
each node's /diagnostics names its shard. Prints "ok: shards" and exits 0 when all hold."""
import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2

NODES = ("/cell/skin_0", "/cell/skin_1")


def labels_of(cloud):
    arr = np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)
    xyz = arr[:, 0:12].copy().view("<f4").reshape(-1, 3)
    ids = arr[:, 16:18].copy().view("<u2").ravel()
    return set(ids[np.isfinite(xyz[:, 0])].tolist())


def main():
    with open(sys.argv[1], "rb") as f:
        scan = deserialize_message(f.read(), PointCloud2)
    rclpy.init()
    node = rclpy.create_node("shards_peer")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST)
    reliable = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    clouds = {name: [] for name in NODES}
    for name in NODES:
        node.create_subscription(PointCloud2, f"{name}/deformed_points",
                                 clouds[name].append, reliable)
    shards = {}

    def diagnostics(msg):
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            if "shard" in values:
                shards[s.hardware_id] = (s.name, values["shard"])

    node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics, reliable)
    pub = node.create_publisher(PointCloud2, "/camera/points", sensor)
    counts = {}
    deadline, last_sent = time.time() + 90, 0.0
    while time.time() < deadline:
        if time.time() - last_sent > 0.2:
            scan.header.stamp = node.get_clock().now().to_msg()
            pub.publish(scan)
            last_sent = time.time()
        rclpy.spin_once(node, timeout_sec=0.02)
        for name, got in clouds.items():
            for c in got:
                labels = labels_of(c)
                if len(labels) != 1:
                    sys.exit(f"FAIL: a deformed cloud of {name} holds instances {labels}")
                key = (name, labels.pop())
                counts[key] = counts.get(key, 0) + 1
            got.clear()
        seen = {label for (_, label) in counts}
        if seen == set(range(1, 9)) and min(counts.values()) >= 10 and len(shards) == 2:
            break
    else:
        sys.exit(f"FAIL: clouds per (node, id) {counts}, diagnostics {shards}")
    for k, name in enumerate(NODES):
        mine = sorted(label for (n, label) in counts if n == name)
        expected = [label for label in range(1, 9) if label % 2 == k]
        if mine != expected:
            sys.exit(f"FAIL: {name} published ids {mine}, expected {expected}")
        label, shard = shards.get(name, ("", ""))
        if shard != f"{k}/2" or f"shard {k}/2" not in label:
            sys.exit(f"FAIL: {name}'s diagnostics say {label!r}, shard {shard!r}")
        print(f"{name}: ids {mine}, {sum(counts[(name, i)] for i in mine)} clouds, {label}")
    print("ok: shards")
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
