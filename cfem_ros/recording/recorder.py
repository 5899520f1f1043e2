# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
MCAP recordings in the ros2 profile (SPEC section 4), without rclpy.

``Recorder`` is the container layer (schemas, channels with their QoS,
messages, statistics and indexes through the ``mcap`` writer, CDR through
``mcap_ros2``); ``StateRecorder`` turns a simulator's arrays into the
messages of SPEC section 3.
"""

from __future__ import annotations

from dataclasses import dataclass
import functools
import json
import math
import os
import struct
from typing import Optional

from cfem_ros import __version__
from cfem_ros.core import rotations
from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.core.run.inputs import stamp_problem
from cfem_ros.recording import loadarrows, viewframes, visuals
from cfem_ros.recording.chunks import ChunkedWriter, message_record_fields, signals_held
from cfem_ros.recording.errors import OutputError, RecordingError
from cfem_ros.recording.markerbytes import MarkerArrayEncoder
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.outputs import output_problem
import mcap
from mcap.opcode import Opcode
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np

POSE = 'geometry_msgs/msg/PoseStamped'
TWIST = 'geometry_msgs/msg/TwistStamped'
WRENCH = 'geometry_msgs/msg/WrenchStamped'
VECTOR3 = 'geometry_msgs/msg/Vector3Stamped'
STRING = 'std_msgs/msg/String'
ODOMETRY = 'nav_msgs/msg/Odometry'
TF = 'tf2_msgs/msg/TFMessage'
MARKERS = 'visualization_msgs/msg/MarkerArray'

#: What the node offers, in the integer form rosbag2 writes and every
#: distro's ``ros2 bag play`` reads (rmw enums: history 1 keep last,
#: reliability 1 reliable, durability 2 volatile / 1 transient local,
#: liveliness 1 automatic; durations {sec, nsec}, 0 0 being rmw's default,
#: i.e. infinite, which also fits the uint32 older distros parse): reliable,
#: volatile, keep last 10.
OFFERED_QOS = (
    '- history: 1\n'
    '  depth: 10\n'
    '  reliability: 1\n'
    '  durability: 2\n'
    '  deadline:\n    sec: 0\n    nsec: 0\n'
    '  lifespan:\n    sec: 0\n    nsec: 0\n'
    '  liveliness: 1\n'
    '  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n'
    '  avoid_ros_namespace_conventions: false'
)
#: What the node offers on its events topic: transient local, keep last 100,
#: so that a late subscriber asking for it still gets the releases.
EVENTS_QOS = OFFERED_QOS.replace('depth: 10', 'depth: 100').replace(
    'durability: 2', 'durability: 1')

#: Latched topics (/tf_static, markers): transient local, keep last 1, as
#: tf2's static broadcaster offers them.
LATCHED_QOS = EVENTS_QOS.replace('depth: 100', 'depth: 1')

#: Chunk size in bytes: small, so that a hard kill loses little.
CHUNK_SIZE = 64 * 1024
#: Samples handed over a batch at a time (``Recorder.free_rows``) are
#: buffered for up to this many chunks before they are written: a batched
#: run comes back to Python once per batch, not once per chunk.
BATCH_CHUNKS = 16
#: builtin_interfaces/Time in CDR.
_STAMP = np.dtype([('sec', '<i4'), ('nanosec', '<u4')])
#: CDR encapsulation header: plain CDR, little endian.
CDR_LE = b'\x00\x01\x00\x00'


@dataclass(frozen=True)
class TransformsOf:
    """
    A sample's tf2_msgs/TFMessage: some bodies' poses as transforms from one frame.

    It takes no numbers of its own: each child's 7 (translation, rotation
    x y z w) are the sample's pose numbers starting at ``columns[j]``; the
    last ``computed`` children's are numbers computed from the sample (the
    layout entry's derived numbers, ``columns`` counting from their first).
    ``parent``: the frame of every child, or a tuple of one per child.
    """

    parent: object
    children: tuple
    columns: tuple
    computed: int = 0

    def parent_of(self, j: int) -> str:
        """Return the parent frame of child j."""
        return self.parent if isinstance(self.parent, str) else self.parent[j]


@dataclass(frozen=True)
class InBodyAxes:
    """
    A sample's force and moment turned from world axes into a body's axes.

    It takes no numbers of its own: the 6 numbers (force, moment) start at
    column ``first`` of the sample, the body's quaternion (x y z w, body to
    world) at column ``quaternion``.
    """

    first: int
    quaternion: int

    #: How many numbers it makes per sample.
    size = 6

    def numbers(self, block: np.ndarray) -> np.ndarray:
        """Return the force and moment of samples (k, columns) in the body's axes, (k, 6)."""
        return _in_body_axes(block, self)


def stamp(stamp_ns: int) -> dict:
    """builtin_interfaces/Time of integer nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return {'sec': sec, 'nanosec': nanosec}


def seconds_to_ns(t: float) -> int:
    """Integer nanoseconds nearest to t seconds."""
    return int(round(t * 1e9))


def run_metadata(model, scenario: str, rate_hz: float, start_ns: int, **extra) -> dict:
    """Describe a run for its ``cfem_ros`` metadata record (what it is, where t = 0 is)."""
    return {'scenario': os.path.abspath(scenario), 'name': model.name,
            'start_stamp_ns': int(start_ns), 'dt': repr(model.dt), 'rate_hz': repr(rate_hz),
            'frame_id': model.frame_id,
            'gravity': '[' + ', '.join(repr(float(g)) for g in model.gravity) + ']', **extra}


def partial_path(path: str) -> str:
    """Return where an atomic recording of path is written: ``.NAME.partial-<pid>`` beside it."""
    directory, name = os.path.split(path)
    return os.path.join(directory, f'.{name}.partial-{os.getpid()}')


def _vector(v) -> dict:
    return {'x': float(v[0]), 'y': float(v[1]), 'z': float(v[2])}


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
        and finished there (``_keep_complete``), or, if even the summary
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
        return self._keep_complete(failure)

    def _keep_complete(self, failure: str) -> OutputError:
        """Cut the file back to its last whole chunk and finish it there; say what is kept."""
        try:
            mark = self._writer.whole_part(os.path.getsize(self.path))
            if mark is None or not mark['statistics'].message_count:
                os.unlink(self.path)   # nothing to keep
                return OutputError(f'{failure} after {self.message_count} messages; no '
                                   f'whole chunk of them reached the disk: {self.path} '
                                   'was removed')
            offset, statistics = mark['offset'], mark['statistics']
            error = OutputError(failure, kept_messages=statistics.message_count,
                                kept_until_ns=statistics.message_end_time
                                if statistics.message_count else None)
            stream = open(self.path, 'r+b')
            try:
                stream.truncate(offset)
                stream.seek(offset)
                self._writer.finish_complete(stream, mark)   # flushed at its end
                stream.close()
                error.complete = True
            except OSError:
                try:
                    stream.close()
                except OSError:
                    pass   # the summary that did not fit
                os.truncate(self.path, offset)   # as a hard kill between two chunks leaves it
        except OSError as again:
            return OutputError(f'{failure}; the file {self.path} could not be cut back to its '
                               f'whole chunks either ({again.strerror or again}): '
                               f'`cfem-sim recover {self.path} -o FIXED.mcap` keeps them')
        kept = f'{statistics.message_count} of {self.message_count} messages'
        if error.complete:
            error.args = (f'{failure}; {self.path} is kept complete up to its last whole '
                          f'chunk ({kept}), a finished recording of the run so far',)
        else:
            error.args = (f'{failure}; {self.path} is kept cut after its last whole chunk '
                          f'({kept}) without a summary (no room for it): '
                          f'`cfem-sim recover {self.path} -o FIXED.mcap` makes it complete',)
        return error

    def __exit__(self, exc_type, exc, traceback):
        if isinstance(exc, OSError) and not self._finished:   # a write failed (disk full)
            raise self.abandon(exc) from exc
        self.finish()


class SampleLayout:
    """
    The messages of one kind of sample, all stamped messages of fixed size.

    A sample's numbers are buffered as a row; ``records`` turns up to a
    chunk's worth of rows (``chunk_rows``) into Message records (header,
    CDR: encapsulation 00 01 00 00, stamp, frame_id, padding to 8 bytes,
    the float64 values: the bytes ``mcap_ros2``'s encoder writes) with
    numpy, all at once. The buffer has room for ``BATCH_CHUNKS`` chunks:
    ``append`` (a sample at a time) reports it full after one chunk,
    ``extend`` (many samples at once) after all of them.

    Parameters
    ----------
    channels : list of int
        Channel of each message.
    messages : list of (str, int)
        frame_id and number of float64 of each message, whose numbers are
        the next columns of a sample; or (TransformsOf, None) for a
        TFMessage made of other messages' numbers; or (frame_id,
        InBodyAxes) for a wrench made of another message's numbers turned
        into a body's axes.

    """

    def __init__(self, channels, messages):
        self.channels = [int(c) for c in channels]
        self.dtype, self.columns, self.offsets, template, self.size, self.turned = \
            _layout_template(tuple(self.channels), tuple(
                (f, c) if isinstance(f, TransformsOf) else
                (str(f), c if isinstance(c, InBodyAxes) else int(c)) for f, c in messages))
        #: Samples whose records make a chunk.
        self.chunk_rows = len(template)
        capacity = BATCH_CHUNKS * self.chunk_rows
        self.stamps = np.empty(capacity, dtype=np.int64)
        self.values = np.empty((capacity, self.size))
        self._rows = list(self.values[:self.chunk_rows])   # the row views, made once
        self.count = 0
        self._records = template.copy()
        # the fields each sample changes, as views made once (making them is slow)
        self._fields = []
        for i, part in enumerate(self.columns):
            record = self._records[f'm{i}']
            self._fields.append((record['sequence'], record['times'], [
                (record['data'][stamp_field], record['data'][values_field])
                for (stamp_field, values_field), _ in part]))

    def next_row(self) -> np.ndarray:
        """Return the buffer row the next sample's numbers go to (filled by ``append``)."""
        return self._rows[self.count]

    def append(self, stamp_ns: int, values: Optional[np.ndarray] = None) -> bool:
        """Buffer one sample (values None: already in ``next_row()``); True at a chunk's worth."""
        self.stamps[self.count] = stamp_ns
        if values is not None:
            self.values[self.count] = values
        self.count += 1
        return self.count >= self.chunk_rows

    def extend(self, stamps_ns: np.ndarray) -> bool:
        """Buffer samples already in the next rows, stamped stamps_ns; True when full."""
        k = len(stamps_ns)
        if self.count + k > len(self.stamps):
            raise ValueError(f'{k} samples do not fit in {len(self.stamps) - self.count} rows')
        self.stamps[self.count:self.count + k] = stamps_ns
        self.count += k
        return self.count == len(self.stamps)

    def numbers(self, start: int = 0, stop: Optional[int] = None) -> np.ndarray:
        """Return the numbers of buffered samples start:stop, turned messages' included."""
        block = self.values[start:self.count if stop is None else stop]
        if not self.turned:
            return block
        return np.concatenate([block] + [t.numbers(block) for t in self.turned], axis=1)

    def records(self, first_sequence: int, start: int = 0, stop: Optional[int] = None,
                numbers: Optional[np.ndarray] = None, shift: Optional[np.ndarray] = None):
        """
        Return buffered samples start:stop (at most ``chunk_rows``) as Message records.

        numbers: ``numbers()`` of all the buffered samples, if already computed;
        shift: per sample, how many other messages come before it from
        first_sequence on (its sequence numbers move on by as many).
        Returns the records (bytes), the channels, the samples' log times and
        each message's offset in the records (samples, channels).
        """
        stop = self.count if stop is None else stop
        k, per = stop - start, len(self.channels)
        stamps = self.stamps[start:stop]
        block = self.numbers(start, stop) if numbers is None else numbers[start:stop]
        records = self._records[:k]
        stamp = np.empty(k, dtype=_STAMP)
        stamp['sec'], stamp['nanosec'] = np.divmod(stamps, 1_000_000_000)
        times = stamps[:, None]
        sequence = first_sequence + per * np.arange(k) + (0 if shift is None else shift)
        for i, (part, (seq, log, views)) in enumerate(zip(self.columns, self._fields)):
            seq[:k] = sequence + i
            log[:k] = times
            for ((_, (a, b)), (head, values)) in zip(part, views):
                head[:k] = stamp
                values[:k] = block[:, a:b]
        offsets = self.dtype.itemsize * np.arange(k)[:, None] + self.offsets
        return records.tobytes(), self.channels, stamps.copy(), offsets


@functools.lru_cache(maxsize=64)
def _layout_template(channels: tuple, messages: tuple):
    """
    Return the layout of a kind of sample's records, and a filled record buffer.

    That is: the record dtype, value columns, message offsets, the buffer,
    the number of a sample's columns and the ``InBodyAxes`` of turned messages.

    The buffer holds a chunk's worth of samples with every constant field
    set (opcode, length, channel, encapsulation, frame_id); kept per kind
    of sample, since building numpy's structured dtypes is most of a
    recording's fixed cost. The columns of message i are a list of
    ((stamp field, values field), (first, end column)), one per stamp of
    the message (a TFMessage has one per transform); a turned message's
    numbers are computed into columns after the sample's own.
    """
    fields, columns, constants, column = [], [], [], 0
    width = sum(c for f, c in messages if isinstance(c, int))
    turned = tuple(c for f, c in messages if c is not None and not isinstance(c, int))
    starts = width + np.cumsum([0] + [t.size for t in turned])   # where each one's go
    for i, (frame_id, count) in enumerate(messages):
        if isinstance(frame_id, TransformsOf):
            data, parts, constant = _transforms_template(frame_id)
            base = 0 if count is None else int(starts[turned.index(count)])
            own = len(frame_id.children) - frame_id.computed   # then the computed ones
            columns.append([(names, (first + base * (j >= own), first + base * (j >= own) + 7))
                            for j, (names, first) in enumerate(zip(parts, frame_id.columns))])
        elif isinstance(count, InBodyAxes):
            data, constant = _stamped_template(frame_id, 6)
            first = int(starts[turned.index(count)])
            columns.append([(('stamp', 'values'), (first, first + 6))])
        else:
            data, constant = _stamped_template(frame_id, count)
            columns.append([(('stamp', 'values'), (column, column + count))])
            column += count
        fields.append((f'm{i}', message_record_fields(np.dtype(data))))
        constants.append(constant)
    dtype = np.dtype(fields)
    capacity = max(1, -(-CHUNK_SIZE // dtype.itemsize))
    template = np.zeros(capacity, dtype=dtype)
    offsets = np.array([dtype.fields[f'm{i}'][1] for i in range(len(messages))])
    for i, constant in enumerate(constants):
        record = template[f'm{i}']
        record['opcode'] = Opcode.MESSAGE
        record['length'] = record.dtype.itemsize - 9
        record['channel'] = channels[i]
        for name, value in constant.items():
            record['data'][name] = np.void(value)
    template.flags.writeable = False
    return dtype, columns, offsets, template, width, turned


def _stamped_template(frame_id: str, count: int):
    """Return the CDR layout of a header and count float64: numpy fields, constants."""
    frame = _frame_bytes(frame_id)
    data = [('encapsulation', 'V4'), ('stamp', _STAMP), ('frame', f'V{len(frame)}')]
    pad = -(8 + len(frame)) % 8
    if pad:
        data.append(('pad', f'V{pad}'))
    data.append(('values', '<f8', (count,)))
    return data, {'encapsulation': CDR_LE, 'frame': frame}


@functools.lru_cache(maxsize=None)
def encoder(msgtype: str):
    """Return mcap_ros2's encoder of msgtype (a dict to CDR bytes), made once."""
    return serialize_dynamic(msgtype, DEFINITIONS[msgtype])[msgtype]


def _in_body_axes(block: np.ndarray, turned: InBodyAxes) -> np.ndarray:
    """Return the force and moment of samples (k, columns) in a body's axes, (k, 6)."""
    matrices = rotations.matrices(block[:, turned.quaternion:turned.quaternion + 4])
    out = np.empty((len(block), 6))
    for a in (0, 3):
        vector = block[:, turned.first + a:turned.first + a + 3]
        out[:, a:a + 3] = np.einsum('nji,nj->ni', matrices, vector)
    return out


def _transforms_template(transforms: TransformsOf):
    """
    Return the CDR layout of a TFMessage: numpy fields, (stamp, values) names, constants.

    The message is encoded once by ``mcap_ros2`` with marker numbers in
    its stamps and transforms; where those land gives the offsets of the
    fields a sample changes, and every other byte is constant.
    """
    encode = serialize_dynamic(TF, DEFINITIONS[TF])[TF]
    marks = [(0x5A000000 + j, 0x3B000000 + j,
              [1.0 + 2.0 ** -40 * (7 * j + c + 1) for c in range(7)])
             for j in range(len(transforms.children))]
    data = encode({'transforms': [
        {'header': {'stamp': {'sec': sec, 'nanosec': nanosec},
                    'frame_id': transforms.parent_of(j)},
         'child_frame_id': child,
         'transform': {'translation': dict(zip('xyz', values[:3])),
                       'rotation': dict(zip('xyzw', values[3:]))}}
        for j, (child, (sec, nanosec, values)) in enumerate(zip(transforms.children, marks))]})
    variable = []
    for j, (sec, nanosec, values) in enumerate(marks):
        at_stamp = data.index(struct.pack('<iI', sec, nanosec))
        at_values = data.index(struct.pack('<7d', *values))
        variable += [(at_stamp, f's{j}', _STAMP), (at_values, f'v{j}', np.dtype(('<f8', (7,))))]
    fields, constant, at = [], {}, 0
    for offset, name, kind in sorted(variable):
        if offset > at:
            fields.append((f'c{len(constant)}', f'V{offset - at}'))
            constant[f'c{len(constant)}'] = data[at:offset]
        fields.append((name, kind))
        at = offset + kind.itemsize
    if at < len(data):
        fields.append((f'c{len(constant)}', f'V{len(data) - at}'))
        constant[f'c{len(constant)}'] = data[at:]
    parts = [(f's{j}', f'v{j}') for j in range(len(marks))]
    return fields, parts, constant


def _periods(t: float, period: float) -> float:
    """Return t in periods, a sample on a multiple counting as there (t = 0.3, period 0.1: 3)."""
    return t / period + 1e-9


def _frame_bytes(frame_id: str) -> bytes:
    """CDR of a frame_id string: uint32 length with the NUL, the bytes, the NUL."""
    text = frame_id.encode() + b'\0'
    return struct.pack('<I', len(text)) + text


class StateRecorder:
    """
    Record a simulator's outputs and inputs as the node publishes them.

    Parameters
    ----------
    recorder : Recorder
    sim : Simulator
    namespace : str
        Prefix of every topic (SPEC section 3), '/cfem' by default.
    start_ns : int
        Stamp of simulated time 0, ns.

    """

    def __init__(self, recorder: Recorder, sim, namespace: str = '/cfem', start_ns: int = 0):
        self.recorder = recorder
        self.sim = sim
        self.namespace = namespace.rstrip('/')
        self.start_ns = int(start_ns)
        self.world = sim.model.frame_id
        model = sim.model
        self._pose_topics = [self.topic(f'bodies/{b.name}/pose') for b in model.bodies]
        self._twist_topics = [self.topic(f'bodies/{b.name}/twist') for b in model.bodies]
        self._wrench_topics = [self.topic(f'joints/{j.name}/wrench') for j in model.joints]
        self._events_written = 0
        self._layouts = {}   # active joints -> SampleLayout
        self._rows_layout = None   # the layout of the rows last handed out
        #: Samples recorded so far.
        self.samples = 0
        moving = [i for i, b in enumerate(model.bodies) if not b.fixed]
        self._transforms = TransformsOf(
            self.world, tuple(model.bodies[i].name for i in moving),
            tuple(13 * i for i in moving)) if moving else None
        # the carriers' z-up frames, computed from their poses, in the same message (a
        # viewer seeking shows the last /tf message before the time: it must hold all)
        self._views = viewframes.of_model(model)
        if self._views is not None:
            views = self._views
            self._transforms = TransformsOf(
                (self.world,) * len(moving) + (views.root,) * len(views.names),
                self._transforms.children + views.names,
                self._transforms.columns + tuple(7 * k for k in range(len(views.names))),
                computed=len(views.names))
        self._scene_written = False
        # the next sendings, counted in periods: the markers at 1, the arrows at 0
        self._markers_due, self._arrows_due = 1, 0
        self._marker_bytes = MarkerArrayEncoder(encoder(MARKERS))
        self._arrows = loadarrows.LoadArrows(model, self.namespace, sim.applied_sources)
        # sent with joints or applied loads, and from the first wrench input on
        self._arrows_on = bool(model.joints or sim.applied_sources)

    def topic(self, relative: str) -> str:
        """Absolute topic name of a topic relative to the namespace."""
        return f'{self.namespace}/{relative}'

    def stamp_ns(self, t: float) -> int:
        """Stamp of simulated time t, ns."""
        return self.start_ns + seconds_to_ns(t)

    def _scene(self):
        """Record the fixed bodies' frames and the markers, once, at t = 0."""
        self._scene_written = True
        when = self.stamp_ns(0.0)
        self.recorder.write('/tf_static', TF, visuals.static_transforms(
            self.sim.model, stamp(when)), when, qos=LATCHED_QOS)
        self._markers(when)

    def _markers_again(self, times) -> list:
        """
        Return the markers to send again among samples at these times (s), as ``between``.

        One sending after the first sample of each ``MARKER_PERIOD`` of
        simulated time, for the viewers that join late with volatile
        durability (RViz's default, live or during ``ros2 bag play``).
        """
        out = []
        for k, t in enumerate(times):
            if _periods(t, visuals.MARKER_PERIOD) >= self._markers_due:
                when = self.stamp_ns(t)
                out.append((k + 1, self.topic('markers'), MARKERS,
                            self._marker_array(when, t), when, LATCHED_QOS))
                self._markers_due = math.floor(_periods(t, visuals.MARKER_PERIOD)) + 1
        return out

    def _arrows_again(self, times, rows, active) -> list:
        """
        Return the load arrows among samples at these times (s), as ``between``.

        Every ``loadarrows.PERIOD`` of simulated time, from the samples'
        numbers (rows in ``Simulator.outputs`` order, these joints active)
        and the wrenches held on the bodies.
        """
        if not self._arrows_on:
            return []
        out, held = [], None
        for k, t in enumerate(times):
            if _periods(t, loadarrows.PERIOD) < self._arrows_due:
                continue
            self._arrows_due = math.floor(_periods(t, loadarrows.PERIOD)) + 1
            held = self.sim.held_wrenches() if held is None else held
            when = self.stamp_ns(t)
            message, kind = self._arrows.message(stamp(when), rows[k], active, held)
            out.append((k + 1, self.topic('load_markers'), MARKERS,
                        self._marker_bytes(message, kind=kind), when, OFFERED_QOS))
        return out

    def _marker_array(self, stamp_ns: int, t: float) -> bytes:
        """Return the MarkerArray at simulated time t (the joints released by then in red), CDR."""
        released = {e['joint'] for e in self.sim.events
                    if e.get('event') == 'release' and e['time'] <= t}
        contacts = [e for e in self.sim.events if e.get('event') == 'contact' and e['time'] <= t]
        return self._marker_bytes(visuals.markers(self.sim.model, stamp(stamp_ns),
                                                  self.namespace, released, contacts))

    def _markers(self, stamp_ns: int):
        t = (stamp_ns - self.start_ns) / 1e9
        self.recorder.write(self.topic('markers'), MARKERS, self._marker_array(stamp_ns, t),
                            stamp_ns, qos=LATCHED_QOS)

    def sample(self):
        """Record poses, twists and active joints' wrenches at the current state."""
        if not self._scene_written:
            self._scene()
        sim = self.sim
        layout = self._layout(sim.active_joints)
        row = layout.next_row()
        sim.outputs(out=row)
        arrows = self._arrows_again([sim.t], [row], sim.active_joints)
        self.recorder.add_sample(layout, self.stamp_ns(sim.t))
        self.samples += 1
        for _, *message in arrows + self._markers_again([sim.t]):
            self.recorder.write(*message)

    def sample_rows(self) -> np.ndarray:
        """Return buffer rows for the next samples' ``Simulator.outputs`` (see ``took_rows``)."""
        if not self._scene_written:
            self._scene()
        self._rows_active = self.sim.active_joints
        self._rows_layout = self._layout(self._rows_active)
        return self.recorder.free_rows(self._rows_layout)

    def took_rows(self, times: np.ndarray):
        """Record the samples at these simulated times (s), in the first rows given."""
        stamps = self.start_ns + np.rint(np.asarray(times) * 1e9).astype(np.int64)
        layout = self._rows_layout
        rows = layout.values[layout.count:layout.count + len(stamps)]
        between = self._arrows_again(times, rows, self._rows_active) + self._markers_again(times)
        self.recorder.commit_rows(layout, stamps, sorted(between, key=lambda m: m[0]))
        self.samples += len(stamps)

    def _layout(self, active) -> 'SampleLayout':
        layout = self._layouts.get(active)
        if layout is None:
            layout = self._layouts[active] = self.recorder.layout(self._messages(active))
        return layout

    def _messages(self, active):
        """
        List the messages of a sample with these joints active.

        First those whose numbers a sample holds, in ``Simulator.outputs``
        order (the loads in world axes); then the loads again in the axes
        where they act (the joint's child, the loaded body: SPEC sections
        3 and 5), turned from those numbers, and /tf.
        """
        messages, turned = [], []
        model = self.sim.model
        bodies = model.bodies
        for i, body in enumerate(bodies):
            messages.append((self._pose_topics[i], POSE, self.world, 7))
            messages.append((self._twist_topics[i], TWIST, body.name, 6))
        column = 13 * len(bodies)
        for k in active:
            joint = model.joints[k]
            messages.append((self._wrench_topics[k] + '_world', WRENCH, self.world, 6))
            turned.append((self._wrench_topics[k], WRENCH, joint.name,
                           InBodyAxes(column, 13 * joint.child + 3)))
            column += 6
        for body, source in self.sim.applied_sources:   # scheduled loads
            messages.append((self.topic(f'bodies/{body}/applied_world/{source}'), WRENCH,
                             self.world, 6))
            turned.append((self.topic(f'bodies/{body}/applied/{source}'), WRENCH, body,
                           InBodyAxes(column, 13 * model.body_index(body) + 3)))
            column += 6
        for entry in model.aero:   # the air each body sees (SPEC section 10), 3 a topic
            body = bodies[entry.body].name
            messages += [(self.topic(f'bodies/{body}/aero/{name}'), VECTOR3, body, 3)
                         for name, _ in AIR_TOPICS]
        for body, ref in self.sim.model.references:   # in a carrier's frame (core/motion.py)
            messages.append((self.topic(f'bodies/{bodies[body].name}/relative_pose'), POSE,
                             bodies[ref].name, 7))
            messages.append((self.topic(f'bodies/{bodies[body].name}/relative_twist'), TWIST,
                             bodies[ref].name, 6))
        messages += turned
        if self._transforms is not None:
            messages.append(('/tf', TF, self._transforms, self._views))
        return messages

    def events(self):
        """Record the simulator's events not yet recorded, at their own times."""
        if len(self.sim.events) == self._events_written:
            return
        topic = self.topic('events')
        new = self.sim.events[self._events_written:]
        for event in new:
            self.recorder.write(topic, STRING, {'data': json.dumps(event)},
                                self.stamp_ns(event['time']), qos=EVENTS_QOS)
            if event.get('event') == 'release':
                self._zero_load(event['joint'], self.stamp_ns(event['time']))
        self._events_written = len(self.sim.events)
        if self._scene_written and any(e.get('event') in ('release', 'contact') for e in new):
            # released joints change colour; contacts get their marker
            self._markers(self.stamp_ns(new[-1]['time']))

    def _zero_load(self, joint: str, stamp_ns: int):
        """Record a released joint's load as zero once, at its release: plots end at zero."""
        zero = {'force': _vector((0, 0, 0)), 'torque': _vector((0, 0, 0))}
        for topic, frame in ((f'joints/{joint}/wrench', joint),
                             (f'joints/{joint}/wrench_world', self.world)):
            self.recorder.write(self.topic(topic), WRENCH, {
                'header': {'stamp': stamp(stamp_ns), 'frame_id': frame}, 'wrench': zero},
                stamp_ns)

    def note(self, event: dict):
        """Record an event of the node's own (a pause, a step, a reset) at its time."""
        self.recorder.write(self.topic('events'), STRING, {'data': json.dumps(event)},
                            self.stamp_ns(event['time']), qos=EVENTS_QOS)

    def restart(self, sim, start_ns: int):
        """Go on recording a new run of the same model (a reset): sim from start_ns on."""
        self.sim = sim
        self.start_ns = int(start_ns)
        self._events_written = 0
        self._markers_due, self._arrows_due = 1, 0
        self._markers(self.stamp_ns(0.0))

    def failed(self):
        """Record the run's failure as an ``error`` event at the time it stopped."""
        sim = self.sim
        self.recorder.write(self.topic('events'), STRING, {'data': json.dumps(
            {'event': 'error', 'time': sim.t, 'message': sim.message})},
            self.stamp_ns(sim.t), qos=EVENTS_QOS)

    def received(self, item, t: float):
        """
        Record an input as received, logged at the simulated time t it took effect.

        The log time is what ``cfem-sim run --inputs`` replays it at; a
        wrench's header keeps the stamp it arrived with (the log time if it
        had none).
        """
        stamp_ns = self.stamp_ns(t)
        if item.kind == 'release':
            self.recorder.write(self.topic('release'), STRING, {'data': item.target}, stamp_ns)
            return
        header_ns = stamp_ns if item.header_ns is None else item.header_ns
        if stamp_problem(header_ns):   # refused, and no header can hold it: the log time's
            header_ns = stamp_ns
        self._arrows_on = self._arrows_on or item.kind == 'wrench'
        if item.kind == 'odom':
            v = item.values
            self.recorder.write(self.topic(f'bodies/{item.target}/odom'), ODOMETRY, {
                'header': {'stamp': stamp(header_ns), 'frame_id': item.frame_id},
                'child_frame_id': item.target,
                'pose': {'pose': {'position': _vector(v[0:3]),
                                  'orientation': dict(zip('xyzw', map(float, v[3:7])))},
                         'covariance': [0.0] * 36},
                'twist': {'twist': {'linear': _vector(v[7:10]), 'angular': _vector(v[10:13])},
                          'covariance': [0.0] * 36},
            }, stamp_ns)
            return
        self.recorder.write(self.topic(f'bodies/{item.target}/wrench'), WRENCH, {
            'header': {'stamp': stamp(header_ns), 'frame_id': item.frame_id},
            'wrench': {'force': _vector(item.force), 'torque': _vector(item.torque)},
        }, stamp_ns)
