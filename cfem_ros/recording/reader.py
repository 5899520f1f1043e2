# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The one reading layer for recordings: every failure becomes one ``RecordingError``.

``info``, ``plot``, ``compare``, ``summarize``, ``play``, ``recover`` and
``run --inputs`` open recordings through ``open_recording`` (a regular file
only: a FIFO, device, socket or directory is refused from its ``stat``
before it is opened, and it is opened non-blocking, so nothing ever waits
on a pipe) and read them inside ``reading``, which turns whatever the file
system, the ``mcap`` library, a decompressor or the CDR decoder raises on a
damaged file (``EndOfFile``, ``struct.error``, ``OverflowError``,
``MemoryError`` for a record declaring gigabytes, ``ZstdError``, a schema
whose name does not parse, ...) into a ``RecordingError`` naming the
file, what was wrong and what to do.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import io
import os
import stat
import struct
from typing import BinaryIO, Iterator
import zlib

from cfem_ros.core.fileio.textfile import file_kind
from cfem_ros.recording.errors import RecordingError
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap_ros2._vendor.rosidl_adapter.parser import InvalidSpecification, InvalidValue
from mcap_ros2.decoder import DecoderFactory

try:   # the decompressors mcap uses, when installed
    from zstandard import ZstdError
except ImportError:  # pragma: no cover - mcap then refuses zstd chunks itself
    ZstdError = McapError

__all__ = ['MCAP_MAGIC', 'READ_ERRORS', 'check_data_crc', 'check_mcap', 'decoded_messages',
           'describe_failure', 'file_kind', 'open_mcap', 'open_recording', 'reading']

MCAP_MAGIC = b'\x89MCAP0\r\n'

#: What reading a damaged file can raise, from the file system, mcap (and the
#: decompressors under it: lz4 raises RuntimeError) and the CDR decoder.
READ_ERRORS = (McapError, OSError, EOFError, ValueError, KeyError, IndexError, TypeError,
               AttributeError, struct.error, OverflowError, MemoryError, UnicodeError,
               RuntimeError, ZstdError, InvalidSpecification, InvalidValue)

#: Longest reason quoted from a lower error, characters.
REASON_LENGTH = 160


def _clip(text: str, limit: int = REASON_LENGTH) -> str:
    text = ' '.join(str(text).split())
    text = ''.join(c if c.isprintable() else '?' for c in text)
    return text if len(text) <= limit else text[:limit - 3] + '...'


def _why(err: BaseException, limit: int = REASON_LENGTH) -> str:
    """Return 'Type: reason' of an error (the type alone if it gives no reason)."""
    reason = _clip(err, limit)
    return f'{type(err).__name__}: {reason}' if reason else type(err).__name__


def describe_failure(path: str, err: BaseException) -> str:
    """Return the one-line message for a failure while reading path."""
    if isinstance(err, OSError) and not isinstance(err, McapError) \
            and err.errno not in (errno.EINVAL, errno.EOVERFLOW, errno.EFBIG):
        return f'{path}: cannot read ({err.strerror or _clip(err) or type(err).__name__})'
    # an offset or size out of range came from the file: damage, not the file system
    what = ('a record declares a size larger than memory' if isinstance(err, MemoryError)
            else _why(err))
    return (f'{path}: damaged recording ({what}); `cfem-sim recover {path} -o FIXED.mcap` '
            'keeps its intact chunks')


@contextlib.contextmanager
def reading(path: str) -> Iterator[None]:
    """Turn any failure of reading path inside the block into a RecordingError."""
    try:
        yield
    except RecordingError:
        raise
    except READ_ERRORS as err:
        raise RecordingError(describe_failure(path, err)) from err


def open_recording(path: str) -> BinaryIO:
    """
    Open a recording for reading: a regular file only, never blocking.

    Raises
    ------
    RecordingError
        If path is missing, unreadable, or a FIFO, device, socket or
        directory (refused from its ``stat``, before it is opened).

    """
    expected = 'an MCAP recording (a regular file)'
    try:
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode):
            raise RecordingError(f'{path}: is {file_kind(mode)}; expected {expected}')
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except (OSError, ValueError) as err:
        raise RecordingError(f'{path}: cannot read '
                             f'({getattr(err, "strerror", None) or err})') from err
    try:
        info = os.fstat(fd)   # the file opened, not the one stat saw
        if not stat.S_ISREG(info.st_mode):
            raise RecordingError(f'{path}: is {file_kind(info.st_mode)}; expected {expected}')
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
        return os.fdopen(fd, 'rb')
    except BaseException:
        os.close(fd)
        raise


_FOOTER = struct.Struct('<BQQQI')    # opcode, length, summary start, offsets start, crc
_DATA_END = struct.Struct('<BQI')     # opcode, length, data section crc


def _damaged(path: str, what: str) -> RecordingError:
    return RecordingError(f'{path}: damaged recording ({what}); `cfem-sim recover {path} '
                          '-o FIXED.mcap` keeps its intact chunks')


def check_mcap(path: str) -> None:
    """
    Raise RecordingError unless path is a complete MCAP file whose summary CRC holds.

    The message says what is wrong: missing, not a regular file, not MCAP,
    truncated (no footer: the writer did not finish, e.g. it was killed),
    or a summary section (schemas, channels, statistics, indexes) whose
    bytes no longer match the footer's CRC.
    """
    with open_recording(path) as stream, reading(path):
        size = os.fstat(stream.fileno()).st_size
        head = stream.read(len(MCAP_MAGIC))
        stream.seek(max(0, size - len(MCAP_MAGIC)))
        tail = stream.read(len(MCAP_MAGIC))
        if head != MCAP_MAGIC:
            raise RecordingError(f'{path}: not an MCAP file (it does not start with the MCAP '
                                 'magic bytes); expected a recording from cfem-sim, cfem_node '
                                 'or ros2 bag record -s mcap')
        if size < 2 * len(MCAP_MAGIC) or tail != MCAP_MAGIC:
            raise RecordingError(
                f'{path}: truncated MCAP file ({size} bytes, no footer): the writer did not '
                'finish it (killed?). Its complete messages can be recovered with '
                f'`cfem-sim recover {path} -o FIXED.mcap`')
        footer_at = size - len(MCAP_MAGIC) - _FOOTER.size
        if footer_at < len(MCAP_MAGIC):
            raise _damaged(path, 'too short for a footer')
        stream.seek(footer_at)
        opcode, length, start, _, crc = _FOOTER.unpack(stream.read(_FOOTER.size))
        if opcode != 0x02 or length != 20 or not (start == 0 or 8 < start <= footer_at):
            raise _damaged(path, 'its footer is not an MCAP footer')
        if start and crc:
            stream.seek(start)
            summary = stream.read(footer_at + _FOOTER.size - 4 - start)
            if zlib.crc32(summary) != crc:
                raise _damaged(path, 'the summary section does not match its CRC')


def check_data_crc(stream, path: str):
    """Raise RecordingError if the data section's CRC (when the file has one) does not hold."""
    size = os.fstat(stream.fileno()).st_size
    footer_at = size - len(MCAP_MAGIC) - _FOOTER.size
    stream.seek(footer_at)
    start = _FOOTER.unpack(stream.read(_FOOTER.size))[2]
    data_end = (start or footer_at) - _DATA_END.size
    if data_end < len(MCAP_MAGIC):
        raise _damaged(path, 'no data end record')
    stream.seek(data_end)
    opcode, length, crc = _DATA_END.unpack(stream.read(_DATA_END.size))
    if opcode != 0x0F or length != 4:
        raise _damaged(path, 'no data end record before the summary')
    if not crc:
        return
    stream.seek(0)
    value, left = 0, data_end
    while left:
        block = stream.read(min(left, 1 << 20))
        if not block:
            raise _damaged(path, 'the data section ends early')
        value = zlib.crc32(block, value)
        left -= len(block)
    if value != crc:
        raise _damaged(path, 'the data section does not match its CRC')
    stream.seek(0)


@contextlib.contextmanager
def open_mcap(path: str, decoder_factories=(), whole: bool = True) -> Iterator:
    """
    Check path (``check_mcap``) and yield an mcap reader of it, failures as RecordingError.

    Everything done with the reader inside the block (summary, iterating
    and decoding messages) is covered by ``reading``. The summary's CRC and
    every chunk's CRC are checked (a flipped byte is an error, not a wrong
    number), and, with ``whole`` (readers that read every message anyway),
    the data section's CRC, which also covers the metadata records.
    """
    check_mcap(path)
    with open_recording(path) as stream, reading(path):
        if whole:
            check_data_crc(stream, path)
            stream.seek(0)
        yield make_reader(stream, validate_crcs=True,
                          decoder_factories=list(decoder_factories))


def decoded_messages(reader, path: str, topics=None, log_time_order: bool = True) -> Iterator:
    """
    Yield (channel, message, decoded) of a reader's CDR messages, each decoded once.

    A schema that does not parse or a payload that does not decode raises
    a RecordingError naming the topic and the message's log time; messages
    of other encodings are skipped.
    """
    factory = DecoderFactory()
    for schema, channel, message in reader.iter_messages(topics=topics,
                                                         log_time_order=log_time_order):
        try:
            with contextlib.redirect_stderr(io.StringIO()):   # the parser prints its errors
                decoder = factory.decoder_for(channel.message_encoding, schema)
        except READ_ERRORS as err:
            raise RecordingError(
                f'{path}: the schema {_clip(getattr(schema, "name", "?"), 80)!r} of '
                f'{_clip(channel.topic, 80)} does not parse ({_why(err, 80)}); expected ROS 2 '
                'message definitions (ros2msg)') from err
        if decoder is None:
            continue
        try:
            decoded = decoder(bytes(message.data))
        except READ_ERRORS as err:
            raise RecordingError(
                f'{path}: a message cannot be decoded ({_clip(channel.topic, 80)} at log time '
                f'{message.log_time} ns: {_why(err, 80)}); expected well-formed ROS 2 CDR '
                'payloads') from err
        yield channel, message, decoded
