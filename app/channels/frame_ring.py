"""`FrameRing`: fixed-size records handed from one process to another through shared memory.

What the tracking process uses to give its frames to a writer process (`writer_process`) without
waiting for it and without sharing its interpreter: a `multiprocessing.shared_memory` block of a
header and `slots` records of `slot_bytes` each, and an eventfd that wakes the reader.

    header (8 uint64, this host's byte order): [0] write_seq, the next record's number (the writer's);
        [1] read_seq, the first record the reader has not done with yet (`acknowledge`); [2] dropped, records the reader lost;
        [3..6] the reader's own figures (`report` / `figure`: what it tells the writer back);
        [7] how many times the reader went to sleep (`wait`)
    record k lives in slot k % slots; its first 8 bytes are k.

The writer packs record k into its slot (`slot(k)`: the offset; the caller `struct.pack_into`s
there) and then publishes it (`commit`: write_seq = k + 1); `wake` writes the eventfd only if the
reader went to sleep since the last wake (header [7]), so a busy reader costs the writer no system
call: the writer never waits. Inside a marker source's poll (`wiithrow.listeners.batch`) the wake
waits for the poll's end: the reader is woken once per poll, after the tracking thread let go of
the rig's lock, not in the middle of the poll, where it took the tracking thread's core. (A wake missed in the race between the reader's "going to sleep"
and a commit costs at most the reader's sleep timeout: it reads the ring after every wait.) A reader that is `slots` records behind has lost the oldest: the ring
*overwrites*, and the reader counts what it lost (`dropped`), from the gap in the numbers and
from a slot the writer reached again while it was being copied (write_seq moved past k + slots - 1
after the copy: the copy may be torn, so it is dropped too: a reader a whole ring behind keeps the
newest `slots - 1`, the oldest slot being the one the writer may be rewriting). The writer is the only one that
writes write_seq, the reader the only one that writes the rest of the header. (CPython's
memoryview stores are plain copies: the order "slot, then write_seq" holds on x86-64's total
store order; this module is for one host's processes.)

Each header word is read and written whole: one aligned 8-byte load or store (`_word`,
`_set_word`: the header seen as unsigned 64-bit items for that access only, an item's assignment
a `memcpy` of 8 bytes; no view stays exported, so the mapping closes whenever the memory does).
Not `struct.pack_into`: CPython's struct zeroes the bytes it packs before writing them
(`s_pack_internal`'s `memset`), so a reader could see write_seq as 0 for a moment, set its next
record to 0 and read the whole ring again (a writer process then put up to 27 s of old frames a
second time: seen in `bench latency` as `publisher_stamps_repeated`, 618-2,728 in a 60 s run).
"""

from __future__ import annotations

import os
import select
import struct
import threading
from multiprocessing import resource_tracker, shared_memory

from wiithrow.listeners import after_batch

HEADER_WORDS = 8
HEADER_BYTES = 8 * HEADER_WORDS
WRITE_SEQ, READ_SEQ, DROPPED, SLEEPS = 0, 1, 2, 7
_RECORD_NUMBER = struct.Struct("<Q")  # a record's first 8 bytes, as its packer wrote them (read from a copy)


class FrameRing:
    """A ring of `slots` records of `slot_bytes` in shared memory (module docstring), created by
    the writer (`create`) and opened by the reader by `name` and `wake_fd` (`open`)."""

    def __init__(self, memory: shared_memory.SharedMemory, slots: int, slot_bytes: int, wake_fd: int, owner: bool):
        self.memory = memory
        self.slots = slots
        self.slot_bytes = slot_bytes
        self.wake_fd = wake_fd
        self.owner = owner
        assert memory.buf is not None  # open until `close`
        self.buf: memoryview = memory.buf
        self._next = 0  # the writer's next record, or the reader's
        self._woken_for = 0  # the writer's: the reader's sleep it last woke
        self._sleeps = 0  # the reader's
        self.closed = False
        self._wake_lock = threading.Lock()
        self._final: tuple[int, ...] = ()

    @classmethod
    def create(cls, slots: int, slot_bytes: int) -> FrameRing:
        memory = shared_memory.SharedMemory(create=True, size=HEADER_BYTES + slots * slot_bytes)
        ring_buffer = memory.buf
        assert ring_buffer is not None
        ring_buffer[:HEADER_BYTES] = bytes(HEADER_BYTES)
        wake = os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC)
        return cls(memory, slots, slot_bytes, wake, owner=True)

    @classmethod
    def open(cls, name: str, slots: int, slot_bytes: int, wake_fd: int, *, other_process: bool = True) -> FrameRing:
        memory = shared_memory.SharedMemory(name=name)
        if other_process:  # the creator unlinks it; this process's resource tracker must not (at our exit)
            resource_tracker.unregister(memory._name, "shared_memory")  # type: ignore[attr-defined]
        ring = cls(memory, slots, slot_bytes, wake_fd, owner=False)
        ring._next = ring.header()[1]
        return ring

    @property
    def name(self) -> str:
        return self.memory.name

    def header(self) -> tuple[int, ...]:
        with self.buf[:HEADER_BYTES].cast("Q") as words:
            return tuple(words)

    def _word(self, index: int) -> int:
        """Header word `index`, loaded whole (module docstring)."""
        with self.buf[:HEADER_BYTES].cast("Q") as words:
            return int(words[index])

    def _set_word(self, index: int, value: int) -> None:
        """Header word `index` := `value`, stored whole (never through a zeroed moment)."""
        with self.buf[:HEADER_BYTES].cast("Q") as words:
            words[index] = value

    # -- the writer

    def slot(self) -> tuple[int, int]:
        """The next record's number and its slot's offset in `buf` (pack it there, then `commit`)."""
        k = self._next
        return k, HEADER_BYTES + (k % self.slots) * self.slot_bytes

    def commit(self) -> None:
        """Publish the record packed at `slot()` and wake the reader (never blocks)."""
        self._next += 1
        self._set_word(WRITE_SEQ, self._next)

    def wake(self) -> None:
        """Wake the reader if it sleeps (module docstring): at once, or, inside a batch of a
        source's events (`wiithrow.listeners.batch`: a rig's poll), once when the batch ends, unless
        more than half the ring waits unread."""
        if self._next - self._word(READ_SEQ) > self.slots // 2 or not after_batch(self, self._wake_now):
            self._wake_now()  # (a long batch, a replay catching up, never fills the ring unread)

    def _wake_now(self) -> None:
        with self._wake_lock:  # (a deferred wake may come after another thread closed the ring)
            if self.closed:
                return
            sleeps = self._word(SLEEPS)
            if sleeps == self._woken_for:
                return
            self._woken_for = sleeps
            try:
                os.eventfd_write(self.wake_fd, 1)
            except OSError:  # the counter is full (the reader sleeps a long time): it is awake enough
                pass

    @property
    def written(self) -> int:
        return self._next

    # -- the reader

    def wait(self, timeout_s: float, others: tuple[int, ...] = ()) -> list[int]:
        """Sleep until woken (or one of `others` is readable) or `timeout_s`; the readable fds. No
        sleep if a record came meanwhile."""
        self._sleeps += 1
        self._set_word(SLEEPS, self._sleeps)
        if self._word(WRITE_SEQ) > self._next:
            return []
        ready = select.select([self.wake_fd, *others], [], [], timeout_s)[0]
        if self.wake_fd in ready:
            try:
                os.eventfd_read(self.wake_fd)
            except BlockingIOError:
                pass
        return ready

    def read(self) -> list[bytes]:
        """The records written since the last read, oldest first (copies); those lost are counted."""
        end = self._word(WRITE_SEQ)
        start = max(self._next, end - self.slots)
        lost = start - self._next
        records = []
        for k in range(start, end):
            offset = HEADER_BYTES + (k % self.slots) * self.slot_bytes
            records.append(bytes(self.buf[offset : offset + self.slot_bytes]))
        after = self._word(WRITE_SEQ)
        first_intact = after - self.slots + 1  # older slots may have been rewritten during the copy
        if start < first_intact:
            torn = min(first_intact, end) - start
            records = records[torn:]
            lost += torn
        self._next = end
        if lost:
            self._set_word(DROPPED, self._word(DROPPED) + lost)
        return [r for r in records if _RECORD_NUMBER.unpack_from(r, 0)[0] >= start]

    def acknowledge(self) -> None:
        """Tell the writer that what was read so far is done with (read_seq: its `flush` waits on it)."""
        self._set_word(READ_SEQ, self._next)

    def report(self, index: int, value: int) -> None:
        """The reader's figure `index` (3-6) for the writer to read (`figure`)."""
        self._set_word(index, max(0, int(value)))

    def figure(self, index: int) -> int:
        """Header word `index` (after `close`: as it was then)."""
        if self.closed:
            return self._final[index]
        return self._word(index)

    @property
    def read_seq(self) -> int:
        return self.figure(1)

    @property
    def dropped(self) -> int:
        return self.figure(2)

    def close(self) -> None:
        """Unmap (and, by its creator, unlink the memory and close the eventfd); the header's last
        values stay readable (`figure`)."""
        with self._wake_lock:
            if self.closed:
                return
            self._final = self.header()
            self.closed = True
        self.buf = memoryview(b"")
        try:
            self.memory.close()
        except BufferError:  # a view still exported somewhere: the mapping goes with the process
            pass
        if self.owner:
            try:
                self.memory.unlink()
            except FileNotFoundError:
                pass
            os.close(self.wake_fd)
