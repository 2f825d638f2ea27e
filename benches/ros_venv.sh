# Sourced by the benches that drive the node from rclpy: makes target/ros-venv (rclpy with
# Fast DDS from pip) if it is missing, and builds the release binary. Run from the repository
# root; sets `venv`.
venv=target/ros-venv
if ! "$venv/bin/python" -c "import rclpy, sensor_msgs.msg, numpy" 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q ros-rclpy ros-rmw-fastrtps-cpp ros-sensor-msgs ros-std-msgs numpy
fi
cargo build --release --locked
