"""Room in the attribute tables of the per-sample objects: MicroPython's speed.

MicroPython keeps an instance's attributes in a hash table (py/map.c) that grows only when it is
full, to the next of _TABLE_SIZES. A lookup that its map cache misses probes from the name's hash
slot by slot (a division each) to the name, or to an empty slot (a method, whose lookup misses the
instance's table before it finds the class's): in a nearly full table that is most of the table.
The flight computer's 70 attributes sat in 73 slots; ``make_room`` grows each per-sample object's
table by one size once it is built, leaving a quarter of it empty (docs/BENCHMARKS.md, "Per-sample
cost on an emulated Cortex-M0"). On CPython it changes nothing.

The per-sample classes have no property, descriptor or ``__setattr__``: with one, MicroPython looks
every store to an instance's attribute up in its class first (py/objtype.c), and the step stores a
dozen per sample (tests/shared/test_flight.py checks it).
"""

# py/map.c's hash_allocation_sizes, as far as an object here reaches
_TABLE_SIZES = (0, 2, 4, 6, 8, 10, 12, 17, 23, 29, 37, 47, 59, 73, 97, 127, 167, 223, 293)


def make_room(obj):
    """Grow ``obj``'s attribute table to the next size: add attributes until the full table grows,
    then delete them (at construction: this allocates)."""
    n = len(obj.__dict__)
    for size in _TABLE_SIZES:
        if size >= n:
            break
    names = ["_room%d" % i for i in range(size - n + 1)]
    for name in names:
        setattr(obj, name, 0)
    for name in names:
        delattr(obj, name)
