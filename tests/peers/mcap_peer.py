"""Reads physskin's MCAP recordings with readers nobody here wrote and prints what they saw.

Usage: mcap_peer.py FILE.mcap [FILE.mcap ...]

For each file:
  * the official reader (mcap) with the ROS 2 decoder (mcap-ros2-support) decodes every message;
    the header profile must be "ros2", every channel "cdr" with an `offered_qos_profiles` that
    parses, every schema "ros2msg"; the summary must carry Statistics whose per-channel counts
    match what was decoded;
  * the `rosbag2` metadata record is parsed (its per-topic counts must match too), written out
    as metadata.yaml beside a link to the file, and rosbags' AnyReader opens that bag directory
    and deserializes every message.
Prints one JSON line per file: {"file", "mcap_counts", "rosbags_counts", "messages"}.
Exits non-zero, naming the problem, when anything fails.
"""

import json
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path

import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader


def fail(message):
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def check_file(path):
    counts = Counter()
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        if header.profile != "ros2":
            fail(f"{path}: profile {header.profile!r}, expected 'ros2'")
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            fail(f"{path}: no summary with statistics")
        for channel in summary.channels.values():
            if channel.message_encoding != "cdr":
                fail(f"{path}: channel {channel.topic} encoding {channel.message_encoding}")
            qos = yaml.safe_load(channel.metadata.get("offered_qos_profiles", ""))
            if not isinstance(qos, list) or "reliability" not in qos[0]:
                fail(f"{path}: channel {channel.topic} has no offered_qos_profiles list")
            schema = summary.schemas[channel.schema_id]
            if schema.encoding != "ros2msg":
                fail(f"{path}: schema {schema.name} encoding {schema.encoding}")
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            counts[channel.topic] += 1
            if channel.topic.endswith("/state"):
                if len(decoded.z) != 12 * decoded.handle_count:
                    fail(f"{path}: state z has {len(decoded.z)} numbers for {decoded.handle_count} handles")
            # Inputs are recorded as they came, bad ones too (the ROS 2 peer test sends one with
            # short data); what the node publishes must be well formed.
            if schema.name == "sensor_msgs/msg/PointCloud2" and not channel.topic.endswith("/points"):
                if len(decoded.data) != decoded.row_step * decoded.height:
                    fail(f"{path}: {channel.topic} data length != row_step * height")
        stats = summary.statistics
        by_channel = {summary.channels[c].topic: n for c, n in stats.channel_message_counts.items()}
        for topic, n in counts.items():
            if by_channel.get(topic, 0) != n:
                fail(f"{path}: statistics say {by_channel.get(topic)} on {topic}, decoded {n}")
        if stats.message_count != sum(counts.values()):
            fail(f"{path}: statistics message_count {stats.message_count} != {sum(counts.values())}")
        metadata = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        if len(metadata) != 1:
            fail(f"{path}: {len(metadata)} rosbag2 metadata records")
        bag_yaml = metadata[0].metadata["serialized_metadata"]
    info = yaml.safe_load(bag_yaml)["rosbag2_bagfile_information"]
    for entry in info["topics_with_message_count"]:
        topic = entry["topic_metadata"]["name"]
        if entry["message_count"] != counts.get(topic, 0):
            fail(f"{path}: rosbag2 metadata says {entry['message_count']} on {topic}, decoded {counts.get(topic, 0)}")

    # rosbags reads a rosbag2 directory: the metadata YAML beside the file it names.
    rosbags_counts = Counter()
    with tempfile.TemporaryDirectory() as bag_dir:
        name = info["relative_file_paths"][0]
        os.symlink(os.path.abspath(path), os.path.join(bag_dir, name))
        Path(bag_dir, "metadata.yaml").write_text(bag_yaml)
        with AnyReader([Path(bag_dir)]) as reader:
            for connection, _, raw in reader.messages():
                reader.deserialize(raw, connection.msgtype)
                rosbags_counts[connection.topic] += 1
    if rosbags_counts != counts:
        fail(f"{path}: rosbags counted {dict(rosbags_counts)}, mcap {dict(counts)}")
    print(json.dumps({
        "file": str(path),
        "mcap_counts": dict(counts),
        "rosbags_counts": dict(rosbags_counts),
        "messages": sum(counts.values()),
    }))


def main():
    if len(sys.argv) < 2:
        fail("usage: mcap_peer.py FILE.mcap [...]")
    for path in sys.argv[1:]:
        check_file(path)


if __name__ == "__main__":
    main()
