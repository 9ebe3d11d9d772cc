"""Rocket TOML and .eng loading: the examples load, and every bad key or value is one clear error."""

from pathlib import Path

import pytest

from desktop.errors import InputFileError
from desktop.io.rocket_file import SCHEMA, RocketFileError, load_rocket, read_eng

ROOT = Path(__file__).resolve().parents[2]
ROCKETS = ROOT / "examples" / "rockets"
MOTORS = ROOT / "examples" / "motors"

BASE = """\
name = "test rocket"

[motor]
file = "{motor}"

[body]
radius_m = 0.049
length_m = 1.9
dry_mass_kg = 3.2
cg_from_nose_m = 1.08

[drag]
cd = 0.45

[nose]
length_m = 0.32
kind = "ogive"

[fins]
count = 3
root_chord_m = 0.16
tip_chord_m = 0.06
span_m = 0.085

[launch]
rail_length_m = 2.4
inclination_deg = 86

[site]
elevation_m = 150
wind_speed_mps = 4
wind_from_deg = 270

[drogue]
cd_s_m2 = 0.25

[main]
cd_s_m2 = 1.8
deploy_altitude_m = 200
"""


def write(tmp_path, text, name="r.toml"):
    p = tmp_path / name
    p.write_text(text.replace("{motor}", str(MOTORS / "Cesaroni_J360.eng")), encoding="utf-8")
    return p


def test_every_example_rocket_loads_with_motor_drogue_and_board():
    names = sorted(p.name for p in ROCKETS.glob("*.toml"))
    assert names == ["c6_model.toml", "j360_sport.toml", "k1000_min_dia.toml", "k400_dual_deploy.toml",
                     "m1670_3km.toml", "m1670_min_dia.toml"]
    for p in ROCKETS.glob("*.toml"):
        spec = load_rocket(p)
        assert spec.name and spec.motor.total_impulse_ns > 0
        assert spec.drogue is not None
        assert spec.board.get("sensors")


def test_base_loads_with_defaults(tmp_path):
    spec = load_rocket(write(tmp_path, BASE))
    assert spec.heading_deg == 0.0 and spec.inclination_deg == 86.0
    assert spec.fin_sweep_m == pytest.approx(0.10)  # default: root - tip
    assert spec.inertia_lateral_kgm2 == pytest.approx(3.2 * 1.9**2 / 12)
    assert spec.drogue.lag_s == 1.0 and spec.main.deploy_altitude_m == 200.0
    # wind from 270 deg (west) blows towards the east
    assert spec.wind_u_mps == pytest.approx(4.0) and abs(spec.wind_v_mps) < 1e-9
    assert spec.drag_points == 0.45


def test_bundled_motor_files_have_their_published_impulse():
    j360 = read_eng(MOTORS / "Cesaroni_J360.eng")
    assert j360.designation == "J360SM" and j360.diameter_mm == 54
    assert j360.total_impulse_ns == pytest.approx(1016, rel=0.03)
    assert j360.time_s[0] == 0.0 and j360.thrust_n[0] == 0.0
    m1670 = read_eng(MOTORS / "Cesaroni_M1670.eng")
    assert m1670.total_impulse_ns == pytest.approx(6000, rel=0.05)
    c6 = read_eng(MOTORS / "Estes_C6_synthetic.eng")
    assert c6.total_impulse_ns == pytest.approx(10.0, abs=0.01)
    assert c6.burn_time_s == pytest.approx(1.85)
    assert c6.average_thrust_n == pytest.approx(5.4, abs=0.01)
    assert any("SYNTHETIC" in c for c in c6.comments)
    assert (MOTORS / "README.md").read_text().count("thrustcurve") >= 1


def replace_line(text, old, new):
    assert old in text, old
    return text.replace(old, new)


ERRORS = [
    # (old line, new line, expected fragments)
    ("dry_mass_kg = 3.2", "dry_mass_kg = -1", ["[body] dry_mass_kg", "out of range", "0.005 to 500 kg"]),
    ("radius_m = 0.049", "radius_m = 2", ["[body] radius_m", "0.005 to 0.5 m"]),
    ("radius_m = 0.049", 'radius_m = "big"', ["[body] radius_m", "must be a number"]),
    ("radius_m = 0.049", "radius_m = true", ["[body] radius_m", "must be a number"]),
    ("count = 3", "count = 3.5", ["[fins] count", "integer", "2 to 8"]),
    ("count = 3", "count = 12", ["[fins] count", "2 to 8"]),
    ("inclination_deg = 86", "inclination_deg = 30", ["[launch] inclination_deg", "45 to 90 deg"]),
    ("wind_from_deg = 270", "wind_from_deg = 400", ["[site] wind_from_deg", "0 to 360 deg"]),
    ("elevation_m = 150", "elevation_m = 9000", ["[site] elevation_m", "-500 to 5000 m"]),
    ("deploy_altitude_m = 200", "deploy_altitude_m = 5", ["[main] deploy_altitude_m", "10 to 3000 m"]),
    ("cd_s_m2 = 0.25", "cd_s_m2 = 0", ["[drogue] cd_s_m2", "out of range"]),
    ('kind = "ogive"', 'kind = "pointy"', ["[nose] kind", "allowed: conical, ogive"]),
    ("span_m = 0.085", "span_m = 0.085\nwidth_m = 3", ["unknown key [fins] width_m", "allowed:"]),
    ('name = "test rocket"', 'name = "test rocket"\ncolour = "red"', ["unknown key colour"]),
    ("[site]", "[weather]", ["unknown section [weather]"]),
    ("cd = 0.45", "cd = 0.45\ncd_table = [[0, 0.4], [1, 0.5]]", ["exactly one of cd"]),
    ("cd = 0.45", "cd_table = [[0, 0.4], [0, 0.5]]", ["[drag] cd_table", "increasing"]),
    ("cd = 0.45", "cd_table = [[0, 0.4]]", ["[drag] cd_table", "at least 2"]),
    ("cd = 0.45", "cd_table = [[0, 0.4], [1, 7]]", ["[drag] cd_table", "cd 0 to 3"]),
    ("cd = 0.45", "", ["exactly one of cd"]),
    ("cg_from_nose_m = 1.08", "cg_from_nose_m = 2.5", ["cg_from_nose_m", "less than [body] length_m"]),
    ("tip_chord_m = 0.06", "tip_chord_m = 0.2", ["[fins] tip_chord_m", "must not exceed root_chord_m"]),
    ("length_m = 0.32", "length_m = 2.5", ["[nose] length_m", "less than [body] length_m"]),
    ("radius_m = 0.049", "radius_m = 0.02", ["does not fit", "radius_m"]),
    ("rail_length_m = 2.4\n", "", ["missing key [launch] rail_length_m", "0.3 to 20 m"]),
    ("[fins]", "[fins_x]", ["unknown section [fins_x]"]),
]


@pytest.mark.parametrize("old,new,fragments", ERRORS)
def test_errors_name_key_and_range(tmp_path, old, new, fragments):
    text = replace_line(BASE, old, new)
    with pytest.raises(RocketFileError) as err:
        load_rocket(write(tmp_path, text))
    msg = str(err.value)
    assert "\n" not in msg
    assert str(tmp_path) in msg
    for f in fragments:
        assert f in msg, (f, msg)


def test_fins_must_fit(tmp_path):
    text = replace_line(BASE, "root_chord_m = 0.16", "root_chord_m = 1.7")
    text = replace_line(text, "tip_chord_m = 0.06", "tip_chord_m = 0.5")
    with pytest.raises(RocketFileError, match="must fit on the body"):
        load_rocket(write(tmp_path, text))


def test_missing_section_and_key(tmp_path):
    with pytest.raises(RocketFileError, match=r"missing section \[motor\]"):
        load_rocket(write(tmp_path, BASE.replace('[motor]\nfile = "{motor}"\n', "")))
    with pytest.raises(RocketFileError, match=r"missing key name \(rocket name\)"):
        load_rocket(write(tmp_path, BASE.replace('name = "test rocket"\n', "")))
    with pytest.raises(RocketFileError, match=r"missing key \[nose\] kind \(one of: conical"):
        load_rocket(write(tmp_path, BASE.replace('kind = "ogive"\n', "")))


def test_board_section_is_normalised_and_range_checked(tmp_path):
    spec = load_rocket(write(tmp_path, BASE + '\n[board]\nsensors = "MS5611+ADXL375"\nrate_hz = 50\n'))
    assert spec.board == {"sensors": "ms5611+adxl375", "rate_hz": 50.0}
    with pytest.raises(RocketFileError,
                       match=r"\[board\] rate_hz = 500 is out of range \(allowed 20 to 100 Hz\)"):
        load_rocket(write(tmp_path, BASE + "\n[board]\nrate_hz = 500\n"))


def test_missing_folder_bad_toml_or_non_utf8_rocket_file_is_an_input_error(tmp_path):
    with pytest.raises(InputFileError, match="rocket file not found"):
        load_rocket(tmp_path / "nope.toml")
    with pytest.raises(InputFileError, match="is a directory"):
        load_rocket(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n", encoding="utf-8")
    with pytest.raises(RocketFileError, match="TOML syntax error"):
        load_rocket(bad)
    bad.write_bytes(b"name = \"\xff\"\n")
    with pytest.raises(InputFileError, match="not UTF-8"):
        load_rocket(bad)
    text = BASE.replace("{motor}", str(tmp_path / "missing.eng"))
    p = tmp_path / "m.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(InputFileError, match="motor file not found"):
        load_rocket(p)


def test_motor_path_is_relative_to_the_toml(tmp_path):
    text = BASE.replace("{motor}", "../motors/Cesaroni_J360.eng")
    p = ROCKETS / "j360_sport.toml"  # a real example uses a relative path
    assert load_rocket(p).motor.designation == "J360SM"
    q = tmp_path / "rel.toml"
    q.write_text(text, encoding="utf-8")
    with pytest.raises(InputFileError, match="motor file not found"):
        load_rocket(q)


@pytest.mark.parametrize("content,fragment", [
    ("; only a comment\n", "no .eng header line"),
    ("X 54 321 P 0.6\n0.1 10\n0.2 0\n", "header needs 7 fields"),
    ("X 54 abc P 0.6 1.1 CTI\n0.1 10\n0.2 0\n", "non-numeric size"),
    ("X 54 321 P 1.6 1.1 CTI\n0.1 10\n0.2 0\n", "masses need"),
    ("X 500 321 P 0.6 1.1 CTI\n0.1 10\n0.2 0\n", "out of range"),
    ("X 54 321 P 0.6 1.1 CTI\n0.1 10\n", "fewer than 2 thrust points"),
    ("X 54 321 P 0.6 1.1 CTI\n0.1 10\n0.2 5\n", "must end at zero thrust"),
    ("X 54 321 P 0.6 1.1 CTI\n0.2 10\n0.1 0\n", "times must increase"),
    ("X 54 321 P 0.6 1.1 CTI\n0.1 -10\n0.2 0\n", "thrust >= 0"),
    ("X 54 321 P 0.6 1.1 CTI\n0.1 ten\n0.2 0\n", "not two numbers"),
    ("X 54 321 P 0.6 1.1 CTI\n0.1 10 3\n0.2 0\n", "needs 'time_s thrust_N'"),
])
def test_malformed_eng_file_is_a_one_line_error(tmp_path, content, fragment):
    p = tmp_path / "m.eng"
    p.write_text(content, encoding="utf-8")
    with pytest.raises(RocketFileError) as err:
        read_eng(p)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_schema_ranges_are_documented():
    for section, keys in SCHEMA.items():
        for key, (kind, _req, low, high, _unit) in keys.items():
            if kind in ("float", "int"):
                assert low < high, (section, key)
