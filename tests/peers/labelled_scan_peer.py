"""A segmenting RGB-D camera as rclpy (Fast DDS) publishes it: an organized PointCloud2 in the
camera's optical frame with x, y, z, a packed rgb and a uint16 instance id (1: a ball, 2: a box,
0: the table). The cloud's bytes come from the Rust test (CDR in the file named by argv[1]).
The peer sends it at 5 Hz and reads both objects back from /physskin/deformed_points: the
camera's fields and colours, each object's points in input order, one object per cloud, moving under gravity (the
Rust test checks the node's recording for the shape ids). Exit 0 on success."""
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2


def records(cloud):
    return np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)


def xyz_and_ids(cloud):
    arr = records(cloud)
    xyz = arr[:, 0:12].copy().view("<f4").reshape(-1, 3)
    ids = arr[:, 16:18].copy().view("<u2").ravel()
    return xyz.astype(np.float64), ids


def main():
    with open(sys.argv[1], "rb") as f:
        scan = deserialize_message(f.read(), PointCloud2)
    sent_xyz, sent_ids = xyz_and_ids(scan)
    sent = records(scan)
    rclpy.init()
    node = rclpy.create_node("labelled_scan_peer")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
    clouds = []
    node.create_subscription(PointCloud2, "/physskin/deformed_points", clouds.append, reliable)
    pub = node.create_publisher(PointCloud2, "/physskin/points", sensor)
    deadline = time.time() + 60
    last_sent = 0.0
    by_label = {}
    while time.time() < deadline:
        if time.time() - last_sent > 0.2:
            scan.header.stamp = node.get_clock().now().to_msg()
            pub.publish(scan)
            last_sent = time.time()
        rclpy.spin_once(node, timeout_sec=0.02)
        for c in clouds:
            _, ids = xyz_and_ids(c)
            finite = np.isfinite(xyz_and_ids(c)[0][:, 0])
            labels = set(ids[finite].tolist())
            if len(labels) != 1:
                sys.exit(f"FAIL: a deformed cloud holds instances {labels}")
            by_label.setdefault(labels.pop(), []).append(c)
        clouds.clear()
        if all(len(by_label.get(k, [])) >= 30 for k in (1, 2)):
            break
    else:
        sys.exit(f"FAIL: deformed clouds per instance: { {k: len(v) for k, v in by_label.items()} }")
    if 0 in by_label:
        sys.exit("FAIL: the background became an object")
    for label, got in by_label.items():
        first, last = got[0], got[-1]
        mine = sent_ids == label
        if first.header.frame_id != scan.header.frame_id:
            sys.exit(f"FAIL: instance {label} in frame {first.header.frame_id}")
        # One object of a labelled cloud: its own points, in the camera's layout and order.
        if (first.height, first.width, first.point_step) != (1, int(mine.sum()), scan.point_step):
            sys.exit(f"FAIL: instance {label}: {first.height} x {first.width}, expected its {int(mine.sum())} points")
        if [(f.name, f.offset, f.datatype) for f in first.fields] != \
                [(f.name, f.offset, f.datatype) for f in scan.fields]:
            sys.exit(f"FAIL: instance {label}: fields {first.fields}")
        arr = records(last)
        if not np.array_equal(arr[:, 12:20], sent[mine][:, 12:20]):
            sys.exit(f"FAIL: instance {label}: rgb or ids changed or reordered")
        xyz, _ = xyz_and_ids(last)
        if not np.isfinite(xyz).all():
            sys.exit(f"FAIL: instance {label}: a deformed point is not finite")
        moved = np.abs(xyz - sent_xyz[mine]).max()
        if not 1e-5 < moved < 0.2:
            sys.exit(f"FAIL: instance {label} moved {moved} m")
        print(f"instance {label}: {len(got)} clouds, {int(mine.sum())} points, moved {moved:.4f} m")
    print("ok: labelled scan, two objects read back")
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
