"""Run the board's boot.py on the MicroPython unix port with the fake machine module."""

import json

from desktop.hosts.micropython import REPO_ROOT, run_micropython

_BOOT_GUEST = """
import json, os
from desktop.hosts.sil import fake_machine
fake_machine.install()
import machine
for n in (16, 17):
    machine.Pin(n, machine.Pin.OUT, value=1)
os.chdir(%r)
exec(open(%r).read(), {"__name__": "boot"})
print("RESULT", json.dumps([fake_machine.LEVELS[16], fake_machine.LEVELS[17], fake_machine.MODES[16]]))
"""


def boot_pin_states(workdir):
    """[level of GP16, level of GP17, mode of GP16] after boot.py ran in ``workdir``, with both pins
    driven high first (a soft reset in the middle of something)."""
    out = run_micropython(_BOOT_GUEST % (str(workdir), str(REPO_ROOT / "device" / "boot.py")), "unix")
    return json.loads(out.split("RESULT ")[1])
