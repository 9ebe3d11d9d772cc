"""Resume after a reset in flight: the one place that saves and restores the flight state.

DESIGN.md D3 and D14: a reset in flight (brown-out when a charge fires, watchdog) must not
re-calibrate "ground" at altitude, and the board must never silently enter pad mode after a reboot
that cannot prove it is on the ground.

Two things are stored:

- ``armed.flag``: a file written (and read back) when the board arms, on the pad (a safe time for
  flash), removed when it disarms or has landed and closed its log. A boot that finds it knows the
  last session ended in a reset while armed.
- the resume record (``FlightComputer.save_state``: 16 bytes) with a small header. Saved every
  0.1 s in flight and at every event, at the safe point after the sample, into memory that
  survives the resets that happen in flight (DESIGN.md D14 has the table per board and cause):
  the RP2040's four free watchdog scratch registers (``backend == "scratch"``: the record alone,
  no header), the ESP32's RTC memory (``"rtc"``), else the file ``resume.bin`` (at events only: a
  flash write stalls the CPU, DESIGN.md D5).

On boot with ``armed.flag`` present, the app restores the record if it is a flight record the
flight computer accepts; otherwise it stays disarmed with error 7 until the arming input is cycled.
"""

import struct

try:
    from binascii import crc32
except ImportError:  # pragma: no cover
    from zlib import crc32

FLAG_FILE = "armed.flag"
RECORD_FILE = "resume.bin"
MAGIC = 0x2AFC
PHASE_NONE = 0
PHASE_PAD = 1
PHASE_FLIGHT = 2
PHASE_LANDED = 3
_HDR_FMT = "<HBBIIII"  # magic, phase, state, sample index, fc_start, snapshot length, crc of it
_HDR_SIZE = 20


def _snapshot_size():
    try:
        from shared.flight import STATE_RECORD_SIZE
    except ImportError:
        return 0
    return STATE_RECORD_SIZE


# RP2040 watchdog block (datasheet 4.7.6): SCRATCH0..3 at 0x4005800C..0x40058018 are free for the
# application (SCRATCH4..7 belong to the boot ROM); a watchdog or software reset keeps them, a
# power-on or brown-out reset clears them.
RP2040_SCRATCH0 = 0x4005800C


class ResumeStore:
    def __init__(self, machine, mcu=None):
        self.rtc = None
        self.mem32 = None
        if mcu in ("rp2040", "rp2350") and hasattr(machine, "mem32"):
            self.mem32 = machine.mem32
        else:
            try:
                rtc = machine.RTC()
                rtc.memory()  # AttributeError where the port has no RTC memory
                self.rtc = rtc
            except Exception:  # noqa: BLE001
                self.rtc = None
        self.backend = "scratch" if self.mem32 is not None else ("rtc" if self.rtc is not None else "file")
        self.words = None
        self.snap_size = _snapshot_size()
        self.buf = bytearray(_HDR_SIZE + self.snap_size)
        self.mv = memoryview(self.buf)
        if self.mem32 is not None:
            from array import array

            self.words = array("I", bytes(self.snap_size))
        self.saves = 0
        self.failures = 0

    @property
    def can_resume(self):
        return self.snap_size > 0

    # -- the armed flag (pad only) -----------------------------------------------------------------

    def set_armed_flag(self, text="armed"):
        """Write the flag and read it back; False (counted) when either fails."""
        try:
            with open(FLAG_FILE, "w") as f:
                f.write(text)
            with open(FLAG_FILE) as f:
                if f.read() == text:
                    return True
        except OSError:
            pass
        self.failures += 1
        return False

    def armed_flag(self):
        try:
            with open(FLAG_FILE) as f:
                return f.read() or "armed"
        except OSError:
            return None

    def clear_armed_flag(self):
        import os

        try:
            os.remove(FLAG_FILE)
        except OSError:
            pass

    # -- the resume record -------------------------------------------------------------------------

    def save(self, phase, fc, sample, fc_start, event=True):
        """Write the record (at safe points). ``event`` False: the periodic save, memory only."""
        if self.mem32 is not None:
            return self._save_scratch(fc)
        if not event and self.rtc is None:
            return False
        buf = self.buf
        n = 0
        if fc is not None and self.snap_size and hasattr(fc, "save_state"):
            fc.save_state(self.mv[_HDR_SIZE:])
            n = self.snap_size
        state = fc.state if fc is not None else 0
        crc = crc32(self.mv[_HDR_SIZE:_HDR_SIZE + n]) & 0xFFFFFFFF
        struct.pack_into(_HDR_FMT, buf, 0, MAGIC, phase, state, sample, fc_start, n, crc)
        try:
            if self.rtc is not None:
                self.rtc.memory(buf)
            else:
                with open(RECORD_FILE, "wb") as f:
                    f.write(buf)
            self.saves += 1
            return True
        except Exception:  # noqa: BLE001 - a failed save must not stop a flight
            self.failures += 1
            return False

    def _save_scratch(self, fc):
        """The 16-byte record into the four scratch registers (no allocation: 30-bit words)."""
        if fc is None:
            return False
        fc.save_state(self.mv[_HDR_SIZE:])
        words = self.words
        mem = self.mem32
        for i in range(4):
            words[i] = self.buf[_HDR_SIZE + 4 * i] | self.buf[_HDR_SIZE + 4 * i + 1] << 8 | (
                self.buf[_HDR_SIZE + 4 * i + 2] << 16) | self.buf[_HDR_SIZE + 4 * i + 3] << 24
            mem[RP2040_SCRATCH0 + 4 * i] = words[i]
        self.saves += 1
        return True

    def clear(self):
        if self.mem32 is not None:
            for i in range(4):
                self.mem32[RP2040_SCRATCH0 + 4 * i] = 0
            return
        if self.rtc is not None:
            try:
                self.rtc.memory(b"")
            except Exception:  # noqa: BLE001
                pass
        else:
            import os

            try:
                os.remove(RECORD_FILE)
            except OSError:
                pass

    def load(self):
        """The saved record as a dict (phase, state, sample, fc_start, snapshot bytes), or None."""
        if self.mem32 is not None:
            snap = bytearray(16)
            for i in range(4):
                struct.pack_into("<I", snap, 4 * i, self.mem32[RP2040_SCRATCH0 + 4 * i] & 0xFFFFFFFF)
            state = snap[3] & 7  # the record's own header (shared/flight.py save_state)
            phase = PHASE_FLIGHT if 0 < state < 6 else (PHASE_LANDED if state == 6 else PHASE_NONE)
            return {"phase": phase, "state": state, "sample": 0, "fc_start": 0, "snapshot": bytes(snap)}
        try:
            if self.rtc is not None:
                data = bytes(self.rtc.memory())
            else:
                with open(RECORD_FILE, "rb") as f:
                    data = f.read()
        except Exception:  # noqa: BLE001
            return None
        if len(data) < _HDR_SIZE:
            return None
        magic, phase, state, sample, fc_start, n, crc = struct.unpack_from(_HDR_FMT, data, 0)
        if magic != MAGIC or len(data) < _HDR_SIZE + n:
            return None
        snap = data[_HDR_SIZE:_HDR_SIZE + n]
        if crc32(snap) & 0xFFFFFFFF != crc:
            return None
        return {"phase": phase, "state": state, "sample": sample, "fc_start": fc_start, "snapshot": snap}

    def restore(self, fc, record, gap_ms=0):
        """Put a saved snapshot into ``fc``, ``gap_ms`` after it was saved; True when the flight
        computer accepted it."""
        snap = record["snapshot"]
        if not snap or not hasattr(fc, "restore_state") or len(snap) != self.snap_size:
            return False
        try:
            return bool(fc.restore_state(bytearray(snap), gap_ms))
        except Exception:  # noqa: BLE001
            return False
