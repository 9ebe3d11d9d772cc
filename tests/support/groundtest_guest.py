"""The ground test run on the MicroPython unix port with the SIL fakes of ``machine`` and time:
``run_groundtest(workdir, body)`` runs ``body`` after a prelude that defines ``attempt(**kw)``
(``device.groundtest.fire`` with its refusal or the pyro pin changes it made, in us from the
call) and an ``out`` dict; returns ``out`` as the guest printed it (JSON)."""

import json

from desktop.hosts.micropython import run_micropython

PYRO_PINS = (16, 17, 18, 19)  # the SIL boards' drogue, main, backup drogue, backup main

PRELUDE = """
import json, os
from desktop.hosts.sil import fake_machine, fake_time
fake_machine.install()
import machine
os.chdir({workdir!r})
from device.groundtest import fire, Refused, LIVE
def attempt(**kw):
    t0 = fake_time.elapsed
    n0 = fake_machine.EV_N[0]
    try:
        took = fire(**kw)
    except Refused as e:
        return {{"refused": str(e)}}
    except KeyboardInterrupt:
        took = "interrupted"
    ev = [(t - t0, p, l) for (t, p, l) in fake_machine.pin_events()[n0:] if p in {pins!r}]
    return {{"took": took, "pins": ev}}
out = {{}}
"""


def run_groundtest(workdir, body):
    """``out`` after running ``body`` on the unix port in ``workdir`` (its board.json)."""
    code = (PRELUDE.format(workdir=str(workdir), pins=PYRO_PINS) + body
            + "\nprint('RESULT', json.dumps(out))\n")
    out = run_micropython(code, "unix")
    line = [x for x in out.splitlines() if x.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])
