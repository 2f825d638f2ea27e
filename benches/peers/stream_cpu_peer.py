"""A depth camera's stream for the node's CPU share: rclpy (Fast DDS) publishes one view of a
resting 0.12 m ball, 6000 points with 2 mm of depth noise at 1 m (new noise each frame), in the
camera frame `cam`, at 30 Hz for WARMUP + SECONDS seconds. The node's CPU time (utime + stime
from /proc/PID/stat) is read at the end of the warm-up and at the end. Prints JSON.
Usage: stream_cpu_peer.py NODE_PID [SECONDS [WARMUP]]"""
import json
import os
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from sensor_msgs.msg import PointCloud2, PointField


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def ball_view(rng, points=6000, radius=0.06, distance=0.6):
    # The half of the ball facing a camera at the origin looking along +z, evenly spread.
    i = np.arange(points) + 0.5
    z = 1.0 - i / points  # cos of the angle from the camera's axis, 1 to 0
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    xyz = np.stack([radius * r * np.cos(phi), radius * r * np.sin(phi), distance - radius * z], 1)
    depth = np.linalg.norm(xyz, axis=1, keepdims=True)
    xyz += xyz / depth * rng.normal(0.0, 0.002, (points, 1)) * depth * depth
    return xyz.astype(np.float32)


def main():
    pid = int(sys.argv[1])
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 30.0
    warmup = float(sys.argv[3]) if len(sys.argv) > 3 else 5.0
    rclpy.init()
    node = rclpy.create_node("stream_cpu_peer")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST)
    pub = node.create_publisher(PointCloud2, "/physskin/points", sensor)
    deadline = time.time() + 30
    while pub.get_subscription_count() == 0 and time.time() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    rng = np.random.default_rng(7)
    cloud = PointCloud2()
    cloud.header.frame_id = "cam"
    cloud.height, cloud.width = 1, 6000
    cloud.fields = [PointField(name=n, offset=4 * k, datatype=PointField.FLOAT32, count=1)
                    for k, n in enumerate("xyz")]
    cloud.point_step, cloud.row_step, cloud.is_dense = 12, 12 * 6000, True
    start = time.time()
    sent, measured = 0, None
    while time.time() - start < warmup + seconds:
        if measured is None and time.time() - start >= warmup:
            measured = (time.time(), cpu_seconds(pid), sent)
        cloud.header.stamp = node.get_clock().now().to_msg()
        cloud.data = ball_view(rng).tobytes()
        pub.publish(cloud)
        sent += 1
        due = start + sent / 30.0
        while time.time() < due:
            rclpy.spin_once(node, timeout_sec=max(0.0, due - time.time()))
    wall, cpu = time.time() - measured[0], cpu_seconds(pid) - measured[1]
    print(json.dumps({
        "points": 6000, "rate_hz": 30.0, "seconds": round(wall, 3),
        "frames": sent - measured[2], "node_cpu_s": round(cpu, 3),
        "node_cpu_share": round(cpu / wall, 4),
    }))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
