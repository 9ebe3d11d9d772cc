"""Per-sample time and allocation of the whole flight loop on real MicroPython.

Runs ``tests/support/sil_measure.py``: the loop body (``FlightLoop.sample`` and the safe point
``after_sample``) over a simulated flight, on the unix port (64-bit) and on the 32-bit wasm build
(31-bit small ints, as on an RP2040: an intermediate past 2**30 would allocate). Prints the figures
quoted in docs/FIRMWARE.md (run with ``pytest -s``).
"""

import json

import pytest

from desktop.hosts.micropython import REPO_ROOT, run_micropython
from desktop.hosts.sil.flightgen import Scenario
from desktop.hosts.sil.host import prepare

pytestmark = pytest.mark.micropython


@pytest.mark.parametrize("interp,samples", [("unix", 900), ("wasm32", 700)])
def test_loop_is_allocation_free_and_timed(tmp_path, interp, samples):
    sc = Scenario(duration_s=samples / 50 + 2, launch_s=1.0, boost_mps2=80.0, burn_s=1.0, seed=21)
    if interp == "wasm32":  # the wasm guest sees only the repository (read-only, as /input)
        work = REPO_ROOT / "build" / "sil-measure"
        frames = prepare(work, sc)
        guest = "/input/build/sil-measure"
        opts = {"frames": guest + "/frames.bin", "workdir": guest, "samples": samples, "alloc": False}
    else:
        frames = prepare(tmp_path, sc)
        opts = {"frames": str(frames), "workdir": str(tmp_path), "samples": samples}
    out = run_micropython("from tests.support.sil_measure import main\nmain(%r)\n" % (opts,), interp)
    res = json.loads(out.split("MEASURE ")[1].splitlines()[0])
    print("\n" + json.dumps(res, indent=1))
    assert res["heap_locked_ok"]
    assert res["sample_alloc_bytes"] == 0
    assert res["own_alloc_bytes"] == 0
    assert res["same_decisions"]
    assert res["final_state"] >= 4  # the measured samples include the flight through apogee
