"""Shared memory between the session's worker and its parent without locks: the latest
byte string one process wrote (``LatestBytes``, a seqlock) and a device sample packed
into a fixed 72-byte record (``pack_sample``, ``unpack_sample``)."""

from __future__ import annotations

import multiprocessing
import struct

from otgym.teleop.device import Sample

_SEQLOCK_TRIES = 256
_SAMPLE = struct.Struct("<dq3d3dq")
"""A device sample in a block: time_s, sequence, position_mm, velocity_mm_s, buttons."""
SAMPLE_BYTES = _SAMPLE.size


class LatestBytes:
    """The latest byte string written by one process, read by others without locks:
    a sequence counter that is odd while the single writer writes (a seqlock, as
    ``otgym.teleop.servo``'s blocks), then the length and the bytes."""

    def __init__(self, capacity: int, context=None):
        context = context or multiprocessing.get_context("spawn")
        self._header = context.RawArray("q", 2)  # [sequence, length]
        self._data = context.RawArray("B", capacity)

    @property
    def capacity(self) -> int:
        return len(self._data)

    def write(self, payload: bytes) -> None:
        size = len(payload)
        if size > len(self._data):
            raise ValueError(f"{size} bytes do not fit in {len(self._data)}")
        header = self._header
        header[0] += 1
        memoryview(self._data).cast("B")[:size] = payload
        header[1] = size
        header[0] += 1

    def read(self) -> tuple[int, bytes] | None:
        """(writes so far, the latest bytes), or None before the first write or when
        every try met a write in progress."""
        header, view = self._header, memoryview(self._data).cast("B")
        for _ in range(_SEQLOCK_TRIES):
            before = header[0]
            if before % 2:
                continue
            payload = bytes(view[: header[1]])
            if header[0] == before:
                return (before // 2, payload) if before else None
        return None


def pack_sample(sample: Sample) -> bytes:
    return _SAMPLE.pack(sample.time_s, sample.sequence, *sample.position_mm, *sample.velocity_mm_s, sample.buttons)


def unpack_sample(data: bytes) -> Sample:
    values = _SAMPLE.unpack(data)
    return Sample(values[0], values[1], values[2:5], values[5:8], values[8])
