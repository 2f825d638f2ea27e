"""A real ROS 2 peer (rclpy, Fast DDS) driving a scene's robot: it publishes
sensor_msgs/JointState on /joint_states, lowering the press 0.17 m onto the block the physskin
node simulates, and checks on /physskin/deformed_points that the middle of the block's top goes
down about 2 cm and comes back when the press lifts. Exit 0 on success."""
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from sensor_msgs.msg import JointState, PointCloud2


def top_middle(cloud):
    names = {f.name: f for f in cloud.fields}
    arr = np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)
    xyz = np.stack([arr[:, names[a].offset:names[a].offset + 4].copy().view("<f4").ravel()
                    for a in "xyz"], axis=1)
    middle = (np.abs(xyz[:, 0]) < 0.04) & (np.abs(xyz[:, 1]) < 0.04) & (xyz[:, 2] > 0.2)
    return float(xyz[middle, 2].max()) if middle.any() else None


def main():
    rclpy.init()
    node = rclpy.create_node("press_driver")
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     history=HistoryPolicy.KEEP_LAST)
    joints = node.create_publisher(JointState, "/joint_states", qos)
    tops = []
    node.create_subscription(PointCloud2, "/physskin/deformed_points",
                             lambda c: tops.append((time.monotonic(), top_middle(c))), qos)

    def spin_for(seconds, lift=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if lift is not None:
                msg = JointState()
                msg.header.stamp = node.get_clock().now().to_msg()
                msg.name = ["lift"]
                msg.position = [float(lift(time.monotonic()))]
                joints.publish(msg)
            rclpy.spin_once(node, timeout_sec=0.02)

    # Wait for the scene's first frames (the node builds it after it starts).
    deadline = time.monotonic() + 60
    while not tops and time.monotonic() < deadline:
        spin_for(0.2, lambda t: 0.0)
    if not tops:
        print("fail: no deformed points from the node")
        return 1
    spin_for(1.0, lambda t: 0.0)
    rest = [z for _, z in tops[-10:] if z is not None]
    start = time.monotonic()
    spin_for(2.0, lambda t: min(0.17, 0.17 * (t - start) / 1.0))
    pressed = [z for _, z in tops[-10:] if z is not None]
    spin_for(2.0, lambda t: 0.0)
    released = [z for _, z in tops[-5:] if z is not None]
    # A bogus joint name: the node must say so on /physskin/status and keep going.
    msg = JointState()
    msg.name, msg.position = ["elbow"], [0.3]
    joints.publish(msg)
    spin_for(0.5)
    node.destroy_node()
    rclpy.shutdown()
    if not (rest and pressed and released):
        print(f"fail: clouds missing: rest {rest}, pressed {pressed}, released {released}")
        return 1
    r, p, q = float(np.mean(rest)), min(pressed), float(np.mean(released))
    print(f"top middle: at rest {r:.4f} m, pressed {p:.4f} m, released {q:.4f} m "
          f"({len(tops)} clouds)")
    if not (0.27 < p < 0.29 and r - p > 0.01 and abs(q - r) < 0.003):
        print("fail: the press did not dent the block as expected")
        return 1
    print("ok: joint states drove the press")
    return 0


if __name__ == "__main__":
    sys.exit(main())
