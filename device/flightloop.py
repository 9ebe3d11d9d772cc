"""The flight loop: fixed-rate sampling, the state machine, pyro outputs, the log.

``FlightLoop(hw, config, log).run()`` samples at the board's rate until the flight has landed
(or the board is disarmed on the pad). Each iteration:

1. waits for the next deadline ``t0 + k * period`` with ``ticks_us``/``ticks_diff`` (wrap-safe:
   the pad wait may be far longer than the 17.9 min ``ticks_us`` period). A late wake-up that
   passed whole deadlines counts them in ``missed`` and moves to the latest deadline passed; the
   sample's ``dt_us`` is the difference of the deadlines actually used, a multiple of the period
   (never silently absorbed: the filter predicts across it, the log records it);
2. ``sample(dt_us)``, the step: sensor reads, pressure to altitude, ``FlightComputer.step``,
   the pyro outputs, one log record, the status pattern. Allocation-free, and run under
   ``micropython.heap_lock()`` (``LOCK_HEAP``): see below;
3. ``after_sample()``, the safe point: pulse guards, status pattern changes, the resume record
   (``device/resume.py``: at every event, and every 0.1 s where there is RTC memory),
   pad epochs, flushing log blocks (descent only) and garbage collection (pad only, at block
   boundaries, and after a flush).

Pad epochs. The log must let ``python -m desktop replay`` reproduce the board's decisions bit for
bit, which needs every sample since the flight computer started; a pad wait can last an hour.
So on the pad a second ("shadow") flight computer starts at a log block boundary and is stepped
with the same readings; after ``PAD_EPOCH_S`` it replaces the first one (at a block boundary,
only while both are on the pad and quiet), and the RAM log keeps only the records from the start
of the one in use. The one in use at launch has between one and two epochs of pad behind it: a
full calibration (DESIGN.md D8), and a log that starts where it started.

Heap lock. With the heap unlocked, MicroPython allocates the frame of every call that needs more
than a few words on the heap and frees it on return; locked, those frames go on the C stack. On a
Cortex-M0 (MicroPython's qemu port, tools/armboard.py) the locked step costs 29-63 % less and is
allocation-free by construction (docs/ARM.md), so the loop runs ``sample()`` locked. A
sensor's exception is still raised and caught under the lock (MicroPython then uses its static
emergency exception object). An allocation the tests never met would raise ``MemoryError`` in
the middle of a sample: the loop counts it (``heap_lock_faults``), runs the rest of the flight
unlocked, and goes on with the next sample.
"""

import gc
import sys
from time import sleep_us, ticks_add, ticks_diff, ticks_ms, ticks_us

import micropython

from device import flightlog
from device.flightlog import BLOCK_RECORDS
from shared.altitude import pressure_to_alt_mm
from shared.flight import (
    DROGUE,
    EV_BACKUP_DROGUE,
    EV_BACKUP_MAIN,
    EV_DROGUE,
    EV_LANDED,
    EV_LAUNCH,
    EV_MAIN,
    LANDED,
    MAIN,
    PAD,
    FlightComputer,
)

PAD_EPOCH_S = flightlog.PAD_EPOCH_S
MAX_MISSED = 1000  # deadlines counted per wake-up at most (keeps ticks arithmetic small)
FLUSH_MARGIN_MM = 100000  # under the drogue, write blocks only this far above the main altitude
GUARD_MARGIN_MS = 100  # pulse guard: the hardware timer cuts the output this long after the pulse
DISARM_DEBOUNCE_MS = 500
# Disarming with the arming input works on the pad, and after a launch detection that has not
# been proven (a hard knock, the rocket carried to the pad) while the filtered altitude stays
# below this: no firing path is open then (DESIGN.md D1). A real boost passes it in well under
# DISARM_DEBOUNCE_MS, so a switch bouncing open at ignition cannot disarm a flight.
NOT_FLOWN_MM = 10000
LOCK_HEAP = True  # run sample() under micropython.heap_lock() (see the module docstring)
# The 32-bit wasm MicroPython's collector corrupts its heap when called inside functions.
_CAN_COLLECT = getattr(sys.implementation, "_build", "") != "wasi"


def collect():
    if _CAN_COLLECT:
        gc.collect()


class FlightLoop:
    def __init__(self, hw, config, log, logfile=None, resume=None, fc=None, fc_start=0):
        self.hw = hw
        self.cfg = config
        self.sensors = hw.sensors
        self.pyro = hw.pyro
        self.status = hw.status
        self.log = log
        self.logfile = logfile
        self.resume = resume
        self.period_us = 1000000 // hw.board["sample_hz"]
        self.fc = fc if fc is not None else FlightComputer(config)
        self.fc_start = fc_start
        log.fc_start = fc_start
        log.keep_from = fc_start
        self.shadow = None
        self.shadow_start = 0
        self.shadow_blocks = 0
        rate = hw.board["sample_hz"]
        self.save_every = rate // 10 if rate >= 10 else 1  # resume record every 0.1 s (RTC memory)
        self.epoch_blocks = (PAD_EPOCH_S * rate + BLOCK_RECORDS - 1) // BLOCK_RECORDS
        if log.nslots < flightlog.pad_blocks_needed(rate):
            raise ValueError("log_ram_kb too small: the pad needs %d KB at %d Hz" % (
                flightlog.pad_blocks_needed(rate) * flightlog.BLOCK_SIZE // 1024, rate))
        self.handovers = 0
        self.samples = 0
        self.missed = 0
        self.worst_late_us = 0
        self.worst_work_us = 0
        self.worst_dt_us = 0
        self.lock_heap = LOCK_HEAP
        self.heap_lock_faults = 0  # MemoryErrors raised by sample() under the heap lock
        self.events_seen = 0
        self.event_log = []  # (sample index, events, agl_mm) appended at safe points
        self.done = False
        self.reason = ""
        self.max_samples = 0  # 0: no limit (tests, bench)
        self._last_err = 0
        self._last_state = -1
        self._disarm_since = None
        self._resumed = False
        self.wdt = hw.wdt
        self.disarm_input = hw.armed_input() is not None
        self.status.idle()

    # -- the loop ----------------------------------------------------------------------------------

    def run(self):
        period = self.period_us
        prev = ticks_us()
        deadline = ticks_add(prev, period)
        while not self.done:
            while True:
                d = ticks_diff(deadline, ticks_us())
                if d <= 0:
                    break
                sleep_us(d)
            late = ticks_diff(ticks_us(), deadline)
            if late >= period:
                k = late // period
                if k > MAX_MISSED:
                    k = MAX_MISSED
                deadline = ticks_add(deadline, k * period)
                self.missed += k
                late -= k * period
            if late > self.worst_late_us:
                self.worst_late_us = late
            dt_us = ticks_diff(deadline, prev)
            prev = deadline
            if self.wdt is not None:
                self.wdt.feed()
            if self.lock_heap:
                micropython.heap_lock()
                try:
                    self.sample(dt_us)
                except MemoryError:
                    # an allocation on a path no test took: this sample is cut short; fly on
                    # unlocked so that it cannot cost every following sample too
                    self.heap_lock_faults += 1
                    self.lock_heap = False
                finally:
                    micropython.heap_unlock()
            else:
                self.sample(dt_us)
            deadline = ticks_add(deadline, period)
            self.after_sample()
            if self.max_samples and self.samples >= self.max_samples:
                self.done = True
                self.reason = "sample limit"
        return self.reason

    def sample(self, dt_us):
        """One sample: read, step, drive, log. Allocation-free."""
        t0 = ticks_us()
        s = self.sensors
        s.read()
        have = s.have
        p = s.pressure_q4_pa
        acc = s.accel_mmps2
        alt = pressure_to_alt_mm(p)
        fc = self.fc
        fc.step(dt_us, alt, acc, have)
        sh = self.shadow
        if sh is not None:
            sh.step(dt_us, alt, acc, have)
        self.pyro.drive(fc.pyro_drogue, fc.pyro_main, fc.pyro_backup_drogue, fc.pyro_backup_main)
        flags = 0
        if fc.pyro_drogue:
            flags = flightlog.FLAG_PYRO_DROGUE
        if fc.pyro_main:
            flags |= flightlog.FLAG_PYRO_MAIN
        if fc.pyro_backup_drogue:
            flags |= flightlog.FLAG_PYRO_BACKUP_DROGUE
        if fc.pyro_backup_main:
            flags |= flightlog.FLAG_PYRO_BACKUP_MAIN
        e = s.baro_errors + s.accel_errors
        if e != self._last_err:
            self._last_err = e
            flags |= flightlog.FLAG_SENSOR_ERROR
        if dt_us > self.period_us + (self.period_us >> 1):
            flags |= flightlog.FLAG_MISSED
            if dt_us > self.worst_dt_us:
                self.worst_dt_us = dt_us
        if self._resumed:
            flags |= flightlog.FLAG_RESUMED
            self._resumed = False
        self.events_seen |= fc.events
        work = ticks_diff(ticks_us(), t0)
        if work > self.worst_work_us:
            self.worst_work_us = work
        kf = fc.kf
        self.log.record(dt_us, p, acc, kf.alt_q4, kf.vel_q4, kf.acc_q4, have, fc.state,
                        fc.events & flightlog.EVENTS_MASK, flags,
                        s.temp_cdeg, work if work < 65535 else 65535)
        self.status.update(ticks_ms())
        self.samples += 1

    # -- the safe point ----------------------------------------------------------------------------

    def after_sample(self):
        fc = self.fc
        log = self.log
        ev = self.events_seen
        self.events_seen = 0
        if ev:
            self.event_log.append((log.sample - 1, ev, fc.agl_mm))
            if ev & EV_LAUNCH:
                self.shadow = None
                log.keep_from = self.fc_start
                log.freeze()
            if ev & EV_DROGUE:
                self.pyro.guard(0, self.cfg.pulse_ms + GUARD_MARGIN_MS)
            if ev & EV_MAIN:
                self.pyro.guard(1, self.cfg.pulse_ms + GUARD_MARGIN_MS)
            if ev & EV_BACKUP_DROGUE:
                self.pyro.guard(2, self.cfg.pulse_ms + GUARD_MARGIN_MS)
            if ev & EV_BACKUP_MAIN:
                self.pyro.guard(3, self.cfg.pulse_ms + GUARD_MARGIN_MS)
            if ev & EV_LANDED:
                self.done = True
                self.reason = "landed"
        state = fc.state
        if state != self._last_state or ev:
            if state != self._last_state:
                self._last_state = state
                self._state_changed(state)
            if self.resume is not None:
                self.resume.save(1 if state == PAD else (3 if state == LANDED else 2), fc, log.sample,
                                 self.fc_start, True)
        elif self.resume is not None and state != PAD and self.samples % self.save_every == 0:
            self.resume.save(2, fc, log.sample, self.fc_start, False)  # RTC memory only
        if self.disarm_input:
            if state == PAD or (not fc.flight_proven and fc.agl_mm < NOT_FLOWN_MM):
                if self._disarmed():
                    self.done = True
                    self.reason = "disarmed"
                    return
            else:
                self._disarm_since = None
        if state == PAD:
            self._pad_safe_point()
        elif state >= DROGUE and not (fc.pyro_drogue or fc.pyro_main or fc.pyro_backup_drogue
                                      or fc.pyro_backup_main) and log.pending():
            if state >= MAIN or fc.agl_mm > self.cfg.main_deploy_mm + FLUSH_MARGIN_MM:
                log.write_one(self.logfile)
                collect()

    def _state_changed(self, state):
        st = self.status
        if state == PAD:
            st.armed(self.pyro.continuity_bits())
        elif state < DROGUE:
            st.flight()
        elif state < LANDED:
            st.descent()

    def _pad_safe_point(self):
        log = self.log
        fc = self.fc
        if not log.block_boundary():
            return
        # a new block starts with the next record: pad epochs and garbage collection happen here
        if self.shadow is not None:
            self.shadow_blocks += 1
            sh = self.shadow
            if (self.shadow_blocks >= self.epoch_blocks and fc.state == PAD and sh.state == PAD
                    and fc.boost_ms == 0 and sh.boost_ms == 0):
                self.fc = sh
                self.fc_start = self.shadow_start
                log.fc_start = self.fc_start
                log.keep_from = self.fc_start
                self.shadow = None
                self.handovers += 1
        if self.shadow is None:
            self.shadow = FlightComputer(self.cfg)
            self.shadow_start = log.sample
            self.shadow_blocks = 0
        self.status.armed(self.pyro.continuity_bits())
        collect()

    def _disarmed(self):
        if self.hw.armed_input():
            self._disarm_since = None
            return False
        now = ticks_ms()
        if self._disarm_since is None:
            self._disarm_since = now
            return False
        return ticks_diff(now, self._disarm_since) >= DISARM_DEBOUNCE_MS

    def summary(self):
        """Figures for the log's summary block and the console (allocates)."""
        fc = self.fc
        s = self.sensors
        return {
            "reason": self.reason,
            "samples": self.samples,
            "missed_deadlines": self.missed,
            "worst_late_us": self.worst_late_us,
            "worst_dt_us": self.worst_dt_us,
            "worst_work_us": self.worst_work_us,
            "heap_lock_faults": self.heap_lock_faults,
            "max_agl_mm": fc.max_agl_mm,
            "max_vel_mmps": fc.max_vel_mmps,
            "state": fc.state,
            "flight_proven": fc.flight_proven,
            "errors": fc.errors,
            "baro_errors": s.baro_errors,
            "accel_errors": s.accel_errors,
            "fc_start": self.fc_start,
            "handovers": self.handovers,
            "log_dropped": self.log.dropped,
            "log_incomplete": self.log.incomplete,
            "log_write_failures": self.log.write_failures,
            "log_over_cap": self.log.over_cap,
            "events": [[i, ev, agl] for (i, ev, agl) in self.event_log],
        }
