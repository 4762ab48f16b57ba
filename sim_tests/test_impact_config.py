"""Campaign configs: parsed, validated, every problem named before anything runs."""

import pytest

from rmbench.errors import InputError
from rmbench.impact import bundled_configs, load_config, parse_config

BAND = """
[bands.high]
f_min = 600.0
f_max = {f_max}
sensor = "accelerometer"
s_1a_mm = 20.0
sample_rate = 40000.0
line_spacing = 1.0
[bands.high.hammer]
pulse_ms = 0.25
peak_n = 400.0
"""


@pytest.mark.parametrize("name", sorted(bundled_configs()))
def test_bundled_configs_are_valid(name):
    cfg = load_config(name)
    assert cfg.hits.averages >= 3


def test_seed_full_config_is_the_seed_design():
    cfg = load_config("seed_full")
    assert cfg.grid.kind == "seed"
    assert cfg.hits.points == ["1X", "1Y", "1aX", "1aY"]
    assert cfg.bands["low"].sensor == "laser" and cfg.bands["low"].s_1a_mm == 33.4
    assert cfg.bands["high"].sensor == "accelerometer" and cfg.bands["high"].s_1a_mm == 20.0


@pytest.mark.parametrize("text, message", [
    ("colour = 'red'", "colour: unknown key"),
    ("[hits]\naverages = -3", "hits.averages"),
    ("[grid]\nkind = 'list'\npostures = []", "non-empty postures"),
    (BAND.format(f_max=12000.0), "beyond the accelerometer"),
    ("[robot]\nname = 'irb6660'\n[robot.extra]\na = 1", "robot.extra"),
    ("seed = ", "not valid TOML"),
], ids=["unknown-key", "negative-averages", "empty-grid", "band-beyond-sensor", "unknown-table", "bad-toml"])
def test_bad_config_is_rejected_with_the_key_named(text, message):
    with pytest.raises(InputError, match=message):
        parse_config(text, source="test.toml")


def test_missing_config_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_config(tmp_path / "nope.toml")


def test_config_digest_changes_with_content():
    a = parse_config("seed = 1")
    b = parse_config("seed = 2")
    assert a.digest != b.digest and a.digest == parse_config("seed = 1").digest
