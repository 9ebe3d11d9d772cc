"""The simulated world of a software-in-the-loop run: publishes precomputed sensor data into the
register-level fakes at the simulated time (MicroPython and CPython).

The frames file (written on the host by ``desktop/hosts/sil/flightgen.py``) holds, every ``frame_us``, the
raw data registers of a BMP3xx barometer (0x04..0x09, published only on frames where the
barometer completes a conversion, which also sets its data-ready bits) and of an ADXL375
accelerometer (0x32..0x37), and up to two stalls: at a frame, the bus transaction in progress
takes that much longer (a flash erase, a bus clock stretch). ``sync(elapsed_us)`` (called by the
fake I2C bus before every transaction) copies every frame up to that time into the fakes'
register files: byte by byte, so the copy allocates nothing inside a heap-locked sample.
Faults: the barometer or the accelerometer dies (every transaction raises ``OSError(5)``) from a
given frame on.
"""

import struct

from desktop.hosts.sil import fake_time

MAGIC = 0x57534C49  # b"ILSW"
# magic, frame_us, frames, kill_baro_frame, kill_accel_frame (-1: never), two stalls (frame, us)
HDR_FMT = "<IIIiiiiii"
HDR_SIZE = 36
FRAME_SIZE = 13  # flags, baro 6 bytes, accel 6 bytes
FLAG_BARO_NEW = 1


class World:
    def __init__(self, path, baro, accel):
        with open(path, "rb") as f:
            data = f.read()
        (magic, self.frame_us, self.frames, self.kill_baro, self.kill_accel, s1, u1, s2,
         u2) = struct.unpack_from(HDR_FMT, data, 0)
        self.stalls = ((s1, u1), (s2, u2))
        self.stalled = 0
        if magic != MAGIC:
            raise ValueError("not a SIL frames file")
        self.data = bytearray(data)
        self.baro = baro
        self.accel = accel
        self.idx = -1
        self.end_us = self.frames * self.frame_us

    def sync(self, elapsed_us):
        k = elapsed_us // self.frame_us
        if k >= self.frames:
            k = self.frames - 1
        while self.idx < k:
            self.idx += 1
            self._apply(self.idx)

    def _apply(self, i):
        d = self.data
        off = HDR_SIZE + i * FRAME_SIZE
        if d[off] & FLAG_BARO_NEW:
            r = self.baro.regs
            for j in range(6):
                r[0x04 + j] = d[off + 1 + j]
            r[0x03] |= 0x60
        r = self.accel.regs
        if r[0x2D] & 0x08:  # measuring
            for j in range(6):
                r[0x32 + j] = d[off + 7 + j]
        if i == self.kill_baro:
            self.baro.fail_after(0)
        if i == self.kill_accel:
            self.accel.fail_after(0)
        for frame, us in self.stalls:
            if i == frame:
                self.stalled += us
                fake_time.advance(us)
