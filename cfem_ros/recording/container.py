# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The MCAP container of a recording (SPEC section 4), without rclpy.

``Recorder`` writes one file in the ros2 profile: schemas, channels with
their offered QoS, messages (dicts encoded by ``mcap_ros2``, or samples as
``SampleLayout`` rows), chunks, statistics and indexes (``ChunkedWriter``),
and its lifecycle: atomic writing, finishing, keeping what is complete
when a write fails. What a simulator's state becomes as messages is
``recorder.StateRecorder``'s.
"""

from __future__ import annotations

import functools
import os
from typing import Optional

from cfem_ros import __version__
from cfem_ros.recording.chunks import CHUNK_SIZE, ChunkedWriter, signals_held
from cfem_ros.recording.errors import OutputError, RecordingError
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.outputs import output_problem
from cfem_ros.recording.samplelayout import SampleLayout
from cfem_ros.recording.schema import EVENTS_QOS, LATCHED_QOS, OUTPUT_QOS, Qos
import mcap
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np


@functools.lru_cache(maxsize=None)
def offered_qos(qos: Qos) -> str:
    """
    Return the ``offered_qos_profiles`` text of a channel offered with qos.

    In the integer form rosbag2 writes and every distro's ``ros2 bag play``
    reads (rmw enums: history 1 keep last, reliability 1 reliable,
    durability 2 volatile / 1 transient local, liveliness 1 automatic;
    durations {sec, nsec}, 0 0 being rmw's default, i.e. infinite, which
    also fits the uint32 older distros parse).
    """
    return ('- history: 1\n'
            f'  depth: {qos.depth}\n'
            '  reliability: 1\n'
            f'  durability: {1 if qos.latched else 2}\n'
            '  deadline:\n    sec: 0\n    nsec: 0\n'
            '  lifespan:\n    sec: 0\n    nsec: 0\n'
            '  liveliness: 1\n'
            '  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n'
            '  avoid_ros_namespace_conventions: false')


#: What the node offers on most topics: reliable, volatile, keep last 10.
OFFERED_QOS = offered_qos(OUTPUT_QOS)
#: What the node offers on its events topic: transient local, keep last 100,
#: so that a late subscriber asking for it still gets the releases.
EVENTS_OFFERED_QOS = offered_qos(EVENTS_QOS)
#: Latched topics (/tf_static, markers): transient local, keep last 1.
LATCHED_OFFERED_QOS = offered_qos(LATCHED_QOS)


def partial_path(path: str) -> str:
    """Return where an atomic recording of path is written: ``.NAME.partial-<pid>`` beside it."""
    directory, name = os.path.split(path)
    return os.path.join(directory, f'.{name}.partial-{os.getpid()}')


class Recorder:
    """
    Write one MCAP file in the ros2 profile.

    Messages given as dicts are encoded with ``mcap_ros2``; the messages of
    a sample (fixed-size CDR, see ``SampleLayout``) are kept as rows of
    numbers and turned into Message records a chunk at a time. The file is
    complete (summary, statistics, indexes) once ``finish`` has run; use
    the recorder as a context manager so that it runs on errors too. Every
    closed chunk is on disk, so a hard kill loses at most the chunk in
    progress (``CHUNK_SIZE``) of samples given one at a time
    (``add_sample``), and at most ``BATCH_CHUNKS`` chunks of samples given
    many at a time (``free_rows``, ``commit_rows``).

    Parameters
    ----------
    path : str
        The ``.mcap`` file to write.
    overwrite : bool
        Replace an existing file; without it an existing file is an error.
    metadata : dict of str to str, optional
        Written as an MCAP metadata record named ``cfem_ros``.
    atomic : bool
        Write to ``partial_path(path)`` (same folder) and move it onto path
        once finished: an existing file is untouched until then, and a hard
        kill leaves the partial file under that name.

    """

    def __init__(self, path: str, *, overwrite: bool = False,
                 metadata: Optional[dict] = None, atomic: bool = False):
        self.path = path
        self.overwrite = overwrite
        #: Where the messages go until ``finish`` (path itself unless atomic).
        self.writing_path = partial_path(path) if atomic else path
        refused = output_problem(path, option='recording')
        if refused:
            raise RecordingError(refused)
        # the folder as written ('sub/..' needs sub), not normalised
        directory = os.path.dirname(path) or os.curdir
        try:
            os.makedirs(directory, exist_ok=True)
            if atomic and not overwrite and os.path.lexists(path):
                raise FileExistsError
            self._stream = open(self.writing_path, 'wb' if overwrite and not atomic else 'xb')
        except FileExistsError:
            if os.path.lexists(path):
                raise RecordingError(
                    f'{path}: already exists; pass --overwrite to replace it') from None
            raise RecordingError(f'{self.writing_path}: already exists (left by another run '
                                 'with the same process id?); remove it') from None
        except OSError as err:
            raise RecordingError(
                f'{self.writing_path}: cannot write ({err.strerror})') from err
        self._writer = ChunkedWriter(
            self._stream, profile='ros2', chunk_size=CHUNK_SIZE,
            library=f'cfem_ros {__version__}; mcap {mcap.__version__}')
        self._schemas = {}
        self._channels = {}
        self._pending = None    # the layout of the samples waiting in its buffer
        self._between = []   # messages to write among them (``commit_rows``)
        #: Messages written so far.
        self.message_count = 0
        self._finished = False
        if metadata:
            self.add_metadata(metadata)

    def add_metadata(self, metadata: dict):
        """Write a metadata record named ``cfem_ros`` (values as strings)."""
        self._flush_samples()
        self._writer.add_metadata('cfem_ros', {k: str(v) for k, v in metadata.items()})

    def channel(self, topic: str, msgtype: str, qos: str = OFFERED_QOS) -> int:
        """Register a topic's channel once, with its offered QoS; return its id."""
        channel = self._channels.get(topic)
        if channel is not None:
            return channel
        if msgtype not in self._schemas:
            text = DEFINITIONS[msgtype]
            self._schemas[msgtype] = self._writer.register_schema(
                name=msgtype, encoding='ros2msg', data=text.encode())
        channel = self._writer.register_channel(
            topic=topic, message_encoding='cdr', schema_id=self._schemas[msgtype],
            metadata={'offered_qos_profiles': qos})
        self._channels[topic] = channel
        return channel

    def write(self, topic: str, msgtype: str, message, stamp_ns: int,
              qos: str = OFFERED_QOS):
        """
        Encode and write one message; log and publish time = stamp_ns.

        message: a dict, or its CDR bytes already encoded.
        """
        self._flush_samples()
        self._write(topic, msgtype, message, stamp_ns, qos)

    def _write(self, topic: str, msgtype: str, message, stamp_ns: int, qos: str):
        channel = self.channel(topic, msgtype, qos)
        data = message if isinstance(message, bytes) else encoder(msgtype)(message)
        self._writer.add_message(channel, int(stamp_ns), data,
                                 sequence=self.message_count, publish_time=int(stamp_ns))
        self.message_count += 1

    def layout(self, messages) -> 'SampleLayout':
        """
        Make the layout of a kind of sample (keep it: it holds the sample buffer).

        messages: (topic, msgtype, frame_id, number of float64) per message,
        in the order of a sample's values; or (topic, msgtype, frame_id,
        InBodyAxes) for numbers turned from others, or (topic, TF,
        TransformsOf, None) for poses among them; or (topic, TF,
        TransformsOf, derived) whose last ``computed`` poses derived
        computes from them (``viewframes.ViewFrames``: its ``size`` and
        ``numbers(block)``).
        """
        channels = [self.channel(topic, msgtype) for topic, msgtype, _, _ in messages]
        return SampleLayout(channels, [(frame, count) for _, _, frame, count in messages])

    def add_sample(self, layout: 'SampleLayout', stamp_ns: int,
                   values: Optional[np.ndarray] = None):
        """
        Write one sample: its messages all stamped stamp_ns.

        values holds their numbers; None if they were written into
        ``layout.next_row()`` already.
        """
        if self._pending is not layout:
            self._flush_samples()
            self._pending = layout
        if layout.append(stamp_ns, values):
            self._flush_samples()

    def free_rows(self, layout: 'SampleLayout') -> np.ndarray:
        """
        Return the free rows of the layout's buffer, for samples given to ``commit_rows``.

        There is room for ``BATCH_CHUNKS`` chunks of samples; they are
        written (as chunks of ``CHUNK_SIZE``) once the buffer is full, or
        when anything else is written or the file is finished.
        """
        if self._pending is not layout:
            self._flush_samples()
            self._pending = layout
        return layout.values[layout.count:]

    def commit_rows(self, layout: 'SampleLayout', stamps_ns: np.ndarray, between=()):
        """
        Write the samples in the first len(stamps_ns) free rows, stamped stamps_ns.

        between: (k, topic, msgtype, message, stamp_ns, qos) of messages
        written among them, before the k-th of these samples (k = their
        number: after the last), so that the file stays in time order.
        """
        if self._pending is not layout:
            raise ValueError('commit_rows: the rows were not taken from this layout last')
        self._between += [(layout.count + k, *rest) for k, *rest in between]
        if layout.extend(stamps_ns):
            self._flush_samples()

    def _flush_samples(self):
        if self._pending is None:
            return
        with signals_held():   # no handler sees half the samples written
            layout, self._pending = self._pending, None
            if not layout.count:
                return
            per = len(layout.channels)
            between, self._between = self._between, []
            cuts = sorted({k for k, *_ in between if k < layout.count} | {layout.count})
            counts = {}   # how many other messages come before sample k
            for k, *_ in between:
                counts[k] = counts.get(k, 0) + 1
            numbers = layout.numbers()
            size = layout.dtype.itemsize
            block = None   # (first sample, end, its records): encoded once, written in pieces
            start = 0
            for cut in cuts:
                first = start
                while first < cut:   # as many rows as fill the chunk in progress
                    rows = max(1, min(-(-self._writer.chunk_room() // size), layout.chunk_rows))
                    stop = min(first + rows, cut)
                    if block is None or not block[0] <= first < stop <= block[1]:
                        end = min(first + rows, layout.count)   # past the cut: the next pieces
                        shift = np.zeros(end - first, dtype=np.int64)
                        for k, count in counts.items():
                            if first < k < end:
                                shift[k - first:] += count
                        block = (first, end, layout.records(self.message_count, first, end,
                                                            numbers, shift))
                    records, channels, stamps, offsets = block[2]
                    a, b = first - block[0], stop - block[0]
                    self._writer.add_messages(records[size * a:size * b], channels, stamps[a:b],
                                              offsets[a:b] - size * a)
                    self.message_count += (stop - first) * per
                    first = stop
                for k, *message in between:
                    if k == cut or (cut == layout.count and k > cut):
                        self._write(*message)
                start = cut
            layout.count = 0

    def finish(self):
        """
        Write the summary and close the file (idempotent).

        An atomic recorder then moves the file onto its path (replacing an
        existing file only with ``overwrite``).
        """
        if self._finished:
            return
        self._finished = True
        with signals_held():
            try:
                self._flush_samples()
                self._writer.finish()
            except OSError as err:
                raise self.abandon(err) from err
            finally:
                self._stream.close()
            if self.writing_path != self.path:
                self._move_into_place()

    def _move_into_place(self):
        try:
            if self.overwrite:
                os.replace(self.writing_path, self.path)
                return
            try:
                os.link(self.writing_path, self.path)   # fails if path appeared meanwhile
            except FileExistsError:
                raise RecordingError(
                    f'{self.path}: appeared during the run; the recording is left in '
                    f'{self.writing_path}') from None
            except OSError:   # no hard links on this file system
                os.replace(self.writing_path, self.path)
                return
            os.unlink(self.writing_path)
        except OSError as err:
            raise RecordingError(f'{self.path}: cannot move {self.writing_path} there '
                                 f'({err.strerror}); the recording is left there') from err

    def __enter__(self) -> 'Recorder':
        return self

    def abandon(self, err: OSError) -> OutputError:
        """
        Give up a recording that cannot be written (a full disk): return the error to raise.

        An atomic recording's partial file is removed (an existing file at
        path is untouched); a direct one is cut back to its last whole chunk
        and finished there (``keep_complete``), or, if even the summary
        cannot be written, left cut there for ``cfem-sim recover``; removed
        if no whole chunk reached the disk.
        """
        self._finished = True
        try:
            self._stream.close()
        except OSError:
            pass   # what was still buffered is lost with the chunk in progress
        failure = f'{self.writing_path}: cannot write ({err.strerror or err})'
        if self.writing_path != self.path:
            try:
                os.unlink(self.writing_path)
            except OSError:
                pass
            kept = (f'the partial recording {self.writing_path} was removed'
                    + ('' if not os.path.lexists(self.path) else f'; {self.path} is untouched'))
            return OutputError(f'{failure} after {self.message_count} messages; {kept}')
        return keep_complete(self._writer, self.path, failure, self.message_count)

    def __exit__(self, exc_type, exc, traceback):
        if isinstance(exc, OSError) and not self._finished:   # a write failed (disk full)
            raise self.abandon(exc) from exc
        self.finish()


def keep_complete(writer: ChunkedWriter, path: str, failure: str, written: int) -> OutputError:
    """
    Cut a recording back to its last whole chunk and finish it there; say what is kept.

    writer: the recording's writer (its stream closed); written: the
    messages given to it. ``Recorder.abandon`` of a direct recording.
    """
    try:
        mark = writer.whole_part(os.path.getsize(path))
        if mark is None or not mark['statistics'].message_count:
            os.unlink(path)   # nothing to keep
            return OutputError(f'{failure} after {written} messages; no '
                               f'whole chunk of them reached the disk: {path} '
                               'was removed')
        offset, statistics = mark['offset'], mark['statistics']
        error = OutputError(failure, kept_messages=statistics.message_count,
                            kept_until_ns=statistics.message_end_time
                            if statistics.message_count else None)
        stream = open(path, 'r+b')
        try:
            stream.truncate(offset)
            stream.seek(offset)
            writer.finish_complete(stream, mark)   # flushed at its end
            stream.close()
            error.complete = True
        except OSError:
            try:
                stream.close()
            except OSError:
                pass   # the summary that did not fit
            os.truncate(path, offset)   # as a hard kill between two chunks leaves it
    except OSError as again:
        return OutputError(f'{failure}; the file {path} could not be cut back to its '
                           f'whole chunks either ({again.strerror or again}): '
                           f'`cfem-sim recover {path} -o FIXED.mcap` keeps them')
    kept = f'{statistics.message_count} of {written} messages'
    if error.complete:
        error.args = (f'{failure}; {path} is kept complete up to its last whole '
                      f'chunk ({kept}), a finished recording of the run so far',)
    else:
        error.args = (f'{failure}; {path} is kept cut after its last whole chunk '
                      f'({kept}) without a summary (no room for it): '
                      f'`cfem-sim recover {path} -o FIXED.mcap` makes it complete',)
    return error


@functools.lru_cache(maxsize=None)
def encoder(msgtype: str):
    """Return mcap_ros2's encoder of msgtype (a dict to CDR bytes), made once."""
    return serialize_dynamic(msgtype, DEFINITIONS[msgtype])[msgtype]
