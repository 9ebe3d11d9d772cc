"""Software-in-the-loop helpers: fake ``machine``, ``time`` and ``micropython`` modules and a
simulated world that feeds the register-level sensor fakes (desktop/fakes) from a precomputed
flight. They run on the MicroPython unix port (tests/device/test_device_sil.py) and on CPython."""
