# Wrapper around ports/qemu/Makefile (make -C ports/qemu -f this-file): the rp2 port's speed-relevant
# build options, so that instruction counts resemble an RP2040 firmware's. The rp2 port compiles
# with -Os but py/vm.c, py/map.c and py/mpz.c at -O2 (vm.c and gc.c get CSUPEROPT, which
# tools/armboard.py sets to -O2), with computed goto (set through CFLAGS_EXTRA).
include Makefile

$(BUILD)/py/map.o: CFLAGS += -O2
$(BUILD)/py/mpz.o: CFLAGS += -O2
