# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Checked reading of the records of a cut or damaged MCAP file (``recover``'s parser).

Every record is parsed to fill exactly its declared length, every chunk is
checked (declared sizes, CRC, each record inside); what does not check out
raises ``Damaged``. ``resync`` finds the next chunk that checks out.
"""

from __future__ import annotations

import io
import struct
import zlib

from cfem_ros.core.errors import CfemError
from cfem_ros.recording.reader import READ_ERRORS
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Header, Message, Schema

MAGIC = b'\x89MCAP0\r\n'
RECORD = struct.Struct('<BQ')
#: A decompressed chunk may hold at most this many times its compressed bytes
#: (zstd's best ratio on the most regular data is about 10^4), and at most
#: ``MAX_CHUNK`` bytes: a damaged size field cannot ask for gigabytes.
MAX_RATIO = 1 << 16
MAX_CHUNK = 1 << 30
#: Records that may appear in the data section.
DATA_OPCODES = {Opcode.HEADER, Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.CHUNK,
                Opcode.MESSAGE_INDEX, Opcode.ATTACHMENT, Opcode.METADATA, Opcode.DATA_END}


class Damaged(CfemError):
    """A record that does not check out (its message says why)."""


class _ExactStream(ReadDataStream):
    """mcap's record stream, refusing a short read (a length field beyond the record)."""

    def read(self, length: int) -> bytes:
        data = super().read(length)
        if len(data) != length:
            raise EndOfFile()
        return data


def record_stream(data) -> ReadDataStream:
    return _ExactStream(io.BytesIO(bytes(data)))


def parse_exact(kind, body):
    """Parse a record of kind from body, which it must fill exactly."""
    stream = record_stream(body)
    try:
        record = kind.read(stream)
    except READ_ERRORS as err:
        raise Damaged(f'{kind.__name__} record does not parse ({type(err).__name__})') from None
    if stream.count != len(body):
        raise Damaged(f'{kind.__name__} record of {len(body)} bytes holds {stream.count}')
    return record


def chunk_records(chunk: Chunk, partial: bool = False) -> list:
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
            raise Damaged(f'declares {chunk.uncompressed_size} bytes uncompressed')
        try:
            import zstandard
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size)
        except Exception as err:  # noqa: B902 - any decompression failure is damage
            raise Damaged(f'zstd data does not decompress ({type(err).__name__})') from None
    elif chunk.compression == 'lz4':
        try:
            import lz4.frame
            data = lz4.frame.decompress(chunk.data)
        except Exception as err:  # noqa: B902 - any decompression failure is damage
            raise Damaged(f'lz4 data does not decompress ({type(err).__name__})') from None
    else:
        raise Damaged(f'unknown compression {chunk.compression[:20]!r}')
    if not partial:
        if len(data) != chunk.uncompressed_size:
            raise Damaged(f'holds {len(data)} bytes, not the {chunk.uncompressed_size} declared')
        if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
            raise Damaged('its CRC does not hold')
    records, position = [], 0
    kinds = {Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel}
    while position < len(data):
        if position + 9 > len(data):
            if partial:
                break
            raise Damaged('ends inside a record header')
        opcode, length = RECORD.unpack_from(data, position)
        body = data[position + 9:position + 9 + length]
        if len(body) < length:
            if partial:
                break
            raise Damaged(f'a record (opcode 0x{opcode:02x}) runs past its end')
        if opcode == Opcode.MESSAGE:
            if length < 22:
                raise Damaged(f'a message record of {length} bytes')
            records.append(Message.read(record_stream(body), length))
        elif opcode in kinds:
            records.append(parse_exact(kinds[opcode], body))
        elif not partial and chunk.uncompressed_crc == 0:
            raise Damaged(f'unknown record opcode 0x{opcode:02x} (and no CRC)')
        position += 9 + length
    return records


def summary_definitions(data, size: int) -> tuple:
    """Schemas and channels of the summary section, if the footer's summary CRC holds."""
    schemas, channels = {}, {}
    footer_at = size - len(MAGIC) - 9 - 20
    if footer_at < len(MAGIC) or data[size - len(MAGIC):size] != MAGIC \
            or data[footer_at] != Opcode.FOOTER:
        return schemas, channels
    try:
        footer = parse_exact(Footer, data[footer_at + 9:footer_at + 29])
    except Damaged:
        return schemas, channels
    start = footer.summary_start
    if not footer.summary_crc or not len(MAGIC) < start < footer_at:
        return schemas, channels
    # the CRC covers the summary section and the footer up to its CRC field
    if zlib.crc32(data[start:footer_at + 9 + 16]) != footer.summary_crc:
        return schemas, channels
    position = start
    while position + 9 <= footer_at:
        opcode, length = RECORD.unpack_from(data, position)
        body = data[position + 9:position + 9 + length]
        try:
            if opcode == Opcode.SCHEMA:
                record = parse_exact(Schema, body)
                schemas[record.id] = record
            elif opcode == Opcode.CHANNEL:
                record = parse_exact(Channel, body)
                channels[record.id] = record
        except Damaged:
            pass
        position += 9 + length
    return schemas, channels


def chunk_at(data, position: int, size: int):
    """Return (Chunk, end) of a plausible, checked chunk record at position, or None."""
    if position + 9 > size or data[position] != Opcode.CHUNK:
        return None
    length = RECORD.unpack_from(data, position)[1]
    if length < 40 or position + 9 + length > size:
        return None
    try:
        chunk = parse_exact(Chunk, data[position + 9:position + 9 + length])
        chunk_records(chunk)
    except (Damaged, *READ_ERRORS):
        return None
    return chunk, position + 9 + length


def resync(data, position: int, size: int) -> int:
    """Return the offset of the next chunk that checks out after position, or size."""
    position = data.find(bytes([Opcode.CHUNK]), position)
    while 0 <= position < size:
        if chunk_at(data, position, size) is not None:
            return position
        position = data.find(bytes([Opcode.CHUNK]), position + 1)
    return size


def read_header(data, size: int):
    """Return (profile, library) of the header record, or None if it is damaged."""
    start = len(MAGIC)
    if start + 9 > size or data[start] != Opcode.HEADER:
        return None, start
    length = RECORD.unpack_from(data, start)[1]
    if start + 9 + length > size:
        return None, start
    try:
        header = parse_exact(Header, data[start + 9:start + 9 + length])
    except Damaged:
        return None, start
    return (header.profile, header.library), start + 9 + length
