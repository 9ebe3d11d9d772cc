"""Software in the loop: the unchanged firmware (``device/``) on the MicroPython unix port.

Fake ``machine``, ``time`` and ``micropython`` modules (``fake_machine``, ``fake_time``,
``fake_micropython``), a simulated world that feeds the register-level sensor fakes
(``desktop/sim/fakes``) from a precomputed flight (``world``, written by ``flightgen``), the guest
side that boots the board (``runner``) and the host side that prepares its files and runs it
(``host``). The guest modules run on the MicroPython unix port and on CPython; the ``sil`` command
(``command.py``) and tests/device/test_device_sil.py use them.
"""
