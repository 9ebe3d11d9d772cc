"""Flight log writer: fixed-size binary records, buffered in RAM blocks, written to flash at safe
points.

The record and block layout, flags and CRC are in ``shared/logformat.py`` (shared with the desktop
decoder, ``desktop/io/logdecode.py``); this module adds the board's side: the RAM ring of blocks
and the file's JSON header (the firmware version, the board description, the flight configuration
(``config``: the user-facing values), the sample period and the record layout).

Power loss: a block is written whole and the file flushed after each block, so a power loss loses
at most the block being written (the decoder checks every block's CRC and sequence number) and
the blocks still in RAM. Records are buffered in RAM from the pad through apogee: nothing is
written to flash in boost or coast (DESIGN.md D5: flash programming stalls the CPU).
"""

import struct

from shared.logformat import (  # noqa: F401 - FLAG_*, KIND_*, FORMAT_VERSION and REC_* are the board's API
    BLK_CRC_OFFSET,
    BLK_FMT,
    BLK_HDR,
    BLK_MAGIC,
    BLOCK_RECORDS,
    BLOCK_SIZE,
    EVENTS_MASK,
    FILE_HDR_FMT,
    FILE_MAGIC,
    FLAG_MISSED,
    FLAG_PYRO_BACKUP_DROGUE,
    FLAG_PYRO_BACKUP_MAIN,
    FLAG_PYRO_DROGUE,
    FLAG_PYRO_MAIN,
    FLAG_RESUMED,
    FLAG_SENSOR_ERROR,
    FORMAT_VERSION,
    KIND_DATA,
    KIND_NOTE,
    KIND_SUMMARY,
    REC_FIELDS,
    REC_FMT,
    REC_SIZE,
    block_crc_ok,
    crc32,
)

try:
    from array import array
except ImportError:  # pragma: no cover
    array = None


PAD_EPOCH_S = 4  # device/flightloop.py: a new flight computer takes over on the pad this often


def pad_blocks_needed(sample_hz):
    """RAM blocks the pad needs at ``sample_hz``: two pad epochs and a margin."""
    epoch = (PAD_EPOCH_S * sample_hz + BLOCK_RECORDS - 1) // BLOCK_RECORDS
    return 2 * epoch + 3


class LogBuffer:
    """RAM ring of blocks. ``record()`` is allocation-free; everything else runs at safe points.

    Slots hold blocks in sample order: ``count`` full blocks from ``head``, then the block being
    filled (``cur``; -1 when none). On the pad (not ``frozen``) a full ring reuses its oldest block:
    the pad keeps only the records from ``keep_from`` (the start of the flight computer in use)
    on. After launch (``freeze()``) nothing is discarded: a full ring drops new records (counted in
    ``dropped``) until a flush frees a block.
    """

    def __init__(self, ram_bytes):
        n = ram_bytes // BLOCK_SIZE
        if n < 4:
            n = 4
        self.nslots = n
        self.buf = bytearray(n * BLOCK_SIZE)
        self.mv = memoryview(self.buf)
        self.slot_first = array("i", bytearray(4 * n))
        self.slot_fcstart = array("i", bytearray(4 * n))
        self.slot_seq = array("i", bytearray(4 * n))
        self.head = 0
        self.count = 0
        self.cur = -1
        self.cur_n = 0
        self.seq = 0
        self.sample = 0  # index of the next record
        self.keep_from = 0
        self.fc_start = 0
        self.frozen = False
        self.dropped = 0  # records lost because the ring was full after launch
        self.discarded = 0  # pad blocks reused
        self.incomplete = False  # a pad block still needed was reused (ring too small)
        self.written = 0  # blocks written to the file
        self.write_failures = 0
        self.max_blocks = 0  # file size cap in blocks (0: none); blocks past it are not written
        self.over_cap = 0

    def record(self, dt_us, pressure_q4_pa, accel_mmps2, alt_q4, vel_q4, acc_q4, have, state, events,
               flags, temp_cdeg, work_us):
        cur = self.cur
        if cur < 0:
            cur = self._acquire()
            if cur < 0:
                self.dropped += 1
                self.sample += 1
                return
        n = self.cur_n
        if n == 0:
            self.slot_first[cur] = self.sample
            self.slot_fcstart[cur] = self.fc_start
            self.slot_seq[cur] = self.seq
            self.seq += 1
        struct.pack_into(REC_FMT, self.buf, cur * BLOCK_SIZE + BLK_HDR + n * REC_SIZE, dt_us,
                         pressure_q4_pa, accel_mmps2, alt_q4, vel_q4, acc_q4, have, state, events,
                         flags, temp_cdeg, work_us)
        self.sample += 1
        n += 1
        if n == BLOCK_RECORDS:
            self.count += 1
            self.cur_n = 0
            self.cur = -1
        else:
            self.cur_n = n

    def _acquire(self):
        n = self.nslots
        if self.count >= n:
            if self.frozen:
                return -1
            head = self.head
            if self.slot_first[head] + BLOCK_RECORDS > self.keep_from:
                self.incomplete = True
            self.head = head + 1 if head + 1 < n else 0
            self.count -= 1
            self.discarded += 1
        cur = self.head + self.count
        if cur >= n:
            cur -= n
        self.cur = cur
        self.cur_n = 0
        return cur

    def block_boundary(self):
        """True when the next record starts a new block (handover and GC happen here)."""
        return self.cur_n == 0

    def freeze(self):
        """Launch: drop the pad blocks before ``keep_from``; from now on nothing is discarded."""
        n = self.nslots
        while self.count and self.slot_first[self.head] + BLOCK_RECORDS <= self.keep_from:
            self.head = self.head + 1 if self.head + 1 < n else 0
            self.count -= 1
            self.discarded += 1
        self.frozen = True

    def _seal(self, slot, nrec, kind):
        base = slot * BLOCK_SIZE
        struct.pack_into(BLK_FMT, self.buf, base, BLK_MAGIC, self.slot_seq[slot], self.slot_first[slot],
                         nrec, kind, self.slot_fcstart[slot], 0)
        for i in range(base + 24, base + BLK_HDR):
            self.buf[i] = 0
        crc = crc32(self.mv[base:base + BLOCK_SIZE]) & 0xFFFFFFFF
        struct.pack_into("<I", self.buf, base + BLK_CRC_OFFSET, crc)

    def _write_slot(self, f, slot):
        base = slot * BLOCK_SIZE
        if self.max_blocks and self.written >= self.max_blocks:
            self.over_cap += 1
            return
        try:
            f.write(self.mv[base:base + BLOCK_SIZE])
            f.flush()
            self.written += 1
        except Exception:  # noqa: BLE001 - a full or failing filesystem must not stop a flight
            self.write_failures += 1

    def pending(self):
        return self.count

    def write_one(self, f):
        """Write the oldest full block (a safe point: may stall for a flash erase)."""
        if not self.count:
            return False
        slot = self.head
        self._seal(slot, BLOCK_RECORDS, KIND_DATA)
        if f is not None:
            self._write_slot(f, slot)
        self.head = slot + 1 if slot + 1 < self.nslots else 0
        self.count -= 1
        return True

    def write_all(self, f, feed=None):
        """Write every full block and the partly filled one (landing, disarming). ``feed`` is
        called between blocks (the watchdog: tens of flash writes take longer than its timeout)."""
        if not self.frozen:
            self.freeze()
        while self.write_one(f):
            if feed is not None:
                feed()
        if self.cur >= 0 and self.cur_n > 0:
            slot = self.cur
            base = slot * BLOCK_SIZE
            self.buf[base + BLK_HDR + self.cur_n * REC_SIZE:base + BLOCK_SIZE] = bytes(
                (BLOCK_RECORDS - self.cur_n) * REC_SIZE)
            self._seal(slot, self.cur_n, KIND_DATA)
            if f is not None:
                self._write_slot(f, slot)
            self.cur = -1
            self.cur_n = 0

    def write_text(self, f, kind, text):
        """A summary or note block carrying UTF-8 JSON (at most BLOCK_SIZE - BLK_HDR bytes)."""
        data = text.encode() if isinstance(text, str) else bytes(text)
        data = data[:BLOCK_SIZE - BLK_HDR]
        block = bytearray(BLOCK_SIZE)
        struct.pack_into(BLK_FMT, block, 0, BLK_MAGIC, self.seq, self.sample, len(data), kind,
                         self.fc_start, 0)
        block[BLK_HDR:BLK_HDR + len(data)] = data
        crc = crc32(block) & 0xFFFFFFFF
        struct.pack_into("<I", block, BLK_CRC_OFFSET, crc)
        self.seq += 1
        if f is not None:
            try:
                f.write(block)
                f.flush()
                self.written += 1
            except Exception:  # noqa: BLE001
                self.write_failures += 1


def file_header(header_json):
    """The bytes that start a log file, for a header JSON string."""
    data = header_json.encode()
    return FILE_MAGIC + struct.pack(FILE_HDR_FMT, len(data), crc32(data) & 0xFFFFFFFF) + data

