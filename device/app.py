"""The flight computer application: idle, arming, pad checks, flight, landed.

``main.py`` calls ``main()``. Sequence (docs/FIRMWARE.md has the user's version):

1. (boot.py already drove every pyro output low.) Read ``board.json`` and ``config.json``,
   build the hardware; start-up errors are beeped, never raised.
2. Reset check: if ``armed.flag`` exists the last session ended in a reset while armed. With a
   resume record of a flight in progress that the flight computer accepts, the flight resumes at
   once (``device/resume.py``: no pad checks, no new ground); otherwise the board stays disarmed
   with error 7 until the arming input is cycled off and on.
3. Idle (disarmed): LED heartbeat, Ctrl-C works, ground tests and bench flights are allowed. Arming
   needs the arming input turned on (after a power-on reset it may already be on; after any other
   reset it must be seen off first), or, on boards without one, ``main(arm="arm")``.
4. Pad checks: sensors alive, pressure plausible, the accelerometer axis and magnitude about +1 g,
   continuity on every channel that has a sense input (a backup channel: when configured), room
   for the log. Any failure: error beeps, disarmed.
5. Flight mode: Ctrl-C disabled (``micropython.kbd_intr(-1)``), watchdog running, ``armed.flag``
   written, log header written, then ``FlightLoop.run()`` until landed (or disarmed on the pad).
6. Landed: log flushed and closed, Ctrl-C restored, the maximum altitude beeped in digits forever
   (the watchdog keeps being fed).
"""

import json
import os
from time import sleep_ms, ticks_diff, ticks_ms, ticks_us

import micropython

from device import board as boardmod
from device import flightlog, status
from device.board import BoardError, Hardware
from device.flightloop import FlightLoop, collect
from device.resume import PHASE_FLIGHT, PHASE_LANDED, ResumeStore
from shared.altitude import pressure_to_alt_mm
from shared.config import ConfigError, ConfigFileMissing, load_config, load_config_file
from shared.flight import STATE_NAMES, FlightComputer
from shared.physics import G_MMPS2

FIRMWARE_VERSION = "0.1.0"
LOG_PATH = "flight.log"
ARM_DEBOUNCE_MS = 1000
PAD_CHECK_S = 1
PRESSURE_MIN_Q4 = 30000 * 16  # 30 kPa: about 9 km
PRESSURE_MAX_Q4 = 110000 * 16
# The barometer's noise at rest, above which the board does not arm: a faulty part, or a port open
# to the wind. Measured (docs/BENCHMARKS.md, "A barometer too noisy to fly"): a barometer-only board
# flies to apogee with 10 m rms, 0.4 to 3.6 s late with 12 m, on its backup timer with 15 m (and
# once launched 17 s late: the climb re-based as pressure steps, the main at 5.5 km). Real parts
# read 0.1 to 1 m. Half the edge, for every board
BARO_NOISE_MAX_CM = 500
LOG_SPACE_MARGIN = 16384
SAVE_PERIOD_MS = 100  # the resume record is saved at least this often in flight (device/flightloop.py)
CURRENT = None  # the running App, for inspection over mpremote (``app.CURRENT.last_summary``)


def _machine():
    import machine

    return machine


class App:
    def __init__(self, board_path="board.json", config_path="config.json", log_path=LOG_PATH):
        global CURRENT
        CURRENT = self
        self.machine = _machine()
        self.errors = []  # (code, text)
        self.log_path = log_path
        self.hw = None
        self.board = boardmod.load(board_path)  # BoardError: main() prints it and stops
        try:
            self.config = load_config_file(config_path)
        except ConfigFileMissing:
            self.config = load_config({})
            print("config: %s not found, using the defaults" % config_path)
        except ConfigError as exc:
            self.config = load_config({})
            self.errors.append((status.ERR_FILES, str(exc)))
        try:
            boardmod.check_with_config(self.board, self.config)
        except BoardError as exc:
            self.errors.append((status.ERR_FILES, str(exc)))
        problem = boardmod.check_pyro_pins_file(self.board)
        if problem:  # boot.py drove these pins low at reset: they must be the pyro pins
            self.errors.append((status.ERR_FILES, problem))
        self.hw = Hardware(self.board, self.machine)
        self.errors += self.hw.errors
        self.resume = ResumeStore(self.machine, self.board["mcu"])
        self.unexpected_reset = False
        self.last_summary = None
        self.last_loop = None

    # -- helpers ------------------------------------------------------------------------------------

    def say(self, text):
        print("[apogee-fc] " + text)

    def show_errors(self):
        st = self.hw.status
        if self.errors:
            st.error(self.errors[0][0])
        else:
            st.idle()

    def reset_gap_ms(self):
        """The worst case of the flight time a reset cost (DESIGN.md D14): the board's measured
        boot time, plus the time since the last save: up to the watchdog's timeout after a
        watchdog reset (the loop stalled that long), else one save period (0.1 s)."""
        m = self.machine
        try:
            wdt = m.reset_cause() == m.WDT_RESET
        except Exception:  # noqa: BLE001 - a port without reset_cause: assume the worst
            wdt = True
        return self.board["boot_ms"] + (self.board["watchdog_ms"] if wdt else SAVE_PERIOD_MS)

    def power_on_reset(self):
        m = self.machine
        try:
            return m.reset_cause() == m.PWRON_RESET
        except Exception:  # noqa: BLE001
            return False

    # -- top level ------------------------------------------------------------------------------------

    def run(self, arm=None, idle_limit_ms=None, landed_beep_ms=None):
        """Idle until armed, fly, beep. ``idle_limit_ms`` returns from idle (tests, tools)."""
        hw = self.hw
        try:
            for code, text in self.errors:
                self.say("error %d (%s): %s" % (code, status.ERROR_NAMES.get(code, "?"), text))
            if self.resume.armed_flag() is not None:
                rec = self.resume.load()
                if rec is not None and rec["phase"] == PHASE_FLIGHT and self.resume.can_resume:
                    fc = FlightComputer(self.config)
                    if self.resume.restore(fc, rec, self.reset_gap_ms()):
                        self.say("reset in flight: resuming in state %s" % STATE_NAMES[fc.state])
                        self.fly("resume", rec, landed_beep_ms, fc)
                        return
                self.unexpected_reset = True
                self.errors.insert(0, (status.ERR_RESET,
                                       "reset while armed; cycle the arming input to clear"))
                self.say("error 7: the board was reset while armed and cannot resume; not arming")
            return self.idle(arm, idle_limit_ms, landed_beep_ms)
        finally:
            hw.pyro.all_low()
            micropython.kbd_intr(3)

    def idle(self, arm, idle_limit_ms, landed_beep_ms):
        hw = self.hw
        self.show_errors()
        has_switch = hw.armed_input() is not None
        seen_off = self.power_on_reset() and not self.unexpected_reset
        on_since = None
        t_start = ticks_ms()
        if arm is not None:
            if arm != "arm":
                self.say("arming refused: pass arm='arm'")
                return "refused"
            if has_switch:
                self.errors.append((status.ERR_ARM_COMMAND, "this board arms with its arming input"))
                self.say("arming refused: this board has an arming input; use it")
                self.show_errors()
                return "refused"
            return self.arm_and_fly("command", landed_beep_ms)
        while True:
            now = ticks_ms()
            if idle_limit_ms is not None and ticks_diff(now, t_start) >= idle_limit_ms:
                return "idle"
            if has_switch:
                if not hw.armed_input():
                    on_since = None
                    if not seen_off:
                        seen_off = True
                        if self.unexpected_reset:  # acknowledged by cycling the switch
                            self.unexpected_reset = False
                            self.resume.clear_armed_flag()
                            self.errors = [e for e in self.errors if e[0] != status.ERR_RESET]
                            self.show_errors()
                elif seen_off:
                    if on_since is None:
                        on_since = now
                    elif ticks_diff(now, on_since) >= ARM_DEBOUNCE_MS:
                        result = self.arm_and_fly("switch", landed_beep_ms)
                        if result in ("landed",):
                            return result
                        seen_off = False  # after a failed check or a disarm: off, then on again
                        on_since = None
                        t_start = ticks_ms()
                        self.show_errors()
            if hw.wdt is not None:  # started by an earlier flight mode: it cannot be stopped
                hw.wdt.feed()
            hw.status.update(now)
            sleep_ms(100)

    # -- arming ------------------------------------------------------------------------------------

    def pad_checks(self):
        """Sample the sensors for PAD_CHECK_S; return a list of (code, text) problems."""
        hw = self.hw
        b = self.board
        problems = [e for e in self.errors if e[0] != status.ERR_RESET]
        s = hw.sensors
        rate = b["sample_hz"]
        n = rate * PAD_CHECK_S
        period_ms = 1000 // rate
        baro_ok = accel_ok = 0
        p_sum = a_sum = mag_sum = 0
        alt0_cm = None  # the first reading's altitude: the others' deviations from it (cm)
        d_sum = d_sq = 0
        e0 = s.baro_errors + s.accel_errors
        for _ in range(n):
            s.read()
            if s.have & boardmod.HAVE_BARO:
                baro_ok += 1
                p_sum += s.pressure_q4_pa >> 4
                alt_cm = pressure_to_alt_mm(s.pressure_q4_pa) // 10
                if alt0_cm is None:
                    alt0_cm = alt_cm
                d = alt_cm - alt0_cm
                d_sum += d
                d_sq += d * d
            if s.have & boardmod.HAVE_ACCEL:
                accel_ok += 1
                a_sum += s.accel_mmps2
                v = hw.accel.accel_mmps2
                mag_sum += int((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) ** 0.5)
            sleep_ms(period_ms)
        cfg = self.config
        self.pad_figures = {"baro_reads": baro_ok, "accel_reads": accel_ok, "samples": n,
                            "sensor_errors": s.baro_errors + s.accel_errors - e0}
        if cfg.has_baro and hw.baro is not None:
            if baro_ok < n // 3:
                problems.append((status.ERR_BARO,
                                 "barometer: %d fresh readings in %d samples" % (baro_ok, n)))
            else:
                p = p_sum // baro_ok
                self.pad_figures["pressure_pa"] = p
                if not PRESSURE_MIN_Q4 >> 4 <= p <= PRESSURE_MAX_Q4 >> 4:
                    problems.append((status.ERR_BARO, "barometer: %d Pa is implausible" % p))
                mean_cm = d_sum / baro_ok
                noise_cm = max(0.0, d_sq / baro_ok - mean_cm * mean_cm) ** 0.5
                self.pad_figures["baro_noise_mm"] = int(noise_cm * 10)
                if noise_cm > BARO_NOISE_MAX_CM:
                    problems.append((status.ERR_BARO, "barometer: %.1f m rms of noise at rest, more than "
                                     "%.1f m: a faulty part, or a static port open to the wind"
                                     % (noise_cm / 100, BARO_NOISE_MAX_CM / 100)))
        if cfg.has_accel and hw.accel is not None:
            if accel_ok < (n * 9) // 10:
                problems.append((status.ERR_ACCEL,
                                 "accelerometer: %d readings in %d samples" % (accel_ok, n)))
            else:
                axis = a_sum // accel_ok
                mag = mag_sum // accel_ok
                self.pad_figures["axis_mmps2"] = axis
                self.pad_figures["magnitude_mmps2"] = mag
                lo = G_MMPS2 * 3 // 4
                hi = G_MMPS2 * 5 // 4
                if not lo <= mag <= hi:
                    problems.append((status.ERR_ONE_G, "accelerometer reads |a| = %.2f g at rest: wrong part "
                                     "or range setting" % (mag / G_MMPS2)))
                elif not lo <= axis <= hi:
                    problems.append((status.ERR_ONE_G, "accelerometer axis %s reads %.2f g: board not "
                                     "upright or mounted inverted" % (b["accel"]["axis"], axis / G_MMPS2)))
        continuity = {}
        for name in boardmod.channels(b):
            c = hw.pyro.continuity(boardmod.CHANNELS.index(name))
            continuity[name] = ("no sense input", "open", "connected")[c + 1]
            # a backup channel the configuration leaves off may stand empty
            enabled = name not in boardmod.BACKUP_KEYS or self.config.values[boardmod.BACKUP_KEYS[name]]
            if c == 0 and enabled:
                problems.append((status.ERR_CONTINUITY, "%s igniter: no continuity" % name))
        self.pad_figures["continuity"] = continuity  # reported per channel, logged in the header
        supply_mv = {}
        for name in b["supply"]:
            sup = b["supply"][name]
            mv = self.machine.ADC(self.machine.Pin(sup["pin"])).read_u16() * sup["full_scale_mv"] // 65535
            supply_mv[name] = mv
            if mv < sup["min_mv"]:
                problems.append((status.ERR_SUPPLY, "%s at %d mV, below %d mV" % (name, mv, sup["min_mv"])))
        self.pad_figures["supply_mv"] = supply_mv
        try:
            st = os.statvfs("/")
            free = st[0] * st[4]
            need = b["log_ram_kb"] * 1024 * 2 + LOG_SPACE_MARGIN
            self.pad_figures["log_free_bytes"] = free
            if free < need:
                problems.append((status.ERR_LOG, "log storage: %d bytes free, need %d" % (free, need)))
        except (AttributeError, OSError):
            pass
        return problems

    def arm_and_fly(self, how, landed_beep_ms):
        self.say("arming (%s): pad checks" % how)
        problems = self.pad_checks()
        if problems:
            for code, text in problems:
                self.say("pad check failed, error %d: %s" % (code, text))
            self.errors = problems
            self.show_errors()
            return "refused"
        self.say("pad checks passed: %s" % json.dumps(self.pad_figures))
        return self.fly(how, None, landed_beep_ms)

    # -- the log file --------------------------------------------------------------------------------

    def _rotate_log(self):
        try:
            os.stat(self.log_path)
        except OSError:
            return
        stem = self.log_path[:-4] if self.log_path.endswith(".log") else self.log_path
        for i in range(1, 1000):
            name = "%s-%d.log" % (stem, i)
            try:
                os.stat(name)
            except OSError:
                os.rename(self.log_path, name)
                return

    def open_log(self, how, resumed=None):
        header = {
            "format": flightlog.FORMAT_VERSION,
            "firmware": FIRMWARE_VERSION,
            "board": self.board,
            "config": self.config.values,
            "sample_hz": self.board["sample_hz"],
            "period_us": 1000000 // self.board["sample_hz"],
            "record": flightlog.REC_FMT,
            "record_fields": flightlog.REC_FIELDS,
            "block_size": flightlog.BLOCK_SIZE,
            "block_records": flightlog.BLOCK_RECORDS,
            "armed_by": how,
            "pad_checks": getattr(self, "pad_figures", {}),
        }
        if resumed is None:
            self._rotate_log()
            f = open(self.log_path, "wb")
            f.write(flightlog.file_header(json.dumps(header)))
            f.flush()
        else:
            f = open(self.log_path, "ab")
        return f

    # -- flight mode ---------------------------------------------------------------------------------

    def fly(self, how, resume_rec, landed_beep_ms, fc=None):
        """Flight mode. The watchdog first (nothing after it may leave an armed board without
        one); on the pad ``armed.flag`` written and read back (else refused: after a reset the
        board would not know it was armed); the log is best-effort: a flight, and above all a
        resumed one, goes on without it."""
        hw = self.hw
        cfg = self.config
        logfile = None
        micropython.kbd_intr(-1)
        try:
            hw.start_watchdog()
            if resume_rec is None and not self.resume.set_armed_flag(how):
                self.errors = [(status.ERR_FILES, "armed.flag cannot be written and read back")]
                self.say("not arming: error %d: %s" % (status.ERR_FILES, self.errors[0][1]))
                self.show_errors()
                return "refused"
            try:
                logbuf = flightlog.LogBuffer(self.board["log_ram_kb"] * 1024)
            except MemoryError as exc:
                if resume_rec is None:
                    self.resume.clear_armed_flag()
                    self.errors = [(status.ERR_LOG, "log: %s (lower log_ram_kb)" % exc)]
                    self.say("not arming: error 5: %s" % self.errors[0][1])
                    self.show_errors()
                    return "refused"
                collect()  # resumed: fly with the smallest buffer the pad logic needs
                logbuf = flightlog.LogBuffer(
                    flightlog.pad_blocks_needed(self.board["sample_hz"]) * flightlog.BLOCK_SIZE)
            logbuf.max_blocks = self.board["log_max_kb"] * 1024 // flightlog.BLOCK_SIZE
            try:
                logfile = self.open_log(how, resume_rec)
            except OSError as exc:
                self.errors.append((status.ERR_LOG, "log: %s: flying without a log" % exc))
                self.say("error 5: log %s cannot be opened (%s): flying without a log" % (self.log_path, exc))
            fc_start = 0
            if resume_rec is not None:
                fc_start = resume_rec["fc_start"]
                logbuf.sample = resume_rec["sample"]
                logbuf.write_text(logfile, flightlog.KIND_NOTE, json.dumps(
                    {"resumed": True, "sample": resume_rec["sample"], "state": resume_rec["state"]}))
            loop = FlightLoop(hw, cfg, logbuf, logfile, self.resume, fc, fc_start)
            if resume_rec is not None:
                logbuf.keep_from = resume_rec["sample"]
                logbuf.freeze()
                loop.shadow = None
                loop._resumed = True
            self.last_loop = loop
            self.say("flight mode: sampling at %d Hz" % self.board["sample_hz"])
            collect()
            reason = loop.run()
            hw.pyro.all_low()
            logbuf.write_all(logfile, hw.wdt.feed if hw.wdt is not None else None)
            summary = loop.summary()
            summary["armed_by"] = how
            self.last_summary = summary
            logbuf.write_text(logfile, flightlog.KIND_SUMMARY, json.dumps(summary))
            if logfile is not None:
                logfile.close()
                logfile = None
            if reason == "landed":
                self.resume.save(PHASE_LANDED, loop.fc, logbuf.sample, loop.fc_start)
            else:
                self.resume.clear()
            self.resume.clear_armed_flag()
        finally:
            hw.pyro.all_low()
            if logfile is not None:
                try:
                    logfile.close()
                except Exception:  # noqa: BLE001
                    pass
            micropython.kbd_intr(3)
        self.say("%s: max altitude %d m, %d samples, %d missed deadlines" % (
            reason, summary["max_agl_mm"] // 1000, summary["samples"], summary["missed_deadlines"]))
        if reason == "landed":
            self.landed(summary["max_agl_mm"] // 1000, landed_beep_ms)
        return reason

    def landed(self, max_m, beep_ms):
        """Beep the maximum altitude forever (or ``beep_ms``), feeding the watchdog."""
        hw = self.hw
        hw.status.landed(max_m)
        t0 = ticks_ms()
        while beep_ms is None or ticks_diff(ticks_ms(), t0) < beep_ms:
            if hw.wdt is not None:
                hw.wdt.feed()
            hw.status.update(ticks_ms())
            sleep_ms(20)


def main(arm=None, board_path="board.json", config_path="config.json", **kw):
    """Entry point of main.py. ``main(arm="arm")`` arms by command (boards without an input)."""
    t0 = ticks_us()
    try:
        app = App(board_path, config_path)
    except BoardError as exc:
        print("[apogee-fc] %s; not starting (pyro outputs stay low)" % exc)
        return None
    print("[apogee-fc] firmware %s, board %s, started in %d us" % (
        FIRMWARE_VERSION, app.board["board"], ticks_diff(ticks_us(), t0)))
    app.run(arm, **kw)
    return app
