"""Hosts that run the board's code off the board: MicroPython interpreters and the smbus2 I2C adapter."""
