# boot.py: MicroPython runs this first after every reset (hard, soft, watchdog, brown-out).
# Its first job, before any other import: drive the pyro outputs low. The pin numbers come from
# pyro_pins.txt, one line written by tools/deploy.py from the board description ("16 17"), so
# nothing has to be parsed or imported. board.json is the fallback when that file is missing,
# empty or not a list of pin numbers; its pins are driven low too when both can be read, so a
# stale pyro_pins.txt still leaves the real pyro pins low (the app then refuses to arm until the
# two agree: device/app.py). Fit a pull-down on each pyro gate (docs/WIRING.md): the pins float
# from reset until these lines run.
import machine

_pins = []
try:
    _f = open("pyro_pins.txt")
    _pins = [int(_p) for _p in _f.read().split()]
    _f.close()
except (OSError, ValueError) as _e:  # missing, or not numbers: board.json decides
    print("boot: pyro_pins.txt: %s" % _e)
    _pins = []
for _p in _pins:
    try:
        machine.Pin(_p, machine.Pin.OUT, value=0)
    except Exception as _e:  # noqa: BLE001
        print("boot: pyro pin %s: %s" % (_p, _e))
try:
    import json

    _f = open("board.json")
    _b = json.load(_f)
    _f.close()
    for _c in _b["pyro"]:
        _p = _b["pyro"][_c]["pin"]
        if _p not in _pins:
            if _pins:
                print("boot: pyro pin %s of board.json is not in pyro_pins.txt" % _p)
            machine.Pin(int(_p), machine.Pin.OUT, value=0)
except Exception as _e:  # noqa: BLE001
    if not _pins:
        print("boot: no pyro_pins.txt or board.json: pyro outputs not driven (%s)" % _e)
del _pins
