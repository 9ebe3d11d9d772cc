"""Board description (``board.json`` on the board): validation, and the hardware built from it.

A board description is a JSON object naming the MCU, the pins of the two pyro channels (drogue,
main) and of the optional backup channels (backup_drogue, backup_main) with optional continuity
sense inputs, the optional arming input, the I2C bus and the sensor
parts, the status LED and buzzer, the sample rate and the log buffer. ``validate(desc)`` checks it
and returns a normalised copy, or raises ``BoardError`` with one line naming the key. It is
portable: ``tools/deploy.py`` runs it on CPython before copying anything to the board, the app runs
it again on the board.

Pins that glitch at reset. Each description lists the pins the MCU drives or samples while it
boots (``reset_glitch_pins``; on the ESP32 the strapping pins 0, 2, 5, 12 and 15). They are
refused for pyro outputs, and the list must contain every pin this module knows for the MCU, so
deleting a pin from the list does not make it acceptable. Pins the module (flash, SMPS, VBUS
sense) or the MCU (input-only pins) cannot give are refused too. See docs/WIRING.md.

``Hardware(desc)`` (MicroPython) builds the pins, the bus, the sensor drivers, the pyro outputs,
the status outputs and the arming input. Sensor failures at start-up are recorded in
``Hardware.errors`` (the board stays disarmed and beeps the error), never raised.
"""

from device.pyro import NAMES as CHANNELS  # the pyro channels in output order

try:
    from micropython import const
except ImportError:  # CPython (tools/deploy.py, tests)

    def const(x):
        return x


# Pins this module knows to glitch or to be sampled at reset, per MCU. A description must list at
# least these in reset_glitch_pins (it may add board-specific ones).
KNOWN_RESET_GLITCH = {
    "rp2040": (),  # every GPIO resets to an input with its pull-down enabled
    "rp2350": (),
    "esp32": (0, 2, 5, 12, 15),  # strapping pins (boot mode, flash voltage, boot log, SDIO timing)
    "esp32s3": (0, 3, 45, 46),
    "esp32c3": (2, 8, 9),
}
GPIO_COUNT = {"rp2040": 30, "rp2350": 48, "esp32": 40, "esp32s3": 49, "esp32c3": 22}
SAMPLE_RATES_HZ = (10, 20, 25, 50, 100, 200)  # the rates of shared/gains_table.py
BARO_PARTS = ("BMP388", "BMP390", "BMP280", "MS5611")
ACCEL_PARTS = ("ADXL375", "ADXL345", "MPU6050", "LSM6DSO", "LSM6DSO32")
REQUIRED_CHANNELS = 2  # the first CHANNELS (drogue, main) every board has
# The configuration key that enables each backup channel (shared/config.py; 0 = off).
BACKUP_KEYS = {"backup_drogue": "backup_drogue_delay_s", "backup_main": "backup_main_m"}
AXES = {"+x": (0, 1), "-x": (0, -1), "+y": (1, 1), "-y": (1, -1), "+z": (2, 1), "-z": (2, -1)}

_TOP_KEYS = ("board", "mcu", "description", "reset_glitch_pins", "reserved_pins", "input_only_pins",
             "sample_hz", "i2c", "baro", "accel", "pyro", "arm", "led", "buzzer", "timers",
             "watchdog_ms", "boot_ms", "log_ram_kb", "log_max_kb", "supply")
SUPPLIES = ("battery", "pyro_rail")


class BoardError(ValueError):
    """A problem with the board description; the message is one line naming the key."""


def _int(value, where, low=None, high=None):
    if isinstance(value, str):  # "0x77" for I2C addresses
        try:
            value = int(value, 0)
        except ValueError:
            raise BoardError("board: %s must be an integer, got %r" % (where, value)) from None
    if not isinstance(value, int) or isinstance(value, bool):
        raise BoardError("board: %s must be an integer, got %r" % (where, value))
    if (low is not None and value < low) or (high is not None and value > high):
        raise BoardError("board: %s = %d is out of range %d..%d" % (where, value, low, high))
    return value


def _obj(value, where, keys):
    if not isinstance(value, dict):
        raise BoardError("board: %s must be an object" % where)
    for k in value:
        if k not in keys:
            raise BoardError("board: unknown key %s.%s (known: %s)" % (where, k, ", ".join(keys)))
    return value


def _pin_list(value, where, ngpio):
    if not isinstance(value, list):
        raise BoardError("board: %s must be a list of pin numbers" % where)
    return [_int(v, "%s[]" % where, 0, ngpio - 1) for v in value]


def validate(desc):
    """Check a board description; return a normalised copy (ints, defaults filled in)."""
    if not isinstance(desc, dict):
        raise BoardError("board: expected a JSON object")
    _obj(desc, "board.json", _TOP_KEYS)
    mcu = desc.get("mcu")
    if mcu not in KNOWN_RESET_GLITCH:
        raise BoardError("board: mcu = %r is not one of %s" % (mcu, ", ".join(sorted(KNOWN_RESET_GLITCH))))
    ngpio = GPIO_COUNT[mcu]
    out = {"board": str(desc.get("board", mcu)), "mcu": mcu, "description": str(desc.get("description", ""))}
    glitch = _pin_list(desc.get("reset_glitch_pins", []), "reset_glitch_pins", ngpio)
    for p in KNOWN_RESET_GLITCH[mcu]:
        if p not in glitch:
            raise BoardError("board: reset_glitch_pins must list %d (it glitches or is sampled at reset "
                             "on the %s)" % (p, mcu))
    out["reset_glitch_pins"] = glitch
    reserved = _pin_list(desc.get("reserved_pins", []), "reserved_pins", ngpio)
    out["reserved_pins"] = reserved
    input_only = _pin_list(desc.get("input_only_pins", []), "input_only_pins", ngpio)
    out["input_only_pins"] = input_only
    rate = _int(desc.get("sample_hz", 50), "sample_hz")
    if rate not in SAMPLE_RATES_HZ:
        raise BoardError("board: sample_hz = %d is not a rate of the gain table (%s)" % (
            rate, ", ".join([str(r) for r in SAMPLE_RATES_HZ])))
    out["sample_hz"] = rate
    used = {}  # pin -> what uses it

    def use(pin, what, output):
        if pin in reserved:
            raise BoardError("board: %s uses pin %d, which is reserved on this board" % (what, pin))
        if output and pin in input_only:
            raise BoardError("board: %s uses pin %d, which is input-only" % (what, pin))
        if pin in used:
            raise BoardError("board: %s uses pin %d, already used by %s" % (what, pin, used[pin]))
        used[pin] = what
        return pin

    # pyro outputs first: their refusals are the ones that matter most
    pyro = _obj(desc.get("pyro"), "pyro", CHANNELS)
    out["pyro"] = {}
    for ch in CHANNELS:
        if ch not in pyro:
            if CHANNELS.index(ch) < REQUIRED_CHANNELS:
                raise BoardError("board: pyro.%s is missing (both channels need a pin)" % ch)
            continue  # a backup channel the board does not have
        c = _obj(pyro[ch], "pyro." + ch, ("pin", "sense"))
        pin = _int(c.get("pin"), "pyro.%s.pin" % ch, 0, ngpio - 1)
        if pin in glitch:
            raise BoardError("board: pyro.%s.pin = %d glitches at reset on the %s (reset_glitch_pins); "
                             "choose another pin" % (ch, pin, mcu))
        use(pin, "pyro." + ch, True)
        ch_out = {"pin": pin, "sense": None}
        if c.get("sense") is not None:
            s = _obj(c["sense"], "pyro.%s.sense" % ch, ("pin", "kind", "active", "threshold_u16"))
            kind = s.get("kind", "digital")
            if kind not in ("digital", "adc"):
                raise BoardError("board: pyro.%s.sense.kind must be 'digital' or 'adc'" % ch)
            where = "pyro.%s.sense" % ch
            ch_out["sense"] = {
                "pin": use(_int(s.get("pin"), where + ".pin", 0, ngpio - 1), where, False),
                "kind": kind,
                "active": _int(s.get("active", 1), where + ".active", 0, 1),
                "threshold_u16": _int(s.get("threshold_u16", 20000), where + ".threshold_u16", 1, 65535),
            }
        out["pyro"][ch] = ch_out

    i2c = _obj(desc.get("i2c"), "i2c", ("id", "sda", "scl", "freq", "soft"))
    out["i2c"] = {
        "id": _int(i2c.get("id", 0), "i2c.id", -1, 8),
        "sda": use(_int(i2c.get("sda"), "i2c.sda", 0, ngpio - 1), "i2c.sda", True),
        "scl": use(_int(i2c.get("scl"), "i2c.scl", 0, ngpio - 1), "i2c.scl", True),
        "freq": _int(i2c.get("freq", 400000), "i2c.freq", 10000, 1000000),
        "soft": bool(i2c.get("soft", False)),
    }
    out["baro"] = None
    if desc.get("baro") is not None:
        b = _obj(desc["baro"], "baro", ("part", "addr", "options"))
        if b.get("part") not in BARO_PARTS:
            raise BoardError("board: baro.part = %r is not one of %s" % (b.get("part"),
                                                                         ", ".join(BARO_PARTS)))
        opts = b.get("options", {})
        if not isinstance(opts, dict):
            raise BoardError("board: baro.options must be an object of driver keywords")
        out["baro"] = {"part": b["part"], "addr": _int(b.get("addr", 0x77), "baro.addr", 0x08, 0x77),
                       "options": opts}
    out["accel"] = None
    if desc.get("accel") is not None:
        a = _obj(desc["accel"], "accel", ("part", "addr", "axis", "options"))
        if a.get("part") not in ACCEL_PARTS:
            raise BoardError("board: accel.part = %r is not one of %s" % (a.get("part"),
                                                                          ", ".join(ACCEL_PARTS)))
        axis = a.get("axis", "+z")
        if axis not in AXES:
            raise BoardError("board: accel.axis = %r: the sensor axis pointing to the nose, one of %s" % (
                axis, ", ".join(sorted(AXES))))
        opts = a.get("options", {})
        if not isinstance(opts, dict):
            raise BoardError("board: accel.options must be an object of driver keywords")
        out["accel"] = {"part": a["part"], "addr": _int(a.get("addr", 0x53), "accel.addr", 0x08, 0x77),
                        "axis": axis, "options": opts}
    if out["baro"] is None and out["accel"] is None:
        raise BoardError("board: no sensors (baro and accel are both missing)")

    out["arm"] = None
    if desc.get("arm") is not None:
        a = _obj(desc["arm"], "arm", ("pin", "active", "pull"))
        pull = a.get("pull", "up")
        if pull not in ("up", "down", None):
            raise BoardError("board: arm.pull must be 'up', 'down' or null")
        out["arm"] = {"pin": use(_int(a.get("pin"), "arm.pin", 0, ngpio - 1), "arm", False),
                      "active": _int(a.get("active", 0), "arm.active", 0, 1), "pull": pull}
    out["led"] = None
    if desc.get("led") is not None:
        a = _obj(desc["led"], "led", ("pin", "active"))
        out["led"] = {"pin": use(_int(a.get("pin"), "led.pin", 0, ngpio - 1), "led", True),
                      "active": _int(a.get("active", 1), "led.active", 0, 1)}
    out["buzzer"] = None
    if desc.get("buzzer") is not None:
        a = _obj(desc["buzzer"], "buzzer", ("pin", "kind", "freq", "active"))
        kind = a.get("kind", "active")
        if kind not in ("active", "passive"):
            raise BoardError("board: buzzer.kind must be 'active' (DC buzzer) or 'passive' (piezo, PWM)")
        out["buzzer"] = {"pin": use(_int(a.get("pin"), "buzzer.pin", 0, ngpio - 1), "buzzer", True),
                         "kind": kind, "freq": _int(a.get("freq", 4000), "buzzer.freq", 100, 20000),
                         "active": _int(a.get("active", 1), "buzzer.active", 0, 1)}
    # voltages checked before arming (AltOS, RRC3 and Eggtimer all report them): an ADC input behind
    # a divider; full_scale_mv is the voltage that reads 65535
    out["supply"] = {}
    for name, sup in _obj(desc.get("supply", {}), "supply", SUPPLIES).items():
        a = _obj(sup, "supply." + name, ("pin", "full_scale_mv", "min_mv"))
        out["supply"][name] = {
            "pin": use(_int(a.get("pin"), "supply.%s.pin" % name, 0, ngpio - 1), "supply." + name, False),
            "full_scale_mv": _int(a.get("full_scale_mv"), "supply.%s.full_scale_mv" % name, 100, 100000),
            "min_mv": _int(a.get("min_mv"), "supply.%s.min_mv" % name, 0, 100000)}
    names = channels(out)
    timers = desc.get("timers", [-1] * len(names))
    if not isinstance(timers, list) or len(timers) != len(names):
        raise BoardError("board: timers must be %d hardware timer ids [%s] (-1: virtual), one per pyro "
                         "channel" % (len(names), ", ".join(names)))
    out["timers"] = [_int(t, "timers[]", -1, 15) for t in timers]
    if mcu.startswith("esp32") and -1 in out["timers"]:
        raise BoardError("board: timers: the %s has no virtual timer; use hardware ids such as [0, 1]" % mcu)
    out["watchdog_ms"] = _int(desc.get("watchdog_ms", 2000), "watchdog_ms", 500, 8000)
    # the worst-case time from a reset to the first sample of the resumed flight, measured on the
    # board (docs/FIRMWARE.md); after a reset the flight's clock is advanced by it
    out["boot_ms"] = _int(desc.get("boot_ms", 1000), "boot_ms", 0, 10000)
    out["log_ram_kb"] = _int(desc.get("log_ram_kb", 64), "log_ram_kb", 8, 4096)
    from device.flightlog import BLOCK_SIZE, pad_blocks_needed

    need_kb = (pad_blocks_needed(rate) + 8) * BLOCK_SIZE // 1024  # the pad, and 8 blocks of flight
    if out["log_ram_kb"] < need_kb:
        raise BoardError("board: log_ram_kb = %d is too small at %d Hz: at least %d (the pad keeps %d "
                         "KB, the flight needs more)" % (out["log_ram_kb"], rate, need_kb,
                                                          pad_blocks_needed(rate) * BLOCK_SIZE // 1024))
    out["log_max_kb"] = _int(desc.get("log_max_kb", 512), "log_max_kb", 16, 1 << 20)
    return out


def check_with_config(board, config):
    """Cross-check a validated board with a ``shared.config.Config``: the sensors must exist."""
    for ch in BACKUP_KEYS:
        key = BACKUP_KEYS[ch]
        if config.values[key] and ch not in board["pyro"]:
            raise BoardError("board: config %s = %r needs pyro.%s, but the board has no such channel"
                             % (key, config.values[key], ch))
    sensors = config.values["sensors"]
    if sensors in ("both", "baro") and board["baro"] is None:
        raise BoardError("board: config sensors = %r needs a barometer, but the board has none" % sensors)
    if sensors in ("both", "accel") and board["accel"] is None:
        raise BoardError("board: config sensors = %r needs an accelerometer, but the board has none"
                         % sensors)


def load(path="board.json"):
    """Read and validate a board description file."""
    import json

    try:
        with open(path) as f:
            desc = json.load(f)
    except OSError:
        raise BoardError("board: cannot read %s" % path) from None
    except ValueError as exc:
        raise BoardError("board: %s is not valid JSON: %s" % (path, exc)) from None
    return validate(desc)


def channels(board):
    """The pyro channels this validated board has, in CHANNELS order."""
    return [ch for ch in CHANNELS if ch in board["pyro"]]


def pyro_pins_text(board):
    """The one-line file boot.py reads before anything else: the pyro pin numbers."""
    return " ".join([str(board["pyro"][ch]["pin"]) for ch in channels(board)]) + "\n"


def check_pyro_pins_file(board, path="pyro_pins.txt"):
    """None when ``path`` names exactly the board's pyro pins, else the problem in one line (the
    app refuses to arm: boot.py drove the pins of that file low at reset, not necessarily these)."""
    try:
        with open(path) as f:
            text = f.read()
    except OSError:
        return "board: %s is missing; run tools/deploy.py" % path
    try:
        pins = sorted([int(p) for p in text.split()])
    except ValueError:
        return "board: %s is not a list of pin numbers: %r" % (path, text[:40])
    want = sorted([board["pyro"][ch]["pin"] for ch in channels(board)])
    if pins != want:
        return "board: %s names pins %s, board.json's pyro pins are %s; run tools/deploy.py" % (
            path, pins, want)
    return None


# -- hardware (MicroPython) ----------------------------------------------------------------------

HAVE_BARO = const(1)  # as shared.detector
HAVE_ACCEL = const(2)
_FAIL_RUN = const(3)  # consecutive failures before a sensor is only retried once a second


def make_baro(part, i2c, addr, options):
    if part in ("BMP388", "BMP390"):
        from device.drivers.bmp3xx import BMP3XX

        return BMP3XX(i2c, addr, **options)
    if part == "BMP280":
        from device.drivers.bmp280 import BMP280

        return BMP280(i2c, addr, **options)
    from device.drivers.ms5611 import MS5611

    return MS5611(i2c, addr, **options)


def make_accel(part, i2c, addr, options):
    if part in ("ADXL375", "ADXL345"):
        from device.drivers.adxl375 import ADXL375

        return ADXL375(i2c, addr, part=part, **options)
    if part == "MPU6050":
        from device.drivers.mpu6050 import MPU6050

        return MPU6050(i2c, addr, **options)
    from device.drivers.lsm6dso import LSM6DSO

    return LSM6DSO(i2c, addr, part=part, **options)


class Sensors:
    """What the flight loop reads each sample. ``read()`` never raises and never allocates on the
    normal path: it fills ``pressure_q4_pa``, ``temp_cdeg``, ``accel_mmps2`` (the axis pointing
    to the nose, specific force) and ``have`` (HAVE_BARO | HAVE_ACCEL for fresh readings).

    A failing sensor (``OSError`` from the bus, or anything else its driver raises) is counted in
    ``baro_errors`` / ``accel_errors``, its reading is marked missing for that sample, and after
    three failures in a row it is retried only once every ``retry_samples`` samples (a dead part
    with a bus timeout must not eat the sample period)."""

    def __init__(self, baro, accel, axis="+z", retry_samples=50):
        self.baro = baro
        self.accel = accel
        self.axis, self.sign = AXES[axis]
        self.retry_samples = retry_samples
        self.pressure_q4_pa = 0
        self.temp_cdeg = 0
        self.accel_mmps2 = 0
        self.have = 0
        self.baro_errors = 0
        self.accel_errors = 0
        self._baro_run = 0
        self._accel_run = 0
        self._baro_skip = 0
        self._accel_skip = 0
        self._two_phase = baro is not None and hasattr(baro, "collect")
        self._has_fresh = baro is not None and hasattr(baro, "fresh")
        self._started = False

    def read(self):
        have = 0
        baro = self.baro
        if baro is not None:
            if self._baro_skip:
                self._baro_skip -= 1
            else:
                try:
                    if self._two_phase:  # MS5611: collect the finished conversion, start the next
                        if not self._started:
                            baro.start()
                            self._started = True
                        elif baro.ready():
                            if baro.collect():
                                have = HAVE_BARO
                            baro.start()
                    else:
                        baro.read()
                        if not self._has_fresh or baro.fresh:
                            have = HAVE_BARO
                    self.pressure_q4_pa = baro.pressure_q4_pa
                    self.temp_cdeg = baro.temp_cdeg
                    self._baro_run = 0
                except Exception:  # noqa: BLE001 - the flight goes on without this reading
                    have = 0
                    self.baro_errors += 1
                    self._baro_run += 1
                    self._started = False
                    if self._baro_run >= _FAIL_RUN:
                        self._baro_skip = self.retry_samples
        accel = self.accel
        if accel is not None:
            if self._accel_skip:
                self._accel_skip -= 1
            else:
                try:
                    accel.read()
                    self.accel_mmps2 = accel.accel_mmps2[self.axis] * self.sign
                    have |= HAVE_ACCEL
                    self._accel_run = 0
                except Exception:  # noqa: BLE001
                    self.accel_errors += 1
                    self._accel_run += 1
                    if self._accel_run >= _FAIL_RUN:
                        self._accel_skip = self.retry_samples
        self.have = have


class Hardware:
    """Pins, bus, sensors, pyro, status and arming input of a validated board description."""

    def __init__(self, board, machine=None):
        if machine is None:
            import machine
        from device.pyro import Pyro
        from device.status import Status

        self.board = board
        self.machine = machine
        self.errors = []  # (code, text) from start-up; see device/status.py for the codes
        self.pyro = Pyro(machine, board)  # first: drives both outputs low again
        self.status = Status(machine, board)
        Pin = machine.Pin
        self.arm_pin = None
        if board["arm"] is not None:
            a = board["arm"]
            pull = Pin.PULL_UP if a["pull"] == "up" else (Pin.PULL_DOWN if a["pull"] == "down" else None)
            self.arm_pin = Pin(a["pin"], Pin.IN, pull) if pull is not None else Pin(a["pin"], Pin.IN)
            self.arm_active = a["active"]
        c = board["i2c"]
        try:
            cls = machine.SoftI2C if c["soft"] else machine.I2C
            if c["soft"]:
                self.i2c = cls(scl=Pin(c["scl"]), sda=Pin(c["sda"]), freq=c["freq"])
            else:
                self.i2c = cls(c["id"], scl=Pin(c["scl"]), sda=Pin(c["sda"]), freq=c["freq"])
        except Exception as exc:  # noqa: BLE001
            self.i2c = None
            self.errors.append((6, "i2c: %s" % exc))
        baro = accel = None
        if board["baro"] is not None and self.i2c is not None:
            b = board["baro"]
            try:
                baro = make_baro(b["part"], self.i2c, b["addr"], b["options"])
            except Exception as exc:  # noqa: BLE001
                self.errors.append((1, "baro %s at 0x%02x: %s" % (b["part"], b["addr"], exc)))
        if board["accel"] is not None and self.i2c is not None:
            a = board["accel"]
            try:
                accel = make_accel(a["part"], self.i2c, a["addr"], a["options"])
            except Exception as exc:  # noqa: BLE001
                self.errors.append((2, "accel %s at 0x%02x: %s" % (a["part"], a["addr"], exc)))
        self.baro = baro
        self.accel = accel
        self.sensors = Sensors(baro, accel, board["accel"]["axis"] if board["accel"] else "+z",
                               retry_samples=board["sample_hz"])
        self.wdt = None

    def armed_input(self):
        """True/False from the arming input, or None when the board has none."""
        if self.arm_pin is None:
            return None
        return self.arm_pin.value() == self.arm_active

    def start_watchdog(self):
        """Start the hardware watchdog (flight mode only: it cannot be stopped on the RP2040)."""
        if self.wdt is None:
            self.wdt = self.machine.WDT(timeout=self.board["watchdog_ms"])
        return self.wdt
