"""A real ROS 2 peer (rclpy, Fast DDS): publishes a PointCloud2 and a Mesh to the physskin node
and checks the deformed cloud and the weights cloud it answers with. Exit 0 on success."""
import struct
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from sensor_msgs.msg import PointCloud2, PointField
from shape_msgs.msg import Mesh, MeshTriangle
from geometry_msgs.msg import Point


def box_cloud(n, frame):
    """n points on the surface of a 0.6 x 0.2 x 0.2 m box, as float64 z, padding, float32 x, y,
    big-endian: a layout no physskin code produced."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 1, size=(n, 3))
    axis = rng.integers(0, 3, size=n)
    pts[np.arange(n), axis] = np.sign(pts[np.arange(n), axis])
    pts *= np.array([0.3, 0.1, 0.1])
    pts[:, 2] += 0.1
    msg = PointCloud2()
    msg.header.frame_id = frame
    msg.height, msg.width = 1, n
    msg.fields = [
        PointField(name="z", offset=0, datatype=PointField.FLOAT64, count=1),
        PointField(name="x", offset=12, datatype=PointField.FLOAT32, count=1),
        PointField(name="y", offset=16, datatype=PointField.FLOAT32, count=1),
    ]
    msg.is_bigendian = True
    msg.point_step, msg.row_step = 20, 20 * n
    data = bytearray()
    for x, y, z in pts:
        data += struct.pack(">d4xff", z, x, y)
    msg.data = bytes(data)
    msg.is_dense = True
    return pts, msg


def box_mesh():
    m = Mesh()
    corners = [(x, y, z) for x in (-0.2, 0.2) for y in (-0.1, 0.1) for z in (0.0, 0.2)]
    m.vertices = [Point(x=x, y=y, z=z) for x, y, z in corners]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    m.triangles = [MeshTriangle(vertex_indices=list(f)) for f in faces]
    return m


def read_xyz(cloud):
    """x, y, z by name, in each field's precision and the cloud's byte order (the node answers
    in the layout it was sent)."""
    names = {f.name: f for f in cloud.fields}
    arr = np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)
    order = ">" if cloud.is_bigendian else "<"

    def column(f):
        size, kind = {PointField.FLOAT32: (4, "f4"), PointField.FLOAT64: (8, "f8")}[f.datatype]
        return arr[:, f.offset:f.offset + size].copy().view(order + kind).ravel()
    cols = [column(names[a]) for a in "xyz"]
    return np.stack(cols, axis=1), names, arr


def main():
    rclpy.init()
    node = rclpy.create_node("physskin_peer")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
    got = {"deformed": {}, "weights": {}}
    node.create_subscription(PointCloud2, "/physskin/deformed_points",
                             lambda m: got["deformed"].setdefault(m.header.frame_id, []).append(m), reliable)
    node.create_subscription(PointCloud2, "/physskin/weights_cloud",
                             lambda m: got["weights"].__setitem__(m.header.frame_id, m), reliable)
    cloud_pub = node.create_publisher(PointCloud2, "/physskin/points", sensor)
    # Meshes are one-shot data: the node reads them reliable and transient local.
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    mesh_pub = node.create_publisher(Mesh, "/physskin/mesh", latched)
    n = 3000
    pts, cloud = box_cloud(n, "peer_cloud")
    deadline = time.time() + 60
    while time.time() < deadline:
        if cloud_pub.get_subscription_count() and mesh_pub.get_subscription_count():
            break
        rclpy.spin_once(node, timeout_sec=0.1)
    else:
        sys.exit("the physskin node never subscribed")
    # Repeats are harmless: identical geometry is not rebuilt.
    last_sent = 0
    while time.time() < deadline:
        if time.time() - last_sent > 1.0:
            cloud_pub.publish(cloud)
            mesh_pub.publish(box_mesh())
            last_sent = time.time()
        rclpy.spin_once(node, timeout_sec=0.05)
        if (len(got["deformed"].get("peer_cloud", [])) >= 30 and "peer_cloud" in got["weights"]
                and got["deformed"].get("world") and "world" in got["weights"]):
            break
    else:
        sys.exit(f"missing answers: deformed {list(got['deformed'])}, weights {list(got['weights'])}")

    frames = got["deformed"]["peer_cloud"]
    # The answer keeps the input's layout: float64 z, padding, float32 x, y, big-endian.
    assert [(f.name, f.offset, f.datatype) for f in frames[0].fields] == \
        [(f.name, f.offset, f.datatype) for f in cloud.fields], frames[0].fields
    assert frames[0].is_bigendian and frames[0].point_step == 20
    first, last = read_xyz(frames[0])[0], read_xyz(frames[-1])[0]
    assert first.shape == (n, 3), first.shape
    # The deformed cloud keeps the input's order: it starts at the input points...
    err0 = np.abs(first - pts).max()
    assert err0 < 0.05, f"first deformed frame is {err0} m from the input"
    # ...and moves under gravity, by a plausible amount, with no NaN.
    assert np.isfinite(last).all()
    moved = np.abs(last - pts).max()
    assert 1e-5 < moved < 0.3, f"max displacement {moved} m"
    w_cloud = got["weights"]["peer_cloud"]
    xyz, names, arr = read_xyz(w_cloud)
    handles = [k for k in names if k.startswith("w")]
    assert len(handles) >= 2, names
    w = np.stack([arr[:, names[h].offset:names[h].offset + 4].copy().view("<f4").ravel()
                  for h in sorted(handles, key=lambda h: int(h[1:]))], axis=1)
    assert w.shape == (n, len(handles))
    assert np.allclose(w[:, 0], 1.0), "w0 is the rigid handle, 1 everywhere"
    assert np.isfinite(w).all() and w[:, 1:].std() > 1e-3, "the other handles vary over the shape"
    assert np.abs(xyz - pts).max() < 1e-5, "the weights cloud carries the rest points"
    mesh_frames = got["deformed"]["world"]
    assert read_xyz(mesh_frames[-1])[0].shape == (8, 3)
    # Bad clouds from a publisher nobody here wrote: a cloud without z, and one whose data is
    # shorter than its layout says. The node refuses them (the Rust side reads its log) and
    # keeps publishing the good object.
    _, bad = box_cloud(50, "peer_bad")
    bad.fields = [f for f in bad.fields if f.name != "z"]
    cloud_pub.publish(bad)
    _, short = box_cloud(50, "peer_short")
    short.data = short.data[:-7]
    cloud_pub.publish(short)
    before = len(got["deformed"]["peer_cloud"])
    while time.time() < deadline and len(got["deformed"]["peer_cloud"]) < before + 30:
        rclpy.spin_once(node, timeout_sec=0.05)
    after = len(got["deformed"]["peer_cloud"]) - before
    assert after >= 30, f"only {after} deformed clouds after the bad inputs"
    assert np.isfinite(read_xyz(got["deformed"]["peer_cloud"][-1])[0]).all()
    assert "peer_bad" not in got["deformed"] and "peer_short" not in got["deformed"]
    params = check_parameters(node)
    print(f"ok: {len(frames)} deformed clouds, max displacement {moved:.4f} m, "
          f"{len(handles)} handles, mesh {len(mesh_frames)} frames, parameters: {params}")
    node.destroy_node()
    rclpy.shutdown()


def check_parameters(node):
    """What `ros2 param get/set` do, through rclpy's parameter client."""
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    client = AsyncParameterClient(node, "/physskin")
    if not client.wait_for_services(timeout_sec=20.0):
        sys.exit("the node's parameter services did not appear")

    def wait(future):
        rclpy.spin_until_future_complete(node, future, timeout_sec=20.0)
        if not future.done():
            sys.exit("a parameter service did not answer")
        return future.result()

    names = wait(client.list_parameters()).result.names
    for name in ["material.young", "rate_hz", "topics.points", "simulation.support"]:
        assert name in names, f"{name} not declared: {names}"
    young = wait(client.get_parameters(["material.young"])).values[0].double_value
    assert young == 2e5, f"material.young is {young}"
    ok = wait(client.set_parameters([Parameter("material.young", value=3e5)])).results[0]
    assert ok.successful, f"setting material.young refused: {ok.reason}"
    young = wait(client.get_parameters(["material.young"])).values[0].double_value
    assert young == 3e5, f"material.young is {young} after the set"
    bad = wait(client.set_parameters([Parameter("material.young", value="soft")])).results[0]
    assert not bad.successful, "a string was accepted for material.young"
    ro = wait(client.set_parameters([Parameter("rate_hz", value=30.0)])).results[0]
    assert not ro.successful and "read-only" in ro.reason, f"rate_hz: {ro.successful} {ro.reason}"
    return f"{len(names)} declared, set/get ok, bad type and read-only refused ({ro.reason!r})"


if __name__ == "__main__":
    main()
