"""A mesh published once, reliable and transient local, before the node starts: the node,
started a few seconds later, must still build it (its deformed cloud arrives in frame world).
Prints "ok: late mesh"; exits non-zero otherwise."""

import sys
import time

import rclpy
from geometry_msgs.msg import Point
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from shape_msgs.msg import Mesh, MeshTriangle


def main():
    rclpy.init()
    node = rclpy.create_node("late_mesh_peer")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = node.create_publisher(Mesh, "/physskin/mesh", latched)
    v = [Point(x=x, y=y, z=z) for x in (-0.1, 0.1) for y in (-0.05, 0.05) for z in (0.0, 0.1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [MeshTriangle(vertex_indices=list(t)) for a, b, c, d in quads
            for t in ((a, b, c), (a, c, d))]
    pub.publish(Mesh(triangles=tris, vertices=v))
    print("published the mesh once, before the node runs", flush=True)
    got = []
    node.create_subscription(PointCloud2, "/physskin/deformed_points", got.append,
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    deadline = time.time() + 90
    while time.time() < deadline and not any(m.header.frame_id == "world" for m in got):
        rclpy.spin_once(node, timeout_sec=0.05)
    if not got:
        sys.exit("FAIL: the mesh published before the node started was never built")
    print(f"ok: late mesh ({len(got[0].data) // 12} deformed points)", flush=True)
    rclpy.shutdown()


if __name__ == "__main__":
    main()
