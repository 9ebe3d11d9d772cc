"""Run the board's boot.py on the MicroPython unix port with the fake machine module."""

import json

from desktop.hosts.micropython import REPO_ROOT, run_micropython

_BOOT_GUEST = """
import json, os
from desktop.hosts.sil import fake_machine
fake_machine.install()
import machine
pins = %r
for n in pins:
    machine.Pin(n, machine.Pin.OUT, value=1)
os.chdir(%r)
exec(open(%r).read(), {"__name__": "boot"})
print("RESULT", json.dumps([fake_machine.LEVELS[n] for n in pins] + [fake_machine.MODES[pins[0]]]))
"""


def boot_pin_states(workdir, pins=(16, 17)):
    """[level of each of ``pins``..., mode of the first] after boot.py ran in ``workdir``, with those
    pins driven high first (a soft reset in the middle of something). The default pins are
    pico.json's drogue and main (GP16, GP17)."""
    out = run_micropython(_BOOT_GUEST % (list(pins), str(workdir), str(REPO_ROOT / "device" / "boot.py")),
                          "unix")
    return json.loads(out.split("RESULT ")[1])
