# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recover the complete messages of a cut MCAP file into a new, indexed one.

A writer killed hard (SIGKILL, power loss) leaves a file without summary or
footer, possibly ending in a half-written record. ``recover`` reads it from
the start, record by record (``mcap``'s record parsers), and writes every
schema, channel, metadata record and complete message it finds with
``mcap``'s ``Writer`` (uncompressed chunks, a summary with statistics and
indexes). The complete Message records at the start of a cut uncompressed
chunk are kept too.
"""

from __future__ import annotations

from dataclasses import dataclass
import io
import os
import struct
import zlib

from cfem_ros.recording.chunks import signals_held
from cfem_ros.recording.errors import RecordingError
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Header, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

MAGIC = b'\x89MCAP0\r\n'
_CHUNK_FIXED = struct.Struct('<QQQI')   # start, end, uncompressed size, crc


@dataclass
class Recovery:
    """
    What ``recover`` found.

    Attributes
    ----------
    messages : int
        Messages written to the new file.
    chunks : int
        Complete chunks read.
    size : int
        Bytes of the broken file.
    cut_at : int
        Offset of the first byte not part of a complete record (size if
        the file ends after a complete record).
    complete : bool
        The file had its footer: nothing was cut.
    end_ns : int
        Log time of the last message recovered (0 if none).
    note : str
        What stopped the reading, if anything.

    """

    messages: int = 0
    chunks: int = 0
    size: int = 0
    cut_at: int = 0
    complete: bool = False
    end_ns: int = 0
    note: str = ''


class _Copier:
    def __init__(self, writer: Writer):
        self.writer = writer
        self.schemas = {}    # id in the broken file -> id in the new one
        self.channels = {}
        self.report = Recovery()

    def take(self, record):
        writer = self.writer
        if isinstance(record, Schema):
            if record.id not in self.schemas:
                self.schemas[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data)
        elif isinstance(record, Channel):
            if record.id not in self.channels:
                self.channels[record.id] = writer.register_channel(
                    record.topic, record.message_encoding,
                    self.schemas.get(record.schema_id, 0), dict(record.metadata))
        elif isinstance(record, Message):
            channel = self.channels.get(record.channel_id)
            if channel is None:
                return
            writer.add_message(channel, record.log_time, record.data, record.publish_time,
                               record.sequence)
            self.report.messages += 1
            self.report.end_ns = max(self.report.end_ns, record.log_time)
        elif isinstance(record, Metadata):
            writer.add_metadata(record.name, dict(record.metadata))


def _parse(opcode: int, body: bytes):
    stream = ReadDataStream(io.BytesIO(body))
    kinds = {Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel, Opcode.METADATA: Metadata,
             Opcode.CHUNK: Chunk, Opcode.HEADER: Header}
    if opcode == Opcode.MESSAGE:
        return Message.read(stream, len(body))
    kind = kinds.get(opcode)
    return kind.read(stream) if kind else None


def _salvage_chunk(body: bytes, copier: _Copier):
    """Take the complete records at the start of a cut uncompressed chunk's bytes."""
    fixed = _CHUNK_FIXED.size
    if len(body) < fixed + 4:
        return
    compression_length = struct.unpack_from('<I', body, fixed)[0]
    if compression_length != 0:
        return   # compressed: nothing usable without its end
    position = fixed + 4 + 8   # past the compression '' and the records' length
    while position + 9 <= len(body):
        opcode, length = struct.unpack_from('<BQ', body, position)
        if position + 9 + length > len(body):
            return
        record = _parse(opcode, body[position + 9:position + 9 + length])
        if record is not None:
            copier.take(record)
        position += 9 + length


def recover(broken: str, fixed: str) -> Recovery:
    """
    Copy every complete message of the MCAP file broken into a new file fixed.

    Raises
    ------
    RecordingError
        If broken cannot be read or is not MCAP, or fixed cannot be written.

    """
    try:
        source = open(broken, 'rb')
    except OSError as err:
        raise RecordingError(f'{broken}: cannot read ({err.strerror})') from err
    with source:
        size = os.fstat(source.fileno()).st_size
        if source.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f'{broken}: not an MCAP file (it does not start with the '
                                 'MCAP magic bytes)')
        try:
            target = open(fixed, 'xb')
        except FileExistsError:
            raise RecordingError(f'{fixed}: already exists; choose another name') from None
        except OSError as err:
            raise RecordingError(f'{fixed}: cannot write ({err.strerror})') from err
        with target:
            writer = Writer(target, chunk_size=1024 * 1024, compression=CompressionType.NONE)
            copier = _Copier(writer)
            report = copier.report
            report.size = size
            started = False
            position = len(MAGIC)
            while True:
                head = source.read(9)
                if len(head) < 9:
                    report.note = 'ends inside a record header' if head else 'ends after a record'
                    break
                opcode, length = struct.unpack('<BQ', head)
                if position + 9 + length > size:
                    body = source.read(max(0, size - position - 9))
                    if opcode == Opcode.CHUNK:
                        _salvage_chunk(body, copier)
                    report.note = f'cut inside a record (opcode 0x{opcode:02x}, ' \
                        f'{length} bytes declared)'
                    break
                body = source.read(length)
                if opcode == Opcode.FOOTER:
                    position += 9 + length
                    report.complete = source.read(len(MAGIC)) == MAGIC
                    report.note = '' if report.complete else 'ends inside the closing magic'
                    break
                if opcode in (Opcode.DATA_END,):
                    position += 9 + length
                    continue
                try:
                    record = _parse(opcode, body)
                    records = (breakup_chunk(record, validate_crc=True)
                               if isinstance(record, Chunk) else [record])
                except (ValueError, EOFError, struct.error, zlib.error) as err:
                    report.note = f'unreadable record (opcode 0x{opcode:02x}: {err})'
                    break
                if isinstance(record, Header):
                    writer.start(record.profile, record.library)
                    started = True
                    position += 9 + length
                    continue
                if not started:
                    writer.start('', 'cfem-sim recover')
                    started = True
                if isinstance(record, Chunk):
                    report.chunks += 1
                for item in records:
                    if item is not None:
                        copier.take(item)
                position += 9 + length
            report.cut_at = position
            if not started:
                writer.start('', 'cfem-sim recover')
            with signals_held():
                writer.finish()
    return report
