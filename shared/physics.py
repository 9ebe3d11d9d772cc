"""Physical constants, one definition each, for the board and the desktop alike."""

# Standard gravity, 9.80665 m/s^2 exactly by definition (3rd CGPM, 1901): the g of the ISA
# atmosphere, of accelerometer data sheets (1 g) and of RocketPy's Environment.
G0_MPS2 = 9.80665
# The same in the integer units of the board's code (mm/s^2), rounded.
G_MMPS2 = 9807
