"""Starts the physskin node in a robot's graph: `ros2 launch physskin.launch.py` (with
launch_ros installed), or `python3 physskin.launch.py` through `launch`'s own runner.

launch_ros runs the executable as
    physskin node --ros-args -r __node:=skin -r __ns:=/cell
        --params-file /tmp/launch_params_XXXX --params-file config/physskin.yaml
        -r ~/points:=/camera/depth/color/points
i.e. the node's name and namespace, the parameter dict written to a temporary file (keyed by
/cell/skin), the parameter file, and the remappings. The node takes exactly that command line.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

HERE = os.path.dirname(os.path.abspath(__file__))


def generate_launch_description():
    namespace = LaunchConfiguration("namespace")
    cloud = LaunchConfiguration("cloud_topic")
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="/cell"),
        DeclareLaunchArgument("cloud_topic", default_value="/camera/depth/color/points"),
        DeclareLaunchArgument("physskin", default_value="physskin",
                              description="the physskin executable (cargo install --path .)"),
        Node(
            executable=LaunchConfiguration("physskin"),
            arguments=["node"],
            name="skin",
            namespace=namespace,
            output="screen",
            parameters=[
                os.path.join(HERE, "..", "physskin.yaml"),
                {
                    # Simulate in the robot's world frame: clouds from the camera's optical
                    # frame are transformed by tf2 at their stamp; gravity is world -z.
                    "fixed_frame": "world",
                    "simulation.support": "floor",
                    # Friction on the floor and the robot's links (robot_description): a
                    # gripper holds what it closes on.
                    "simulation.friction": 0.5,
                    "floor_z": 0.0,
                    "object_timeout_s": 2.0,
                    "markers.rate_hz": 15.0,
                },
            ],
            remappings=[("~/points", cloud)],
        ),
    ])
