# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Read recordings twice, with two independent readers, for the tests.

The mcap reader (with mcap_ros2's decoder) and rosbags' own MCAP reader and
CDR deserializer must agree message by message.
"""

import pathlib

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import get_types_from_msg, get_typestore, Stores


def read_mcap(path):
    """Return header, summary and decoded messages with the mcap library."""
    with open(path, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        messages = [(channel.topic, message.log_time, message.publish_time, decoded)
                    for _, channel, message, decoded in reader.iter_decoded_messages()]
    return header, summary, messages


def read_rosbags(path):
    """Return (topic, time, message) with rosbags, types built from the file's schemas."""
    reader = McapReader(pathlib.Path(path))
    reader.open()
    try:
        store = get_typestore(Stores.EMPTY)
        for connection in reader.connections:
            parts = connection.msgdef.data.split('=' * 80 + '\n')
            types = get_types_from_msg(parts[0], connection.msgtype)
            for part in parts[1:]:
                name, text = part.split('\n', 1)
                types.update(get_types_from_msg(text, name.replace('MSG: ', '').strip()))
            store.register(types)
        messages = [(c.topic, t, store.deserialize_cdr(data, c.msgtype))
                    for c, t, data in reader.messages(reader.connections)]
        return messages, {c.msgtype for c in reader.connections}
    finally:
        reader.close()


def fields(message):
    """Flatten a decoded message of either library into comparable values."""
    if hasattr(message, 'data') and isinstance(message.data, str):
        return [message.data]
    if hasattr(message, 'transforms'):
        out = []
        for t in message.transforms:
            a, b = t.transform.translation, t.transform.rotation
            out += [t.header.stamp.sec, t.header.stamp.nanosec, t.header.frame_id,
                    t.child_frame_id, a.x, a.y, a.z, b.x, b.y, b.z, b.w]
        return out
    if hasattr(message, 'markers'):
        out = []
        for m in message.markers:
            p, q, s, c = m.pose.position, m.pose.orientation, m.scale, m.color
            out += [m.header.frame_id, m.ns, m.id, m.type, m.action, p.x, p.y, p.z, q.x, q.y,
                    q.z, q.w, s.x, s.y, s.z, c.r, c.g, c.b, c.a, m.frame_locked, m.text,
                    m.mesh_resource]
        return out
    header = [message.header.stamp.sec, message.header.stamp.nanosec, message.header.frame_id]
    if hasattr(message, 'child_frame_id'):   # nav_msgs/Odometry
        p, q = message.pose.pose.position, message.pose.pose.orientation
        v, w = message.twist.twist.linear, message.twist.twist.angular
        return header + [message.child_frame_id, p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y,
                         v.z, w.x, w.y, w.z, *map(float, message.pose.covariance),
                         *map(float, message.twist.covariance)]
    if hasattr(message, 'pose'):
        p, q = message.pose.position, message.pose.orientation
        return header + [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
    if hasattr(message, 'twist'):
        a, b = message.twist.linear, message.twist.angular
        return header + [a.x, a.y, a.z, b.x, b.y, b.z]
    if hasattr(message, 'vector'):   # Vector3Stamped (the air a body sees)
        v = message.vector
        return header + [v.x, v.y, v.z]
    a, b = message.wrench.force, message.wrench.torque
    return header + [a.x, a.y, a.z, b.x, b.y, b.z]


def read_checked(path):
    """Read a recording with both readers, assert they agree, return the mcap view."""
    header, summary, ours = read_mcap(path)
    theirs, _ = read_rosbags(path)
    assert len(ours) == len(theirs)
    for (topic, log_time, publish_time, a), (topic_b, time_b, b) in zip(ours, theirs):
        assert topic == topic_b and log_time == time_b == publish_time
        assert list(map(repr, fields(a))) == list(map(repr, fields(b)))
    return header, summary, ours


def top_records(data: bytes) -> list:
    """Walk an MCAP file's top-level records: (start, end) of each (a bad length ends it)."""
    out, position = [], 8
    while position + 9 <= len(data):
        length = int.from_bytes(data[position + 1:position + 9], 'little')
        if position + 9 + length > len(data):
            break
        out.append((position, position + 9 + length))
        position += 9 + length
    return out


def rewrite_zstd(source, target, chunk_size: int = 32 * 1024):
    """Write source's schemas, channels, metadata and messages again in zstd chunks."""
    from mcap.writer import CompressionType, Writer
    with open(source, 'rb') as stream, open(target, 'wb') as out:
        reader = make_reader(stream)
        writer = Writer(out, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start('ros2', 'test')
        summary = reader.get_summary()
        schemas = {sid: writer.register_schema(s.name, s.encoding, s.data)
                   for sid, s in summary.schemas.items()}
        channels = {cid: writer.register_channel(c.topic, c.message_encoding,
                                                 schemas[c.schema_id], dict(c.metadata))
                    for cid, c in summary.channels.items()}
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        for _, channel, message in reader.iter_messages():
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
        writer.finish()
