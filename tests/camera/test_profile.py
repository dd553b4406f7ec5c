"""CameraProfile files: what save_profile writes load_profile reads back, and every
unusable file or value is refused by name."""

from __future__ import annotations

import dataclasses

import pytest

from simroad.camera.profile import (
    CAMERA_FIELDS,
    PROFILE_RANGES,
    CameraProfile,
    load_profile,
    profile_from_dict,
    resolve_profile,
    save_profile,
)
from simroad.camera.sensor_params import SensorParams
from simroad.errors import InvalidParameterError

FITTED = CameraProfile(
    exposure_bias_ev=0.8,
    wb_preset_k=4200.0,
    tone_gamma=1.3,
    asphalt_scale=1.4,
    sky_brightness=(0.9, 2.5),
    overcast_share=0.3,
    hazy_share=0.1,
)


def test_save_then_load_is_the_same_profile(tmp_path):
    path = tmp_path / "camera.toml"
    save_profile(FITTED, path, comment="fitted to 12 photos\nKS road_V 0.1")
    text = path.read_text()
    assert text.startswith("# fitted to 12 photos\n# KS road_V 0.1\n[camera_profile]\n")
    assert load_profile(path) == FITTED
    assert resolve_profile(str(path)) == FITTED and resolve_profile(path) == FITTED


def test_top_level_keys_and_a_partial_table_keep_the_defaults(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("tone_gamma = 2.0\nsky_brightness = [1.0, 1.5]\n")
    assert load_profile(path) == CameraProfile(tone_gamma=2.0, sky_brightness=(1.0, 1.5))


def test_as_dict_is_plain_values():
    d = FITTED.as_dict()
    assert d["sky_brightness"] == [0.9, 2.5] and d["wb_preset_k"] == 4200.0
    assert profile_from_dict(d) == FITTED


def test_resolve_profile_forms():
    assert resolve_profile(None) == CameraProfile()
    assert resolve_profile(FITTED) is FITTED
    assert resolve_profile({"tone_gamma": 1.3}) == CameraProfile(tone_gamma=1.3)
    with pytest.raises(InvalidParameterError, match="camera_profile: expected a CameraProfile"):
        resolve_profile(3)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[camera_profile]\nexposure_bias = 0.5\n", "unknown profile key 'exposure_bias'"),
        ("[camera_profile]\nexposure_bias = 0.5\n", "Did you mean 'exposure_bias_ev'?"),
        ("[camera_profile]\ntone_gamma = 9.0\n", "tone_gamma"),
        ("[camera_profile]\nwb_preset_k = 100.0\n", "wb_preset_k"),
        ("[camera_profile]\nsky_brightness = [2.0, 1.0]\n", "sky_brightness: expected low <= high"),
        ("[camera_profile]\nsky_brightness = 1.0\n", "sky_brightness: expected a pair"),
        ("[camera_profile]\novercast_share = 0.8\nhazy_share = 0.5\n", "overcast_share + hazy_share"),
        ("[camera_profile\n", "is not valid TOML"),
    ],
)
def test_bad_files_are_refused_by_name(tmp_path, text, words):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InvalidParameterError) as info:
        load_profile(path)
    assert words in str(info.value)


def test_a_missing_file_is_refused_by_name(tmp_path):
    with pytest.raises(InvalidParameterError, match="camera_profile"):
        load_profile(tmp_path / "nowhere.toml")


def _moved(profile: CameraProfile, name: str) -> CameraProfile:
    """``profile`` with field ``name`` moved inside its range."""
    value = getattr(profile, name)
    if isinstance(value, tuple):
        return dataclasses.replace(profile, **{name: (value[0] * 1.1, value[1] * 1.05)})
    lo, hi, _ = PROFILE_RANGES[name]
    return dataclasses.replace(profile, **{name: value + 0.1 * (hi - lo) if value + 0.1 * (hi - lo) <= hi else lo})


def test_the_sensor_reads_exactly_the_camera_fields():
    """What the calibration's replays rely on: a profile that differs only in daylight
    or asphalt gives the same sensor; each camera field changes it."""
    params, base = SensorParams(), CameraProfile(overcast_share=0.4)
    for f in dataclasses.fields(CameraProfile):
        moved = params.with_profile(_moved(base, f.name))
        assert (moved != params.with_profile(base)) == (f.name in CAMERA_FIELDS), f.name
