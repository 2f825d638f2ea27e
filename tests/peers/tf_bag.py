"""tf2 through the node's pipeline, with software nobody here wrote.

`tf_bag.py write OUT`: the official MCAP writer (mcap-ros2-support) writes /tf_static with
world -> camera_optical_frame (the camera 0.5 m up, looking along world +x, REP 103 optical
axes) and a box cloud 1 m in front of the camera, in the optical frame.
`tf_bag.py check REPLAYED`: the official reader reads what `physskin replay` made of it with
fixed_frame world and support free: the box falls along world -z, not towards the camera."""

import sys

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer

HEADER = """builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec"""

TF_MESSAGE = f"""geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
Transform transform
================================================================================
MSG: geometry_msgs/Transform
Vector3 translation
Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
================================================================================
MSG: std_msgs/Header
{HEADER}"""

POINT_CLOUD2 = f"""std_msgs/Header header
uint32 height
uint32 width
PointField[] fields
bool is_bigendian
uint32 point_step
uint32 row_step
uint8[] data
bool is_dense
================================================================================
MSG: sensor_msgs/PointField
uint8 INT8=1
uint8 UINT8=2
uint8 INT16=3
uint8 UINT16=4
uint8 INT32=5
uint8 UINT32=6
uint8 FLOAT32=7
uint8 FLOAT64=8
string name
uint32 offset
uint8 datatype
uint32 count
================================================================================
MSG: std_msgs/Header
{HEADER}"""

G = 9.81
T0 = 1_000_000_000


def box_in_optical_frame():
    """A 0.2 x 0.1 x 0.1 m box (long along world x, i.e. optical z) 1 m ahead."""
    rng = np.random.default_rng(5)
    p = rng.uniform(-1, 1, size=(3000, 3))
    face = rng.integers(0, 3, size=len(p))
    p[np.arange(len(p)), face] = np.sign(p[np.arange(len(p)), face] + 1e-9)
    # Optical axes: x right (world -y), y down (world -z), z forward (world x).
    return p * np.array([0.05, 0.05, 0.1]) + np.array([0.0, 0.0, 1.0])


def write(path):
    with open(path, "wb") as f:
        writer = Writer(f)
        tf_schema = writer.register_msgdef("tf2_msgs/msg/TFMessage", TF_MESSAGE)
        cloud_schema = writer.register_msgdef("sensor_msgs/msg/PointCloud2", POINT_CLOUD2)
        transform = {
            "header": {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "world"},
            "child_frame_id": "camera_optical_frame",
            "transform": {"translation": {"x": 0.0, "y": 0.0, "z": 0.5},
                          "rotation": {"x": -0.5, "y": 0.5, "z": -0.5, "w": 0.5}},
        }
        writer.write_message("/tf_static", tf_schema, {"transforms": [transform]}, T0, T0)
        points = box_in_optical_frame().astype("<f4")
        cloud = {
            "header": {"stamp": {"sec": 1, "nanosec": 100_000_000},
                       "frame_id": "camera_optical_frame"},
            "height": 1, "width": len(points),
            "fields": [{"name": a, "offset": 4 * i, "datatype": 7, "count": 1}
                       for i, a in enumerate("xyz")],
            "is_bigendian": False, "point_step": 12, "row_step": 12 * len(points),
            "data": points.tobytes(), "is_dense": True,
        }
        at = T0 + 100_000_000
        writer.write_message("/physskin/points", cloud_schema, cloud, at, at)
        writer.finish()


def check(path):
    clouds = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            if channel.topic == "/physskin/deformed_points":
                pts = np.frombuffer(bytes(decoded.data), dtype="<f4").reshape(-1, 3)
                t = decoded.header.stamp.sec + decoded.header.stamp.nanosec / 1e9
                clouds.append((t, decoded.header.frame_id, pts.astype(np.float64)))
    if not clouds:
        sys.exit("FAIL: no deformed cloud in the replay")
    frames = {c[1] for c in clouds}
    if frames != {"world"}:
        sys.exit(f"FAIL: deformed clouds in frames {frames}, expected world")
    # The rest box in world: 1 m ahead of a camera 0.5 m up.
    rest = np.array([1.0, 0.0, 0.5])
    t_first = clouds[0][0]
    t, _, pts = min(clouds, key=lambda c: abs(c[0] - (t_first + 0.5)))
    elapsed = t - t_first
    centroid = pts.mean(axis=0)
    drop = rest[2] - centroid[2]
    lateral = np.abs(centroid[:2] - rest[:2]).max()
    need = 0.5 * G * elapsed ** 2 / 2
    print(f"after {elapsed:.3f} s: centroid {centroid}, fell {drop:.4f} m (need {need:.4f}), "
          f"lateral {lateral:.5f} m")
    if drop < need or lateral > 0.01 * drop:
        sys.exit("FAIL: the box did not fall along world -z")
    print("ok: tf2")


if __name__ == "__main__":
    {"write": write, "check": check}[sys.argv[1]](sys.argv[2])
