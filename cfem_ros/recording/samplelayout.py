# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A kind of sample's messages as one buffer of fixed-size CDR records, encoded with numpy.

``SampleLayout`` keeps a sample's numbers as a row and turns up to a chunk's
worth of rows into MCAP Message records at once; ``TransformsOf`` and
``InBodyAxes`` are messages made of other messages' numbers (a /tf message,
a load turned into a body's axes).
"""

from __future__ import annotations

from dataclasses import dataclass
import functools
import struct
from typing import Optional

from cfem_ros.core import rotations
from cfem_ros.recording.chunks import BATCH_CHUNKS, CHUNK_SIZE, message_record_fields
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.schema import TF_TYPE
from mcap.opcode import Opcode
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np

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
    encode = serialize_dynamic(TF_TYPE, DEFINITIONS[TF_TYPE])[TF_TYPE]
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


def _frame_bytes(frame_id: str) -> bytes:
    """CDR of a frame_id string: uint32 length with the NUL, the bytes, the NUL."""
    text = frame_id.encode() + b'\0'
    return struct.pack('<I', len(text)) + text
