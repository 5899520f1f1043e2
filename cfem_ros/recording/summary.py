# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording's summary, read without reading its messages.

``read_summary(path)`` reads the summary section at the end of an MCAP file
(schemas, channels, statistics, chunk indexes), the metadata records it
indexes, and the messages of the ``events`` topics only (through the chunk
indexes): seconds and little memory for a file of any size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import json

from cfem_ros.core.engine.events import Event
from cfem_ros.recording import schema
from cfem_ros.recording.errors import RecordingError
from cfem_ros.recording.reader import open_mcap


@dataclass
class Summary:
    """
    What a recording's summary says.

    Attributes
    ----------
    path : str
    topics : dict of str to (str, int)
        Message type and message count of every topic.
    message_count, chunk_count : int
    start_ns, end_ns : int
        Log times of the first and last message.
    metadata : dict of str to dict
        Metadata records by name.
    events : list of dict
        The decoded JSON of the ``<namespace>/events`` messages, in log time order.

    """

    path: str
    topics: dict
    message_count: int
    chunk_count: int
    start_ns: int
    end_ns: int
    metadata: dict = field(default_factory=dict)
    events: list = field(default_factory=list)


def read_summary(path: str) -> Summary:
    """
    Read a finished recording's summary, metadata and events.

    Raises
    ------
    RecordingError
        If the file is missing, not MCAP, truncated (with the advice to run
        ``cfem-sim recover``) or has no summary.

    """
    with open_mcap(path, whole=False) as reader:   # seconds for a file of any size
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            raise RecordingError(
                f'{path}: MCAP file without a summary or statistics; expected a finished '
                f'recording (`cfem-sim recover {path} -o FIXED.mcap` writes one)')
        stats = summary.statistics
        topics = {}
        for channel in summary.channels.values():
            kind = summary.schemas.get(channel.schema_id)
            topics[channel.topic] = (kind.name if kind else '?',
                                     stats.channel_message_counts.get(channel.id, 0))
        metadata = {record.name: dict(record.metadata)
                    for record in reader.iter_metadata()}
        events = []
        wanted = [t for t in topics if schema.EVENTS.pattern.match(t)]
        if wanted:
            for _, _, message in reader.iter_messages(topics=wanted, log_time_order=True):
                events.append(_event(message.data))
    return Summary(path=path, topics=topics, message_count=stats.message_count,
                   chunk_count=stats.chunk_count, start_ns=stats.message_start_time,
                   end_ns=stats.message_end_time, metadata=metadata, events=events)


def _event(data: bytes) -> dict:
    """Decode a std_msgs/String event: CDR header, uint32 length, text, NUL."""
    try:
        length = int.from_bytes(data[4:8], 'little')
        event = json.loads(data[8:8 + length].rstrip(b'\0').decode())
    except (ValueError, UnicodeDecodeError):
        return {'event': Event.UNPARSED, 'data': repr(data)}
    return event if isinstance(event, dict) else {'event': event}
