# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recover the verifiably intact messages of a cut or damaged MCAP file into a new one.

A writer killed hard (SIGKILL, power loss) leaves a file without summary or
footer, possibly ending in a half-written record; a damaged disk or copy
flips bytes anywhere. ``recover`` reads the data section record by record
and keeps only what it can check:

- a chunk is kept when its CRC holds (or, if it has none, when all its
  records parse), its decompressed size is the declared one and each of its
  records fills exactly its declared length;
- schemas and channels come from such chunks (or from the summary section
  when the footer's summary CRC holds); the unprotected schema and channel
  records outside chunks are not trusted;
- a message is kept when it decodes against its schema (CDR with a ros2msg
  schema; a message of another encoding only from a chunk whose CRC holds);
- a damaged record is skipped and the reading goes on at the next chunk
  that checks out; the complete records at the start of a chunk cut by the
  end of the file are kept when they decode (a kill truncates, it does not
  corrupt; they have no CRC to check and are counted apart).

The output (``mcap``'s ``Writer``: uncompressed chunks with CRCs, a summary
with statistics and indexes) is read back with the indexed reader and every
message decoded before ``recover`` returns; a failure removes it.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
import io
import mmap
import os
import struct
import zlib

from cfem_ros.recording.chunks import signals_held
from cfem_ros.recording.errors import OutputError, RecordingError
from cfem_ros.recording.reader import open_recording, READ_ERRORS, reading
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import (Channel, Chunk, Footer, Header, Message, MessageIndex, Metadata,
                          Schema)
from mcap.writer import CompressionType, Writer
from mcap_ros2.decoder import DecoderFactory

MAGIC = b'\x89MCAP0\r\n'
_RECORD = struct.Struct('<BQ')
#: A decompressed chunk may hold at most this many times its compressed bytes
#: (zstd's best ratio on the most regular data is about 10^4), and at most
#: ``MAX_CHUNK`` bytes: a damaged size field cannot ask for gigabytes.
MAX_RATIO = 1 << 16
MAX_CHUNK = 1 << 30
#: Records that may appear in the data section.
_DATA_OPCODES = {Opcode.HEADER, Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.CHUNK,
                 Opcode.MESSAGE_INDEX, Opcode.ATTACHMENT, Opcode.METADATA, Opcode.DATA_END}
#: Most damaged places listed one by one in the report.
MAX_LISTED = 20


@dataclass
class Recovery:
    """
    What ``recover`` found and kept.

    Attributes
    ----------
    messages : int
        Messages written to the new file.
    skipped : int
        Messages found but not kept (in a damaged chunk, no intact channel
        or schema, or not decoding).
    chunks : int
        Chunks kept (their CRC held, or they were the cut last one).
    bad_chunks : int
        Chunks skipped as damaged.
    unverified : int
        Messages kept from a chunk cut by the end of the file (they decode;
        no CRC to check).
    size : int
        Bytes of the broken file.
    cut_at : int
        Offset of the first byte not part of a complete record (size if
        the file ends after a complete record).
    complete : bool
        The file had its data end and closing magic: nothing was cut.
    end_ns : int
        Log time of the last message recovered (0 if none).
    note : str
        What stopped the reading, if anything.
    damage : list of str
        Where the damage was: byte offset and what.

    """

    messages: int = 0
    skipped: int = 0
    chunks: int = 0
    bad_chunks: int = 0
    unverified: int = 0
    size: int = 0
    cut_at: int = 0
    complete: bool = False
    end_ns: int = 0
    note: str = ''
    damage: list = field(default_factory=list)


class _Damaged(Exception):
    """A record that does not check out (its message says why)."""


class _ExactStream(ReadDataStream):
    """mcap's record stream, refusing a short read (a length field beyond the record)."""

    def read(self, length: int) -> bytes:
        data = super().read(length)
        if len(data) != length:
            raise EndOfFile()
        return data


def _stream(data) -> ReadDataStream:
    return _ExactStream(io.BytesIO(bytes(data)))


def _parse_exact(kind, body):
    """Parse a record of kind from body, which it must fill exactly."""
    stream = _stream(body)
    try:
        record = kind.read(stream)
    except READ_ERRORS as err:
        raise _Damaged(f'{kind.__name__} record does not parse ({type(err).__name__})') from None
    if stream.count != len(body):
        raise _Damaged(f'{kind.__name__} record of {len(body)} bytes holds {stream.count}')
    return record


def _chunk_records(chunk: Chunk, partial: bool = False) -> list:
    """
    Return the records of a chunk, after checking its size, CRC and every record's length.

    ``partial``: the chunk's bytes were cut by the end of the file (an
    uncompressed chunk only): the complete records before the cut.
    """
    if partial:
        data = chunk.data
    elif chunk.compression == '':
        data = chunk.data
    elif chunk.compression == 'zstd':
        if chunk.uncompressed_size > min(MAX_CHUNK, MAX_RATIO * max(1, len(chunk.data))):
            raise _Damaged(f'declares {chunk.uncompressed_size} bytes uncompressed')
        try:
            import zstandard
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size)
        except Exception as err:  # noqa: B902 - any decompression failure is damage
            raise _Damaged(f'zstd data does not decompress ({type(err).__name__})') from None
    elif chunk.compression == 'lz4':
        try:
            import lz4.frame
            data = lz4.frame.decompress(chunk.data)
        except Exception as err:  # noqa: B902 - any decompression failure is damage
            raise _Damaged(f'lz4 data does not decompress ({type(err).__name__})') from None
    else:
        raise _Damaged(f'unknown compression {chunk.compression[:20]!r}')
    if not partial:
        if len(data) != chunk.uncompressed_size:
            raise _Damaged(f'holds {len(data)} bytes, not the {chunk.uncompressed_size} declared')
        if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
            raise _Damaged('its CRC does not hold')
    records, position = [], 0
    kinds = {Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel}
    while position < len(data):
        if position + 9 > len(data):
            if partial:
                break
            raise _Damaged('ends inside a record header')
        opcode, length = _RECORD.unpack_from(data, position)
        body = data[position + 9:position + 9 + length]
        if len(body) < length:
            if partial:
                break
            raise _Damaged(f'a record (opcode 0x{opcode:02x}) runs past its end')
        if opcode == Opcode.MESSAGE:
            if length < 22:
                raise _Damaged(f'a message record of {length} bytes')
            records.append(Message.read(_stream(body), length))
        elif opcode in kinds:
            records.append(_parse_exact(kinds[opcode], body))
        elif not partial and chunk.uncompressed_crc == 0:
            raise _Damaged(f'unknown record opcode 0x{opcode:02x} (and no CRC)')
        position += 9 + length
    return records


class _Keeper:
    """Schemas, channels and messages that check out, written to the new file."""

    def __init__(self, writer: Writer, report: Recovery, fallback: tuple):
        self.writer, self.report = writer, report
        self.schemas, self.channels = {}, {}          # old id -> record, checked
        self.fallback_schemas, self.fallback_channels = fallback
        self.schema_ids, self.channel_ids = {}, {}    # old id -> new id
        self.decoders = {}
        self.factory = DecoderFactory()

    def chunk(self, records: list, verified: bool) -> tuple:
        """Keep a chunk's records; return (kept, skipped) messages."""
        kept = skipped = 0
        for record in records:
            if isinstance(record, Schema):
                self.schemas.setdefault(record.id, record)
            elif isinstance(record, Channel):
                self.channels.setdefault(record.id, record)
        for record in records:
            if isinstance(record, Message):
                if self._message(record, verified):
                    kept += 1
                else:
                    skipped += 1
        return kept, skipped

    def _channel(self, old_id: int):
        """Return (new channel id, decoder or None) of a channel, or None if unusable."""
        channel = self.channels.get(old_id) or self.fallback_channels.get(old_id)
        if channel is None:
            return None
        schema = None
        if channel.schema_id:
            schema = (self.schemas.get(channel.schema_id)
                      or self.fallback_schemas.get(channel.schema_id))
            if schema is None:
                return None
        if old_id not in self.decoders:
            try:
                with contextlib.redirect_stderr(io.StringIO()):   # the parser prints errors
                    decoder = self.factory.decoder_for(channel.message_encoding, schema)
            except Exception:  # noqa: B902 - a schema that does not parse is damage
                decoder = False
            self.decoders[old_id] = decoder
        if self.decoders[old_id] is False:
            return None
        if old_id not in self.channel_ids:
            new_schema = 0
            if schema is not None:
                if schema.id not in self.schema_ids:
                    self.schema_ids[schema.id] = self.writer.register_schema(
                        schema.name, schema.encoding, schema.data)
                new_schema = self.schema_ids[schema.id]
            self.channel_ids[old_id] = self.writer.register_channel(
                channel.topic, channel.message_encoding, new_schema, dict(channel.metadata))
        return self.channel_ids[old_id], self.decoders[old_id]

    def _message(self, message: Message, verified: bool) -> bool:
        found = self._channel(message.channel_id)
        if found is None:
            return False
        channel, decoder = found
        if decoder is None and not verified:
            return False   # nothing to check it with, and no CRC either
        if decoder is not None:
            try:
                decoder(bytes(message.data))
            except Exception:  # noqa: B902 - a message that does not decode is damage
                return False
        self.writer.add_message(channel, message.log_time, message.data,
                                message.publish_time, message.sequence)
        self.report.end_ns = max(self.report.end_ns, message.log_time)
        return True


def _summary_definitions(data, size: int) -> tuple:
    """Schemas and channels of the summary section, if the footer's summary CRC holds."""
    schemas, channels = {}, {}
    footer_at = size - len(MAGIC) - 9 - 20
    if footer_at < len(MAGIC) or data[size - len(MAGIC):size] != MAGIC \
            or data[footer_at] != Opcode.FOOTER:
        return schemas, channels
    try:
        footer = _parse_exact(Footer, data[footer_at + 9:footer_at + 29])
    except _Damaged:
        return schemas, channels
    start = footer.summary_start
    if not footer.summary_crc or not len(MAGIC) < start < footer_at:
        return schemas, channels
    # the CRC covers the summary section and the footer up to its CRC field
    if zlib.crc32(data[start:footer_at + 9 + 16]) != footer.summary_crc:
        return schemas, channels
    position = start
    while position + 9 <= footer_at:
        opcode, length = _RECORD.unpack_from(data, position)
        body = data[position + 9:position + 9 + length]
        try:
            if opcode == Opcode.SCHEMA:
                record = _parse_exact(Schema, body)
                schemas[record.id] = record
            elif opcode == Opcode.CHANNEL:
                record = _parse_exact(Channel, body)
                channels[record.id] = record
        except _Damaged:
            pass
        position += 9 + length
    return schemas, channels


def _chunk_at(data, position: int, size: int):
    """Return (Chunk, end) of a plausible, checked chunk record at position, or None."""
    if position + 9 > size or data[position] != Opcode.CHUNK:
        return None
    length = _RECORD.unpack_from(data, position)[1]
    if length < 40 or position + 9 + length > size:
        return None
    try:
        chunk = _parse_exact(Chunk, data[position + 9:position + 9 + length])
        _chunk_records(chunk)
    except (_Damaged, *READ_ERRORS):
        return None
    return chunk, position + 9 + length


def _resync(data, position: int, size: int) -> int:
    """Return the offset of the next chunk that checks out after position, or size."""
    position = data.find(bytes([Opcode.CHUNK]), position)
    while 0 <= position < size:
        if _chunk_at(data, position, size) is not None:
            return position
        position = data.find(bytes([Opcode.CHUNK]), position + 1)
    return size


class _Scan:
    """One pass over the data section, keeping what checks out."""

    def __init__(self, data, size: int, keeper: _Keeper):
        self.data, self.size, self.keeper = data, size, keeper
        self.report = keeper.report

    def damaged(self, position: int, what: str):
        if len(self.report.damage) < MAX_LISTED:
            self.report.damage.append(f'byte {position}: {what}')
        elif len(self.report.damage) == MAX_LISTED:
            self.report.damage.append('...')

    def run(self, position: int):
        data, size, report = self.data, self.size, self.report
        while True:
            if position + 9 > size:
                report.cut_at = position
                if position < size:
                    report.note = 'ends inside a record header'
                else:
                    report.note = 'ends after a record'
                return
            opcode, length = _RECORD.unpack_from(data, position)
            end = position + 9 + length
            if opcode not in _DATA_OPCODES:
                position = self.skip(position, f'no record starts here (opcode 0x{opcode:02x})')
                continue
            if end > size:
                if opcode == Opcode.CHUNK:
                    self.salvage(position)
                    report.note = (f'cut inside a chunk at byte {position} ({length} bytes '
                                   'declared)')
                    report.cut_at = position
                    return
                position = self.skip(position, f'a record (opcode 0x{opcode:02x}) declares '
                                     f'{length} bytes, past the end of the file')
                continue
            body = data[position + 9:end]
            if opcode == Opcode.DATA_END:
                report.cut_at = end
                report.complete = length == 4 and data[size - len(MAGIC):size] == MAGIC
                report.note = '' if report.complete else 'no closing magic after the data end'
                return
            try:
                self.take(opcode, body, position)
            except _Damaged as err:
                position = self.skip(position, str(err), chunk=opcode == Opcode.CHUNK)
                continue
            position = end

    def take(self, opcode: int, body, position: int):
        if opcode == Opcode.CHUNK:
            chunk = _parse_exact(Chunk, body)
            records = _chunk_records(chunk)
            kept, skipped = self.keeper.chunk(records, verified=bool(chunk.uncompressed_crc))
            self.report.chunks += 1
            self.report.messages += kept
            self.report.skipped += skipped
            if skipped:
                self.damaged(position, f'chunk: {skipped} message(s) without an intact '
                             'channel or schema, or not decoding')
        elif opcode == Opcode.METADATA:
            record = _parse_exact(Metadata, body)
            self.keeper.writer.add_metadata(record.name, dict(record.metadata))
        elif opcode == Opcode.MESSAGE_INDEX:
            _parse_exact(MessageIndex, body)
        elif opcode == Opcode.MESSAGE:
            self.damaged(position, 'a message outside any chunk (no CRC); skipped')
            self.report.skipped += 1
        # a schema or channel outside a chunk has no CRC: the chunks' own copies are used

    def skip(self, position: int, what: str, chunk: bool = False) -> int:
        """Note damage at position; return where reading goes on (the next good chunk)."""
        if chunk:
            self.report.bad_chunks += 1
            self.report.skipped += self.count_messages(position)
        following = _resync(self.data, position + 1, self.size)
        gap = '' if following >= self.size else f'; reading goes on at byte {following}'
        self.damaged(position, what + gap)
        return following

    def count_messages(self, position: int) -> int:
        """Count the message records a damaged uncompressed chunk seems to hold (best effort)."""
        data, count = self.data, 0
        length = _RECORD.unpack_from(data, position)[1]
        end = min(self.size, position + 9 + length)
        fixed = position + 9 + 8 + 8 + 8 + 4
        if fixed + 4 > end or struct.unpack_from('<I', data, fixed)[0] != 0:
            return 0   # compressed: its records cannot be walked
        cursor = fixed + 4 + 8
        while cursor + 9 <= end and count < 1_000_000:
            opcode, inner = _RECORD.unpack_from(data, cursor)
            if opcode not in (Opcode.MESSAGE, Opcode.SCHEMA, Opcode.CHANNEL):
                break
            count += opcode == Opcode.MESSAGE
            cursor += 9 + inner
        return count

    def salvage(self, position: int):
        """Keep the complete records at the start of an uncompressed chunk cut by the end."""
        data, size = self.data, self.size
        fixed = position + 9 + 8 + 8 + 8 + 4
        if fixed + 4 > size or struct.unpack_from('<I', data, fixed)[0] != 0:
            return   # compressed (nothing usable without its end) or too short
        start = fixed + 4 + 8
        if start > size:
            return
        head = struct.unpack_from('<QQQI', data, position + 9)
        chunk = Chunk(message_start_time=head[0], message_end_time=head[1],
                      uncompressed_size=head[2], uncompressed_crc=head[3], compression='',
                      data=bytes(data[start:size]))
        try:
            records = _chunk_records(chunk, partial=True)
        except (_Damaged, *READ_ERRORS):
            return
        kept, skipped = self.keeper.chunk(records, verified=False)
        self.report.messages += kept
        self.report.unverified += kept
        self.report.skipped += skipped


def _header(data, size: int):
    """Return (profile, library) of the header record, or None if it is damaged."""
    start = len(MAGIC)
    if start + 9 > size or data[start] != Opcode.HEADER:
        return None, start
    length = _RECORD.unpack_from(data, start)[1]
    if start + 9 + length > size:
        return None, start
    try:
        header = _parse_exact(Header, data[start + 9:start + 9 + length])
    except _Damaged:
        return None, start
    return (header.profile, header.library), start + 9 + length


def _verify(fixed: str, expected: int):
    """Read the output back with the indexed reader, decoding every message."""
    with open(fixed, 'rb') as stream, reading(fixed):
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        count = sum(1 for _ in reader.iter_decoded_messages())
        if summary is None or summary.statistics.message_count != expected or count != expected:
            raise RecordingError(f'{fixed}: reads back {count} messages, not {expected}')


def recover(broken: str, fixed: str) -> Recovery:
    """
    Copy the verifiably intact messages of the MCAP file broken into a new file fixed.

    Raises
    ------
    RecordingError
        If broken cannot be read or is not MCAP, or fixed exists or cannot
        be made (nothing written then).
    OutputError
        If writing fixed fails (a full disk): the partial output is removed.

    """
    with open_recording(broken) as source:
        size = os.fstat(source.fileno()).st_size
        head = source.read(len(MAGIC))
        if sum(a == b for a, b in zip(head, MAGIC)) < len(MAGIC) - 1:
            raise RecordingError(f'{broken}: not an MCAP file (it does not start with the '
                                 'MCAP magic bytes)')
        data = mmap.mmap(source.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        return _recover(data, size, broken, fixed, head != MAGIC)
    finally:
        data.close()


def _recover(data, size: int, broken: str, fixed: str, bad_magic: bool) -> Recovery:
    try:
        target = open(fixed, 'xb')
    except FileExistsError:
        raise RecordingError(f'{fixed}: already exists; choose another name') from None
    except OSError as err:
        raise RecordingError(f'{fixed}: cannot write ({err.strerror})') from err
    report = Recovery(size=size)
    try:
        with target:
            header, position = _header(data, size)
            writer = Writer(target, chunk_size=1024 * 1024, compression=CompressionType.NONE)
            writer.start(*(header or ('ros2', 'cfem-sim recover')))
            keeper = _Keeper(writer, report, _summary_definitions(data, size))
            scan = _Scan(data, size, keeper)
            if bad_magic:
                scan.damaged(0, 'the magic bytes are damaged')
            if header is None:
                scan.damaged(len(MAGIC), 'the header record is damaged')
                position = _resync(data, len(MAGIC), size)
            scan.run(position)
            with signals_held():
                writer.finish()
        _verify(fixed, report.messages)
    except OSError as err:
        _remove(fixed)
        raise OutputError(f'{fixed}: cannot write ({err.strerror or err}); nothing was kept '
                          '(the partial output is removed)') from err
    except BaseException:
        _remove(fixed)
        raise
    return report


def _remove(path: str):
    try:
        os.unlink(path)
    except OSError:
        pass
