"""Subscribes to physskin's deformed points over iceoryx2 (pip's iceoryx2 bindings) and checks
the frames it reads in place.

Usage: shm_peer.py SERVICE     (e.g. physskin/deformed_points)

Waits up to 20 s for 60 frames of the demo replay; checks the header against the payload
(3 floats per point, finite), the demo's shapes (3000, 1760, 1056 points, 17 handles) and
increasing sequence numbers. Prints "ok: ..." or exits non-zero naming the problem.
"""

import ctypes
import sys
import time

import iceoryx2 as iox2
import numpy as np


class FrameHeader(ctypes.Structure):
    """physskin::shm::FrameHeader, #[repr(C)]."""

    _fields_ = [
        ("shape_id", ctypes.c_uint32),
        ("point_count", ctypes.c_uint32),
        ("handle_count", ctypes.c_uint32),
        ("kind", ctypes.c_uint32),
        ("stamp_ns", ctypes.c_int64),
        ("sequence", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "PhysskinFrameHeader"


def main():
    name = sys.argv[1]
    node = iox2.NodeBuilder.new().create(iox2.ServiceType.Ipc)
    service = (
        node.service_builder(iox2.ServiceName.new(name))
        .publish_subscribe(iox2.Slice[ctypes.c_float])
        .user_header(FrameHeader)
        .history_size(1)
        .subscriber_max_buffer_size(64)  # physskin::shm::SUBSCRIBER_BUFFER
        .max_publishers(4)
        .max_subscribers(8)  # physskin::shm::MAX_SUBSCRIBERS
        .open_or_create()
    )
    subscriber = service.subscriber_builder().create()
    frames, points, sequences = 0, {}, []
    deadline = time.time() + 20
    while frames < 60 and time.time() < deadline:
        sample = subscriber.receive()
        if sample is None:
            time.sleep(0.001)
            continue
        header = sample.user_header().contents
        # iceoryx2's own header counts the slice's elements. (The Python binding 0.10.0's
        # Slice.len() gives the payload's size in bytes for this service instead.)
        count = sample.header.number_of_elements
        view = (ctypes.c_float * count).from_address(sample.payload().as_ptr())
        xyz = np.frombuffer(view, dtype=np.float32)  # the publisher's memory, not a copy
        if header.kind != 0:
            sys.exit(f"kind {header.kind} on the deformed points service")
        if xyz.size != 3 * header.point_count:
            sys.exit(f"{xyz.size} floats for {header.point_count} points")
        if not np.isfinite(xyz).all():
            sys.exit("a non-finite coordinate")
        if header.handle_count != 17:
            sys.exit(f"{header.handle_count} handles")
        points[header.shape_id] = header.point_count
        sequences.append(header.sequence)
        frames += 1
        del sample
    if frames < 60:
        sys.exit(f"only {frames} frames in 20 s")
    if any(b <= a for a, b in zip(sequences, sequences[1:])):
        sys.exit("sequence numbers do not increase")
    if sorted(points.values()) != sorted([3000, 1760, 1056][: len(points)]):
        sys.exit(f"unexpected shapes {points}")
    print(f"ok: {frames} frames, shapes {points}, sequences {sequences[0]}..{sequences[-1]}")


if __name__ == "__main__":
    main()
