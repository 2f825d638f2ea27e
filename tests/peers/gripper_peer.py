"""A real ROS 2 robot (rclpy, Fast DDS) as robot_state_publisher and a driver would present it:
the bundled two-finger gripper's URDF (config/robots/gripper.urdf) once on robot_description (std_msgs/String, reliable,
transient local), a soft 0.1 m block's cloud on /physskin/points in `world` until the node
answers, then sensor_msgs/JointState on /joint_states at 60 Hz: the fingers close 0.025 m each
in 0.7 s, the palm lifts 0.2 m in 1 s, and holds for 5 s. Checks on /physskin/deformed_points
that the block rose with the palm and moved under 1 mm in the grip. Exit 0 on success."""
import os
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy, DurabilityPolicy
from sensor_msgs.msg import JointState, PointCloud2, PointField
from std_msgs.msg import String


def block_cloud(node):
    """A 0.1 m cube's surface resting on z = 0, 11 x 11 points a face."""
    at = np.linspace(-0.05, 0.05, 11)
    u, v = [a.ravel() for a in np.meshgrid(at, at)]
    faces = []
    for axis in range(3):
        for side in (-0.05, 0.05):
            p = np.zeros((u.size, 3))
            p[:, axis] = side
            p[:, (axis + 1) % 3] = u
            p[:, (axis + 2) % 3] = v
            faces.append(p)
    xyz = np.concatenate(faces).astype("<f4")
    xyz[:, 2] += 0.05
    cloud = PointCloud2()
    cloud.header.frame_id = "world"
    cloud.header.stamp = node.get_clock().now().to_msg()
    cloud.height, cloud.width = 1, len(xyz)
    cloud.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                    for i, n in enumerate("xyz")]
    cloud.point_step, cloud.row_step = 12, 12 * len(xyz)
    cloud.is_dense = True
    cloud.data = xyz.tobytes()
    return cloud


def centroid(cloud):
    xyz = np.frombuffer(bytes(cloud.data), dtype="<f4").reshape(-1, cloud.point_step // 4)[:, :3]
    return xyz.mean(axis=0)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "../../config/robots/gripper.urdf")) as f:
        urdf = f.read()
    rclpy.init()
    node = rclpy.create_node("gripper_driver")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST)
    description = node.create_publisher(String, "/robot_description", latched)
    description.publish(String(data=urdf))
    joints = node.create_publisher(JointState, "/joint_states", reliable)
    points = node.create_publisher(PointCloud2, "/physskin/points", reliable)
    seen = []
    node.create_subscription(PointCloud2, "/physskin/deformed_points",
                             lambda c: seen.append((time.monotonic(), centroid(c))), reliable)

    def spin_for(seconds, positions):
        end = time.monotonic() + seconds
        next_state = time.monotonic()
        while time.monotonic() < end:
            if time.monotonic() >= next_state:
                lift, finger = positions(time.monotonic())
                msg = JointState()
                msg.header.stamp = node.get_clock().now().to_msg()
                msg.name = ["lift", "left", "right"]
                msg.position = [float(lift), float(finger), float(finger)]
                joints.publish(msg)
                next_state += 1 / 60
            rclpy.spin_once(node, timeout_sec=0.005)

    # The block's cloud until the node answers with its first deformed cloud.
    deadline = time.monotonic() + 60
    while not seen and time.monotonic() < deadline:
        points.publish(block_cloud(node))
        spin_for(0.2, lambda t: (0.0, 0.0))
    if not seen:
        print("fail: no deformed points from the node")
        return 1
    spin_for(1.0, lambda t: (0.0, 0.0))
    before = np.mean([c for _, c in seen[-10:]], axis=0)
    start = time.monotonic()

    def grasp(t):
        ramp = lambda a, b: min(max((t - start - a) / (b - a), 0.0), 1.0)
        return 0.2 * ramp(1.2, 2.2), 0.025 * ramp(0.0, 0.7)

    spin_for(2.4, grasp)
    held_from = time.monotonic()
    lifted = np.mean([c for _, c in seen[-5:]], axis=0)
    spin_for(5.0, grasp)
    held = [c for t, c in seen if t >= held_from]
    node.destroy_node()
    rclpy.shutdown()
    rise = lifted[2] - before[2]
    drift = max(np.linalg.norm(c - lifted) for c in held) if held else float("inf")
    print(f"block rose {rise:.4f} m with the palm; moved {drift * 1e3:.3f} mm in the grip over "
          f"5 s ({len(held)} clouds)")
    if not (0.18 < rise < 0.205 and drift < 1e-3 and len(held) > 100):
        print("fail: the described gripper did not lift and hold the block")
        return 1
    print("ok: robot_description gripper lifted the block")
    return 0


if __name__ == "__main__":
    sys.exit(main())
