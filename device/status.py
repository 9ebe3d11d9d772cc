"""Status LED and buzzer: beep codes for state and errors, and the landed altitude in digits.

A pattern is a list of durations in ms, alternately on and off, played in a loop. ``set_*``
methods build a pattern (allocates: call them at safe points, when the state changes);
``update(now_ms)`` plays it and is called every sample (allocation-free, wrap-safe ticks).

Codes (docs/FIRMWARE.md has the table users read):

- idle, disarmed, no error: LED blink every 2 s, buzzer silent;
- error N: N long beeps (0.5 s), pause 2 s, repeated. 1 barometer, 2 accelerometer, 3 not about
  +1 g on the axis (wrong part, range or mount; board not upright), 4 continuity missing,
  5 log storage, 6 board or config file, 7 unexpected reset (re-arm to clear), 8 command arming
  refused;
- armed on the pad: one long beep, then 1 short = drogue igniter connected, 2 = main, 3 = both
  (no short beeps: no continuity sensed, or no sense inputs), every 2 s;
- boost to apogee: LED on, buzzer silent;
- descent: a short chirp every second (locator);
- landed: the maximum altitude above the pad in metres, digit by digit: n short beeps for the digit
  n, one long beep for 0, 1 s between digits, 3 s between repeats (e.g. 1203 m is
  . / .. / - / ...).
"""

from array import array

try:
    from time import ticks_add, ticks_diff, ticks_ms
except ImportError:  # CPython (desktop tests of the patterns)
    from time import monotonic_ns as _ns

    def ticks_ms():
        return (_ns() // 1000000) & 0x3FFFFFFF

    def ticks_diff(a, b):
        return ((a - b + 0x20000000) & 0x3FFFFFFF) - 0x20000000

    def ticks_add(a, d):
        return (a + d) & 0x3FFFFFFF

SHORT_MS = 150
SHORT_GAP_MS = 250
LONG_MS = 500
LONG_GAP_MS = 300
DIGIT_GAP_MS = 1000
REPEAT_GAP_MS = 3000

ERR_BARO = 1
ERR_ACCEL = 2
ERR_ONE_G = 3
ERR_CONTINUITY = 4
ERR_LOG = 5
ERR_FILES = 6
ERR_RESET = 7
ERR_ARM_COMMAND = 8
ERR_SUPPLY = 9
ERROR_NAMES = {1: "barometer", 2: "accelerometer", 3: "not +1 g on the axis", 4: "continuity",
               5: "log storage", 6: "board/config file", 7: "unexpected reset", 8: "command arming refused",
               9: "battery or pyro rail voltage low"}

_MAX_STEPS = 64


def digits_pattern(value):
    """Durations (ms, on/off alternating) that beep ``value`` digit by digit."""
    value = max(0, int(value))
    out = []
    digits = str(value)
    for i, ch in enumerate(digits):
        d = ord(ch) - 48
        if d == 0:
            out += [LONG_MS, SHORT_GAP_MS]
        else:
            for _ in range(d):
                out += [SHORT_MS, SHORT_GAP_MS]
        out[-1] = DIGIT_GAP_MS if i < len(digits) - 1 else REPEAT_GAP_MS
    return out


class Status:
    def __init__(self, machine, board):
        Pin = machine.Pin
        self._led = None
        self._led_on = 1
        if board.get("led") is not None:
            self._led = Pin(board["led"]["pin"], Pin.OUT, value=1 - board["led"]["active"])
            self._led_on = board["led"]["active"]
        self._buz = None
        self._pwm = None
        self._buz_on = 1
        b = board.get("buzzer")
        if b is not None:
            if b["kind"] == "passive":
                self._pwm = machine.PWM(Pin(b["pin"]), freq=b["freq"], duty_u16=0)
            else:
                self._buz = Pin(b["pin"], Pin.OUT, value=1 - b["active"])
                self._buz_on = b["active"]
        self._steps = array("H", bytearray(2 * _MAX_STEPS))
        self._n = 0
        self._i = 0
        self._next = ticks_ms()
        self._beep = False  # pattern uses the buzzer (False: LED only)
        self._solid = False
        self.name = ""
        self._out(False)

    # -- outputs ---------------------------------------------------------------------------------

    def _out(self, on):
        if self._led is not None:
            self._led.value(self._led_on if on else 1 - self._led_on)
        beep = on and self._beep
        if self._buz is not None:
            self._buz.value(self._buz_on if beep else 1 - self._buz_on)
        elif self._pwm is not None:
            self._pwm.duty_u16(32768 if beep else 0)

    def _set(self, name, steps, beep, solid=False):
        if name == self.name:
            return
        self.name = name
        n = min(len(steps), _MAX_STEPS)
        for i in range(n):
            self._steps[i] = steps[i]
        self._n = n
        self._i = 0
        self._beep = beep
        self._solid = solid
        self._next = ticks_ms()
        self._out(solid)

    def update(self, now_ms):
        """Advance the pattern (every sample; allocation-free)."""
        if self._n == 0 or self._solid:
            return
        if ticks_diff(now_ms, self._next) < 0:
            return
        i = self._i
        self._out(not (i & 1))
        self._next = ticks_add(self._next, self._steps[i])
        if ticks_diff(now_ms, self._next) > 0:  # fell behind (a long stall): resynchronise
            self._next = now_ms
        i += 1
        self._i = 0 if i >= self._n else i

    # -- patterns --------------------------------------------------------------------------------

    def off(self):
        self._set("off", [], False)

    def idle(self):
        self._set("idle", [60, 1940], False)

    def error(self, code):
        steps = []
        for _ in range(code):
            steps += [LONG_MS, LONG_GAP_MS]
        steps[-1] = 2000
        self._set("error%d" % code, steps, True)

    def armed(self, continuity_bits):
        steps = [700, 400]
        for _ in range(continuity_bits):
            steps += [SHORT_MS, SHORT_GAP_MS]
        steps[-1] = 2000
        self._set("armed%d" % continuity_bits, steps, True)

    def flight(self):
        self._set("flight", [1000], False, solid=True)

    def descent(self):
        self._set("descent", [80, 920], True)

    def landed(self, max_agl_m):
        self._set("landed%d" % max_agl_m, digits_pattern(max_agl_m), True)

    def play_blocking(self, ms, sleep_ms):
        """Play the current pattern for ``ms`` (idle and landed loops)."""
        end = ticks_add(ticks_ms(), ms)
        while ticks_diff(end, ticks_ms()) > 0:
            self.update(ticks_ms())
            sleep_ms(10)
