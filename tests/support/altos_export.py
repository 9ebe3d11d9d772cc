"""AltosUI CSV exports written from the documented layouts (docs/IMPORT.md), filled with a real
flight: the sensor samples and logged states of a converted AltOS log in tests/data/flights/altos/.

No original AltosUI export with a licence that allows copying it here was found (the public ones
carry no licence), so the importer is tested on these: each layout's header as AltosUI writes it
(version 5: the 2012 eeprom exports, with the documented header bugs; version 6: the current
writer's optional column groups per board family), one row per log record with every value
carried forward, several rows per printed time and the extra temperature/voltage rows between
descent samples, as AltosUI writes them.
"""

from shared.physics import G0_MPS2 as G

MISSING = "2147483647.00"

V5_COMMENTS = [
    "# Comments",
    "# Config version: 1.1",
    "# Main deploy: 250",
    "# Apogee delay: 0",
    "# Callsign: N0CALL",
    "# Accel cal: 16126 16382",
    "# Product: TeleMetrum-v1.2",
    "# Serial number: 882",
    "# Software version: 1.0.3",
]
V5_HEADER = ("#version,serial,flight,call,time,clock,rssi,lqi,state,state_name,acceleration,pressure,"
             "altitude,height,accel_speed,baro_speed,temperature,battery_voltage,drogue_voltage,"
             "main_voltageaccel_x,accel_y,accel_z,gyro_x,gyro_y,gyro_z,connected,locked,nsat,latitude,"
             "longitude,altitude,year,month,day,hour,minute,second,pad_dist,pad_range,pad_az,pad_el,hdop,"
             + ",".join("sat%02d" % i for i in range(1, 33)))
STATE_CODES = {"pad": 2, "boost": 3, "fast": 4, "coast": 5, "drogue": 6, "main": 7, "landed": 8}
GPS_V6 = ("connected,locked,nsat,latitude,longitude,altitude,year,month,day,hour,minute,second,"
          "pad_dist,pad_range,pad_az,pad_el,pdop,hdop,vdop")
# version 6 column groups per family (AltosCSV: has_accel, has_pyro, has_battery, 3-D accel + IMU,
# extra igniters, GPS)
FAMILIES = {
    "TeleMetrum": dict(call=True, radio=False, accel=True, imu=False, igniters=False, gps=True),
    "TeleMega": dict(call=True, radio=False, accel=True, imu=True, igniters=True, gps=True),
    "TeleMega-telemetry": dict(call=True, radio=True, accel=True, imu=True, igniters=True, gps=True),
    "EasyMega": dict(call=False, radio=False, accel=True, imu=True, igniters=True, gps=False),
    "EasyMini": dict(call=False, radio=False, accel=False, imu=False, igniters=False, gps=False),
    "TeleMini": dict(call=True, radio=False, accel=False, imu=False, igniters=False, gps=False),
}


def _alt(p):
    return 44330.77 * (1 - (p / 101325.0) ** 0.190263)


def records(log):
    """(time_s, pressure, acceleration, state, is_sensor) per log record: every sample of ``log``
    (a converted AltOS FlightLog), plus, every 0.32 s, a temperature/voltage record that repeats
    the last sensor values (at the same printed time in the ascent, 0.02 s later in the descent)."""
    out = []
    next_extra = log.time_s[0]
    for i in range(len(log)):
        t = float(log.time_s[i])
        state = str(log.extra["altos_state"][i])
        acc = float(log.accel_mps2[i]) - G
        p = float(log.pressure_pa[i])
        out.append((t, p, acc, state, True))
        if t >= next_extra:
            later = 0.02 if state in ("drogue", "main", "landed") else 0.0
            out.append((round(t + later, 2), p, acc, state, False))
            next_extra = t + 0.32
    return out


def write_v5(path, log):
    """A version-5 TeleMetrum export (70 fields, the documented 2012 layout)."""
    lines = list(V5_COMMENTS) + [V5_HEADER]
    ground = _alt(float(log.pressure_pa[0]))
    for t, p, acc, state, _sensor in records(log):
        fields = ["5", "882", "1", "N0CALL", "%8.2f" % t, "%8.2f" % (t + 100), "0", "0",
                  str(STATE_CODES[state]), "%8s" % state, "%8.2f" % acc, "%10.2f" % p,
                  "%8.2f" % _alt(p), "%8.2f" % (_alt(p) - ground), "%8.2f" % 0.0, "%8.2f" % 0.0,
                  "%5.1f" % 15.0, "%5.2f" % 3.9, "%5.2f" % 3.7, "%5.2f" % 3.7, ""]
        fields += ["1", "1", "8", "37.1", "-97.7", "382", "2012", "4", "7", "18", "0", "0",
                   "0", "0", "0", "0", "1.0"] + ["0"] * 32
        lines.append(",".join(fields))
    _write_lines(path, lines)
    return len(fields)


def write_v6(path, log, family):
    """A version-6 export of ``family`` (FAMILIES) as the current AltosUI writes it."""
    f = FAMILIES[family]
    names = ["version", "serial", "flight"] + (["call"] if f["call"] else []) + ["time"]
    names += (["rssi", "lqi"] if f["radio"] else []) + ["state", "state_name"]
    names += (["acceleration"] if f["accel"] else []) + ["pressure", "altitude", "height", "speed",
                                                         "temperature", "drogue_voltage", "main_voltage",
                                                         "battery_voltage"]
    if f["imu"]:
        names += "accel_x,accel_y,accel_z,gyro_roll,gyro_pitch,gyro_yaw,mag_x,mag_y,mag_z,tilt".split(",")
    if f["igniters"]:
        names += ["pyro", "igniter_a", "igniter_b", "igniter_c", "igniter_d"]
    if f["gps"]:
        names += GPS_V6.split(",") + ["sat%02d" % i for i in range(1, 33)]
    lines = ["#" + ",".join(names)]
    ground = _alt(float(log.pressure_pa[0]))
    for t, p, acc, state, _sensor in records(log):
        row = ["6", " 1018", " 3"] + (["KC1QJA"] if f["call"] else []) + ["%8.2f" % t]
        row += (["%4d" % -71, "%3d" % 6] if f["radio"] else []) + ["%2d" % STATE_CODES[state], "%8s" % state]
        row += (["%8.2f" % acc] if f["accel"] else []) + ["%10.2f" % p, "%8.2f" % _alt(p),
                                                          "%8.2f" % (_alt(p) - ground), "%8.2f" % 0.0,
                                                          "%5.1f" % 20.0, "%5.2f" % 3.7,
                                                          "%5.2f" % 3.7, "%5.2f" % 4.1]
        if f["imu"]:
            row += ["%7.2f" % (acc + G)] + ["%7.2f" % 0.0] * 8 + ["%7.2f" % 4.0]
        if f["igniters"]:
            row += ["%5.2f" % 8.3] + ["%5.2f" % 0.0] * 4
        if f["gps"]:
            row += ["1", "1", "8", "42.63", "-88.17", "33.0", "2013", "4", "27", "20", "16", "12",
                    "0", "0", "0", "0", "2147483647.0", "2147483647.0", "2147483647.0"] + ["0"] * 32
        lines.append(",".join(row))
    _write_lines(path, lines)
    return names


def _write_lines(path, lines):
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
