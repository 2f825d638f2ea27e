"""The node inside a ROS 2 graph, seen from rclpy (Fast DDS): it was started with launch_ros's
argv as /cell/skin (rate_hz 30 by -p, material.young from a --params-file, ~/points remapped
to /camera/points), and a second instance runs as /cell2/skin. Checks names, parameters, the
deformed clouds' rate, that /cell2 hears nothing of /cell, /rosout, /diagnostics, markers,
~/reset and ~/clear. Prints "ok: graph" when every check passed; exits non-zero otherwise."""

import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import Log
from rcl_interfaces.srv import GetParameters
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2, PointField
from shape_msgs.msg import Mesh, MeshTriangle
from geometry_msgs.msg import Point
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def fail(why):
    print(f"FAIL: {why}", flush=True)
    sys.exit(1)


def cloud_of(points, frame, with_z=True):
    names = "xyz" if with_z else "xy"
    m = PointCloud2()
    m.header.frame_id = frame
    m.height, m.width = 1, len(points)
    m.fields = [PointField(name=a, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                for i, a in enumerate(names)]
    m.point_step = 4 * len(names)
    m.row_step = m.point_step * len(points)
    m.is_dense = True
    m.data = np.ascontiguousarray(points[:, :len(names)], dtype="<f4").tobytes()
    return m


def xyz(cloud):
    return np.frombuffer(bytes(cloud.data), dtype="<f4").reshape(-1, 3).astype(np.float64)


def stamp(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def box_points(n, rng):
    p = rng.uniform(-1, 1, size=(n, 3))
    face = rng.integers(0, 3, size=n)
    p[np.arange(n), face] = np.sign(p[np.arange(n), face] + 1e-9)
    return p * np.array([0.1, 0.05, 0.05]) + np.array([0.0, 0.0, 0.05])


def box_mesh():
    v = [Point(x=x, y=y, z=z) for x in (-0.1, 0.1) for y in (-0.05, 0.05) for z in (0.0, 0.1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = []
    for a, b, c, d in quads:
        tris += [MeshTriangle(vertex_indices=[a, b, c]), MeshTriangle(vertex_indices=[a, c, d])]
    return Mesh(triangles=tris, vertices=v)


class Peer:
    def __init__(self):
        self.node = rclpy.create_node("graph_peer")
        self.clouds, self.clouds2, self.logs, self.diags, self.markers = [], [], [], [], []
        n = self.node
        n.create_subscription(PointCloud2, "/cell/skin/deformed_points",
                              lambda m: self.clouds.append((time.time(), m)), RELIABLE)
        n.create_subscription(PointCloud2, "/cell2/skin/deformed_points",
                              lambda m: self.clouds2.append(m), RELIABLE)
        n.create_subscription(Log, "/rosout", lambda m: self.logs.append((time.time(), m)),
                              QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        n.create_subscription(DiagnosticArray, "/diagnostics",
                              lambda m: self.diags.append((time.time(), m)), RELIABLE)
        self.cloud_pub = n.create_publisher(PointCloud2, "/camera/points", RELIABLE)
        self.mesh_pub = n.create_publisher(Mesh, "/cell/skin/mesh", LATCHED)

    def spin(self, seconds, until=lambda: False):
        end = time.time() + seconds
        while time.time() < end and not until():
            rclpy.spin_once(self.node, timeout_sec=0.02)
        return until()

    def call(self, srv_type, name, request):
        client = self.node.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=20):
            fail(f"service {name} not offered")
        future = client.call_async(request)
        rclpy.spin_until_future_complete(self.node, future, timeout_sec=10)
        if future.result() is None:
            fail(f"no answer from {name}")
        return future.result()


def check_names_and_parameters(peer):
    want = {("skin", "/cell"), ("skin", "/cell2")}
    if not peer.spin(60, lambda: want <= set(peer.node.get_node_names_and_namespaces())):
        fail(f"nodes seen: {peer.node.get_node_names_and_namespaces()}")
    request = GetParameters.Request(names=["rate_hz", "material.young", "topics.points"])
    values = peer.call(GetParameters, "/cell/skin/get_parameters", request).values
    got = (values[0].double_value, values[1].double_value, values[2].string_value)
    if got[:2] != (30.0, 300000.0) or got[2] != "~/points":
        fail(f"parameters of /cell/skin: {got}")
    print(f"ok: /cell/skin and /cell2/skin listed; rate_hz {got[0]}, material.young {got[1]}")


def check_rate(peer, rest):
    if not peer.spin(30, lambda: peer.cloud_pub.get_subscription_count() > 0):
        fail("no subscriber on /camera/points")
    peer.cloud_pub.publish(cloud_of(rest, "cam"))
    if not peer.spin(30, lambda: any(m.header.frame_id == "cam" for _, m in peer.clouds)):
        fail("no deformed cloud for the cloud sent on /camera/points")
    first = len(peer.clouds)
    peer.spin(2.0)
    stamps = [stamp(m.header) for _, m in peer.clouds[first:] if m.header.frame_id == "cam"]
    rate = (len(stamps) - 1) / ((stamps[-1] - stamps[0]) / 1e9)
    if not 27.0 <= rate <= 33.0:
        fail(f"deformed clouds at {rate:.2f} Hz, expected 30")
    if len(xyz(peer.clouds[-1][1])) != len(rest):
        fail("the deformed cloud lost points")
    print(f"ok: /cell/skin/deformed_points at {rate:.2f} Hz")


def check_rosout(peer, rest):
    sent = time.time()
    peer.cloud_pub.publish(cloud_of(rest, "flat", with_z=False))

    def refused():
        return any(m.level == 40 and m.name == "/cell/skin" and "`z`" in m.msg and t >= sent
                   for t, m in peer.logs)
    if not peer.spin(2.0, refused):
        fail(f"no ERROR on /rosout within 2 s: {[(m.level, m.name, m.msg) for _, m in peer.logs][-5:]}")
    print("ok: the cloud without z was refused on /rosout at ERROR within 2 s")


def check_diagnostics(peer):
    peer.spin(3.0)
    ours = [(t, a) for t, a in peer.diags if any(s.name == "physskin: /cell/skin" for s in a.status)]
    if len(ours) < 2:
        fail(f"{len(ours)} diagnostics from /cell/skin in 3 s")
    gaps = [b[0] - a[0] for a, b in zip(ours, ours[1:])]
    status = next(s for s in ours[-1][1].status if s.name == "physskin: /cell/skin")
    keys = {v.key for v in status.values}
    need = {"objects", "awake_objects", "missed_ticks", "step_ms_p50", "step_ms_p99",
            "builds_queued", "recording_path", "recording_bytes", "recording_dropped"}
    if max(gaps) > 2.0 or not need <= keys:
        fail(f"diagnostics gaps {gaps}, keys {keys}")
    print(f"ok: /diagnostics every {max(gaps):.2f} s at most, with {sorted(need)}")


def check_markers(peer):
    # Markers are subscribed to only now: rclpy decodes each point as a Python object, and the
    # cloud's surface markers would slow the peer down.
    peer.node.create_subscription(MarkerArray, "/cell/skin/markers",
                                  lambda m: peer.markers.extend(m.markers), RELIABLE)
    peer.mesh_pub.publish(box_mesh())

    def matched():
        adds = [m for m in peer.markers if m.ns == "world" and m.action == Marker.ADD]
        clouds = {stamp(m.header): m for _, m in peer.clouds if m.header.frame_id == "world"}
        for marker in adds:
            cloud = clouds.get(stamp(marker.header))
            if cloud is not None:
                return marker, cloud
        return None
    if not peer.spin(30, lambda: matched() is not None):
        fail(f"no marker of the box with a deformed cloud of the same stamp ({len(peer.markers)} markers)")
    marker, cloud = matched()
    if marker.type != Marker.TRIANGLE_LIST or len(marker.points) != 36 or len(marker.colors) != 36:
        fail(f"marker type {marker.type}, {len(marker.points)} points")
    vertices = xyz(cloud)
    mesh = box_mesh()
    expected = np.array([vertices[i] for t in mesh.triangles for i in t.vertex_indices])
    got = np.array([[p.x, p.y, p.z] for p in marker.points])
    error = np.abs(got - expected).max()
    if error > 1e-5:
        fail(f"marker points differ from the deformed vertices by {error}")
    print(f"ok: the box's TRIANGLE_LIST has 36 points, within {error:.1e} m of the deformed vertices")


def check_reset(peer, rest):
    answer = peer.call(Trigger, "/cell/skin/reset", Trigger.Request())
    if not answer.success or "stamped" not in answer.message:
        fail(f"reset answered {answer}")
    sec, nsec = answer.message.rsplit("stamped ", 1)[1].split(".")
    at = int(sec) * 1_000_000_000 + int(nsec)
    found = lambda: [m for _, m in peer.clouds if m.header.frame_id == "cam" and stamp(m.header) >= at]
    if not peer.spin(5, lambda: len(found()) > 0):
        fail("no deformed cloud after the reset")
    first = min(found(), key=lambda m: stamp(m.header))
    error = np.abs(xyz(first) - rest).max()
    if stamp(first.header) != at or error > 1e-4:
        fail(f"the first cloud after reset is {error} m from rest (stamp {stamp(first.header)} vs {at})")
    print(f"ok: after ~/reset the next deformed cloud is the rest state (within {error:.1e} m)")


def check_clear(peer):
    answer = peer.call(Trigger, "/cell/skin/clear", Trigger.Request())
    answered = time.time()
    if not answer.success:
        fail(f"clear answered {answer}")
    peer.spin(1.2)
    # By stamp (the node's clock is this host's): a cloud published before the answer may
    # still be on its way, or in this peer's queue, after it.
    late = [m for _, m in peer.clouds
            if m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 > answered]
    if late:
        fail(f"{len(late)} deformed clouds stamped after ~/clear was answered")
    deleted = any(m.ns == "world" and m.action == Marker.DELETE for m in peer.markers)
    if not deleted:
        fail("no DELETE marker after ~/clear")
    print(f"ok: ~/clear ({answer.message}): no deformed cloud for 1 s, markers deleted")


def main():
    rclpy.init()
    peer = Peer()
    rest = box_points(2000, np.random.default_rng(3))
    check_names_and_parameters(peer)
    check_rate(peer, rest)
    check_rosout(peer, rest)
    check_diagnostics(peer)
    check_markers(peer)
    check_reset(peer, rest)
    check_clear(peer)
    if peer.clouds2:
        fail(f"/cell2/skin published {len(peer.clouds2)} deformed clouds of /cell's inputs")
    print("ok: /cell2/skin heard nothing of /cell")
    print("ok: graph", flush=True)
    rclpy.shutdown()


if __name__ == "__main__":
    main()
