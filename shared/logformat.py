"""The flight log's portable layout: file magic, block and record formats, flags, CRC.

Shared by the board's writer (``device/flightlog.py``, which also builds the JSON header) and the
desktop decoder (``desktop/io/logdecode.py``). Constants and one check only: runs unchanged on
MicroPython and CPython.

File layout (``flight.log``)::

    FILE_MAGIC (8 bytes) | header length (u32) | CRC-32 of the header (u32) | header (JSON, UTF-8)
    block | block | ...                                   (BLOCK_SIZE bytes each)

Block (BLOCK_SIZE = 2048 bytes)::

    BLK_FMT header, 32 bytes: magic 'FBLK', sequence number, index of the first sample, number of
    records, kind (0 data, 1 summary JSON, 2 note JSON), index of the sample at which the flight
    computer whose records these are started (``fc_start``), CRC-32 of the whole block computed
    with this field 0, 8 zero bytes; then up to BLOCK_RECORDS records of REC_SIZE bytes.

Record (REC_FMT, 32 bytes, little-endian): what ``FlightComputer.step()`` was given (``dt_us``,
``pressure_q4_pa`` (the altitude is ``shared.altitude.pressure_to_alt_mm`` of it),
``accel_mmps2``, ``have``) and what it decided (filter ``alt_q4``/``vel_q4``/``acc_q4``,
``state``, ``events``), plus ``flags`` (FLAG_*), the barometer temperature (0.01 degC) and the
work time of the sample (read + step + outputs, us, saturated at 65535).

``events`` holds the low 8 bits of ``FlightComputer.events`` (launch .. mode). The backup channels'
events (bits 8 and 9) do not fit that byte: the record keeps their output levels in
FLAG_PYRO_BACKUP_DROGUE / FLAG_PYRO_BACKUP_MAIN, and a backup fired on the first record whose
flag is set (a pulse lasts at least 10 ms: pulse_ms). Logs written before these flags existed
never set them: they decode as before. An ignition in coast (bit 10) is the record whose ``state``
goes from fast or coast back to boost.
"""

import struct

try:
    from binascii import crc32
except ImportError:  # pragma: no cover - ports without binascii.crc32
    from zlib import crc32

FORMAT_VERSION = 1
FILE_MAGIC = b"AFCLOG1\n"
FILE_HDR_FMT = "<II"  # header length, CRC-32 of the header
REC_FMT = "<IiiiiiBBBBhH"
REC_SIZE = 32
REC_FIELDS = ("dt_us", "pressure_q4_pa", "accel_mmps2", "alt_q4", "vel_q4", "acc_q4", "have", "state",
              "events", "flags", "temp_cdeg", "work_us")
BLOCK_SIZE = 2048
BLK_FMT = "<IIIHHII"
BLK_HDR = 32
BLOCK_RECORDS = (BLOCK_SIZE - BLK_HDR) // REC_SIZE  # 63
BLK_MAGIC = 0x4B4C4246  # b"FBLK" read as a little-endian u32
BLK_CRC_OFFSET = 20
KIND_DATA = 0
KIND_SUMMARY = 1
KIND_NOTE = 2

FLAG_PYRO_DROGUE = 1  # output level after this sample
FLAG_PYRO_MAIN = 2
FLAG_SENSOR_ERROR = 4  # a sensor read failed in this sample
FLAG_MISSED = 8  # dt_us covers missed sample deadlines
FLAG_RESUMED = 16  # first sample after a reset in flight (the state was restored)
FLAG_PYRO_BACKUP_DROGUE = 32  # output level after this sample
FLAG_PYRO_BACKUP_MAIN = 64
EVENTS_MASK = 0xFF  # the events a record's byte holds


def block_crc_ok(block):
    """Check one block's CRC (CPython and MicroPython; allocates)."""
    stored = struct.unpack_from("<I", block, BLK_CRC_OFFSET)[0]
    tmp = bytearray(block)
    struct.pack_into("<I", tmp, BLK_CRC_OFFSET, 0)
    return crc32(tmp) & 0xFFFFFFFF == stored
