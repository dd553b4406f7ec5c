"""A camera profile through the experiments: the ablation grid's field and config key,
every episode spec of the grid, and the ``camera_profile`` of every episode record."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import pytest

from simroad.camera.profile import CameraProfile, save_profile
from simroad.errors import InvalidParameterError
from simroad.experiments.ablate import run_cell
from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, run_episode
from simroad.experiments.grid import AblationGrid, load_grid_file
from simroad.experiments.results import check_row

PROFILE = CameraProfile(exposure_bias_ev=0.8, wb_preset_k=4200.0, tone_gamma=1.3, asphalt_scale=1.4)


def test_grid_field_reaches_every_episode_spec(tmp_path):
    path = tmp_path / "camera.toml"
    save_profile(PROFILE, path)
    for given in (PROFILE, str(path), path, PROFILE.as_dict()):
        grid = AblationGrid(noises="clear", filters="none", seeds=1, camera_profile=given)
        assert grid.camera_profile == PROFILE
        assert all(s.env_options["camera_profile"] == PROFILE for s in grid.specs())
    plain = AblationGrid(noises="clear", filters="none", seeds=1)
    assert plain.camera_profile is None and all("camera_profile" not in s.env_options for s in plain.specs())


def test_a_grid_without_a_profile_keeps_its_fingerprint():
    """Sweeps started before the field existed resume: their digest is unchanged."""
    grid = AblationGrid()
    fields = {k: v for k, v in dataclasses.asdict(grid).items() if k not in ("camera_profile", "env_options")}
    old = hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:16]
    assert grid.fingerprint() == old
    assert AblationGrid(camera_profile=PROFILE).fingerprint() != old
    assert grid.fingerprint() == "7df94e7414f770c7"  # the digest of the default grid before env_options existed


def test_config_file_path_is_relative_to_the_config(tmp_path):
    (tmp_path / "profiles").mkdir()
    save_profile(PROFILE, tmp_path / "profiles" / "camera.toml")
    cfg = tmp_path / "grid.toml"
    cfg.write_text('noises = "clear"\nseeds = 1\ncamera_profile = "profiles/camera.toml"\n')
    opts = load_grid_file(cfg)
    assert AblationGrid(**opts).camera_profile == PROFILE
    cfg.write_text('noises = "clear"\n[camera_profile]\ntone_gamma = 1.3\n')
    assert AblationGrid(**load_grid_file(cfg)).camera_profile == CameraProfile(tone_gamma=1.3)


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ({"tone_gama": 1.3}, "unknown profile key 'tone_gama'"),
        ({"tone_gama": 1.3}, "Did you mean 'tone_gamma'"),
        ({"asphalt_scale": 9.0}, "asphalt_scale"),
        ("nowhere.toml", "camera_profile"),
        (3, "camera_profile: expected a CameraProfile"),
    ],
)
def test_bad_profiles_in_a_grid_are_refused_by_name(value, words):
    with pytest.raises(InvalidParameterError) as info:
        AblationGrid(camera_profile=value)
    assert words in str(info.value)


def test_episode_records_say_which_camera(tmp_path):
    spec = EpisodeSpec(
        scenario="highway", noise="clear", driver="oracle", steps=2, env_options={"camera_profile": PROFILE}
    )
    record = run_episode(spec)
    assert tuple(record) == RECORD_KEYS and record["camera_profile"] == PROFILE.as_dict()
    assert json.loads(json.dumps(record))["camera_profile"]["sky_brightness"] == list(PROFILE.sky_brightness)
    assert run_episode(dataclasses.replace(spec, env_options={}))["camera_profile"] == CameraProfile().as_dict()
    assert check_row({**record, "error": None}) is None


def test_a_failed_episode_keeps_its_camera():
    def boom(spec):
        raise RuntimeError("boom")

    spec = EpisodeSpec(scenario="highway", driver="oracle", steps=1, env_options={"camera_profile": PROFILE})
    record = run_cell(spec, episode_fn=boom)
    assert record["camera_profile"] == PROFILE.as_dict() and record["error"].startswith("RuntimeError")
    assert check_row(record) is None


def test_result_rows_without_a_profile_still_count_and_bad_ones_are_named():
    row = {**dict.fromkeys(RECORD_KEYS, 0.0), "scenario": "highway", "noise": "clear", "filters": "none",
           "driver": "oracle", "detector": "", "detector_version": "", "detector_spec": "", "seed": 0, "steps": 1,
           "min_ttc_s": None, "min_stopping_margin_m": None, "error": None}  # fmt: skip
    for key in ("camera_profile", "detector_options", "env_options", "step_budget"):
        row.pop(key)
    assert check_row(row) is None  # written before records held the camera, the options and the budget
    assert "camera_profile" in check_row({**row, "camera_profile": "default"})
