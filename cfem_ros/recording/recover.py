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

from cfem_ros.recording.chunks import signals_held
from cfem_ros.recording.errors import OutputError, RecordingError
from cfem_ros.recording.reader import open_recording, READ_ERRORS, reading
from cfem_ros.recording.salvage import (chunk_records, Damaged, DATA_OPCODES, MAGIC, parse_exact,
                                        read_header, RECORD, resync, summary_definitions)
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message, MessageIndex, Metadata, Schema
from mcap.writer import CompressionType, Writer
from mcap_ros2.decoder import DecoderFactory

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
            opcode, length = RECORD.unpack_from(data, position)
            end = position + 9 + length
            if opcode not in DATA_OPCODES:
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
            except Damaged as err:
                position = self.skip(position, str(err), chunk=opcode == Opcode.CHUNK)
                continue
            position = end

    def take(self, opcode: int, body, position: int):
        if opcode == Opcode.CHUNK:
            chunk = parse_exact(Chunk, body)
            records = chunk_records(chunk)
            kept, skipped = self.keeper.chunk(records, verified=bool(chunk.uncompressed_crc))
            self.report.chunks += 1
            self.report.messages += kept
            self.report.skipped += skipped
            if skipped:
                self.damaged(position, f'chunk: {skipped} message(s) without an intact '
                             'channel or schema, or not decoding')
        elif opcode == Opcode.METADATA:
            record = parse_exact(Metadata, body)
            self.keeper.writer.add_metadata(record.name, dict(record.metadata))
        elif opcode == Opcode.MESSAGE_INDEX:
            parse_exact(MessageIndex, body)
        elif opcode == Opcode.MESSAGE:
            self.damaged(position, 'a message outside any chunk (no CRC); skipped')
            self.report.skipped += 1
        # a schema or channel outside a chunk has no CRC: the chunks' own copies are used

    def skip(self, position: int, what: str, chunk: bool = False) -> int:
        """Note damage at position; return where reading goes on (the next good chunk)."""
        if chunk:
            self.report.bad_chunks += 1
            self.report.skipped += self.count_messages(position)
        following = resync(self.data, position + 1, self.size)
        gap = '' if following >= self.size else f'; reading goes on at byte {following}'
        self.damaged(position, what + gap)
        return following

    def count_messages(self, position: int) -> int:
        """Count the message records a damaged uncompressed chunk seems to hold (best effort)."""
        data, count = self.data, 0
        length = RECORD.unpack_from(data, position)[1]
        end = min(self.size, position + 9 + length)
        fixed = position + 9 + 8 + 8 + 8 + 4
        if fixed + 4 > end or struct.unpack_from('<I', data, fixed)[0] != 0:
            return 0   # compressed: its records cannot be walked
        cursor = fixed + 4 + 8
        while cursor + 9 <= end and count < 1_000_000:
            opcode, inner = RECORD.unpack_from(data, cursor)
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
            records = chunk_records(chunk, partial=True)
        except (Damaged, *READ_ERRORS):
            return
        kept, skipped = self.keeper.chunk(records, verified=False)
        self.report.messages += kept
        self.report.unverified += kept
        self.report.skipped += skipped


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
            header, position = read_header(data, size)
            writer = Writer(target, chunk_size=1024 * 1024, compression=CompressionType.NONE)
            writer.start(*(header or ('ros2', 'cfem-sim recover')))
            keeper = _Keeper(writer, report, summary_definitions(data, size))
            scan = _Scan(data, size, keeper)
            if bad_magic:
                scan.damaged(0, 'the magic bytes are damaged')
            if header is None:
                scan.damaged(len(MAGIC), 'the header record is damaged')
                position = resync(data, len(MAGIC), size)
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
