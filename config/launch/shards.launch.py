"""Starts N physskin nodes that split the objects among them: `ros2 launch shards.launch.py
instances:=3`. Node k (named skin_k, in one namespace) runs with `instances.shard: "k/N"`: it
takes the labelled objects whose id is k modulo N, and the frames whose name hashes to k
modulo N; together they simulate every object once, each publishing its own on
~/deformed_points. Every node hears the same camera topic.

launch_ros runs node k as
    physskin node --ros-args -r __node:=skin_k -r __ns:=/cell
        --params-file /tmp/launch_params_XXXX --params-file config/physskin.yaml
        -r ~/points:=/camera/depth/color/points
with `instances.shard: k/N` among the parameters written to the temporary file.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

HERE = os.path.dirname(os.path.abspath(__file__))


def instances(context):
    count = int(LaunchConfiguration("instances").perform(context))
    if count < 1:
        raise ValueError(f"instances:={count}: at least one")
    return [
        Node(
            executable=LaunchConfiguration("physskin"),
            arguments=["node"],
            name=f"skin_{k}",
            namespace=LaunchConfiguration("namespace"),
            output="screen",
            parameters=[
                os.path.join(HERE, "..", "physskin.yaml"),
                {
                    "instances.shard": f"{k}/{count}",
                    # One iceoryx2 service per instance: a service has one publisher.
                    "shm.deformed_service": f"physskin/skin_{k}/deformed_points",
                    "shm.weights_service": f"physskin/skin_{k}/weights",
                    "fixed_frame": "world",
                    "simulation.support": "floor",
                    "floor_z": 0.0,
                    "object_timeout_s": 2.0,
                },
            ],
            remappings=[("~/points", LaunchConfiguration("cloud_topic"))],
        )
        for k in range(count)
    ]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("instances", default_value="2"),
        DeclareLaunchArgument("namespace", default_value="/cell"),
        DeclareLaunchArgument("cloud_topic", default_value="/camera/depth/color/points"),
        DeclareLaunchArgument("physskin", default_value="physskin",
                              description="the physskin executable (cargo install --path .)"),
        OpaqueFunction(function=instances),
    ])
