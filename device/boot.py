# boot.py: MicroPython runs this first after every reset (hard, soft, watchdog, brown-out).
# Its first job, before any other import: drive the pyro outputs low. The pin numbers come from
# pyro_pins.txt, one line written by tools/deploy.py from the board description ("16 17"), so
# nothing has to be parsed or imported; board.json is the fallback. Fit a pull-down on each pyro
# gate (docs/WIRING.md): the pins float from reset until these lines run.
import machine

try:
    _f = open("pyro_pins.txt")
    _pins = _f.read().split()
    _f.close()
except OSError:
    _pins = ()
    try:
        import json

        _f = open("board.json")
        _b = json.load(_f)
        _f.close()
        _pins = [_b["pyro"][_c]["pin"] for _c in _b["pyro"]]
    except Exception:  # noqa: BLE001
        print("boot: no pyro_pins.txt or board.json: pyro outputs not driven")
for _p in _pins:
    try:
        machine.Pin(int(_p), machine.Pin.OUT, value=0)
    except Exception as _e:  # noqa: BLE001
        print("boot: pyro pin %s: %s" % (_p, _e))
del _pins
