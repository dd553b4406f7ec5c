"""The shipped sweep configurations: valid grids, and an honest protocol (training,
validation and evaluation worlds never overlap)."""

from __future__ import annotations

from pathlib import Path

import pytest

from simroad.experiments.grid import AblationGrid, load_grid_file

CONFIGS = Path(__file__).resolve().parents[2] / "experiments"
#: The shipped model's training worlds (simroad train-detector, README "The shipped model").
TRAINING_WORLDS = set(range(16))
GRID_KEYS = {"workers", "backend", "ray_address", "out"}


def _grid(name: str) -> AblationGrid:
    data = load_grid_file(CONFIGS / name)
    return AblationGrid(**{k: v for k, v in data.items() if k not in GRID_KEYS})


def _worlds(grid: AblationGrid) -> set[int]:
    return {spec.seed for spec in grid.specs()}


@pytest.mark.parametrize("name", sorted(p.name for p in CONFIGS.glob("*.toml")))
def test_every_shipped_config_is_a_valid_grid(name):
    assert _grid(name).specs()


def test_paper_evaluates_paired_on_worlds_no_one_tuned_or_trained_on():
    paper, validate = _grid("paper.toml"), _grid("validate.toml")
    evaluation, validation = _worlds(paper), _worlds(validate)
    assert evaluation == set(range(140, 146)) and validation == set(range(200, 203))
    # nor looked at before: filter-effect's two sets and the earlier evaluations (100-114, 120-135)
    assert not evaluation & (set(range(100, 115)) | set(range(120, 136)))
    assert not evaluation & validation and not (evaluation | validation) & TRAINING_WORLDS
    specs = paper.specs()
    assert len(specs) == 648
    # paired: every world and weather is driven without filters and with all of them
    cells = {}
    for s in specs:
        if s.driver == "detector":
            cells.setdefault((s.scenario, s.noise, s.severity, s.seed), set()).add(s.filters)
    assert cells and all(v == {(), ("shadow", "rain_snow", "light")} for v in cells.values())
