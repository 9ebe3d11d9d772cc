"""Configuration: defaults are valid, every bad value is one clear error naming the key."""

import json

import pytest

from shared.config import SCHEMA, ConfigError, load_config, load_config_file


def test_defaults_are_valid_and_converted_to_integer_units():
    cfg = load_config()
    assert cfg.main_deploy_mm == 250000 and cfg.pulse_ms == 500
    assert cfg.has_baro and cfg.has_accel and not cfg.seed_rule
    assert cfg.values["main_deploy_m"] == 250


@pytest.mark.parametrize("values,expected", [
    ({"main_deploy_m": -5}, "main_deploy_m = -5 is out of range: allowed 0 to 5000 m AGL"),
    ({"main_deploy_m": 5}, "main_deploy_m = 5 is out of range: allowed 0 (no main) or 10 to 5000 m AGL"),
    ({"main_deploy_m": "250"}, "main_deploy_m must be a number"),
    ({"main_deploy_m": True}, "main_deploy_m must be a number"),
    ({"main_deploy_m": float("nan")}, "main_deploy_m must be a number"),
    ({"pulse_ms": 0}, "pulse_ms = 0 is out of range"),
    ({"main_altitude": 300}, "unknown key 'main_altitude'"),
    ({"apogee_rule": "fast"}, "apogee_rule = 'fast' is not one of velocity, seed"),
    ({"sensors": "gps"}, "sensors = 'gps' is not one of both, baro, accel"),
    ({"backup_drogue_s": 5, "apogee_lockout_s": 10}, "backup_drogue_s = 5 fires before apogee_lockout_s"),
    ({"sensors": "accel", "apogee_rule": "seed"}, "needs a barometer"),
    ({"backup_main_m": 250}, "backup_main_m = 250 is out of range: allowed 0 (no backup main) or 10 m AGL "
                             "to below main_deploy_m = 250"),
    ({"backup_main_m": 5}, "backup_main_m = 5 is out of range"),
    ({"backup_main_m": 100, "main_deploy_m": 0}, "below main_deploy_m = 0"),
    ({"backup_drogue_delay_s": 31}, "backup_drogue_delay_s = 31 is out of range: allowed 0 to 30 s"),
    ({"backup_main_delay_s": 0}, "backup_main_delay_s = 0 is out of range: allowed 0.1 to 60 s"),
])
def test_bad_values_name_the_key(values, expected):
    with pytest.raises(ConfigError) as exc:
        load_config(values)
    msg = str(exc.value)
    assert expected in msg and "\n" not in msg


def test_not_an_object():
    with pytest.raises(ConfigError, match="expected a JSON object"):
        load_config([1, 2])


def test_file_errors(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{main_deploy_m: 200")
    with pytest.raises(ConfigError, match="not valid JSON"):
        load_config_file(str(bad))
    with pytest.raises(ConfigError, match="cannot read"):
        load_config_file(str(tmp_path / "missing.json"))
    good = tmp_path / "good.json"
    good.write_text(json.dumps({"main_deploy_m": 150, "apogee_delay_s": 1}))
    assert load_config_file(str(good)).main_deploy_mm == 150000


def test_every_key_has_a_unit_and_meaning():
    for key, (default, low, high, unit, meaning) in SCHEMA.items():
        assert low <= default <= high, key
        assert unit and meaning, key


def test_every_key_is_documented():
    from pathlib import Path

    from shared.config import CHOICES

    doc = (Path(__file__).parents[2] / "docs" / "CONFIG.md").read_text()
    for key in list(SCHEMA) + list(CHOICES):
        assert "`%s`" % key in doc, key
