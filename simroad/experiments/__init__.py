"""Experiments: episodes, ablation sweeps, reports, frame export, evaluation, figures."""

from __future__ import annotations

from simroad.experiments.ablate import BACKENDS, run_ablation, run_cell
from simroad.experiments.episode import RECORD_KEYS, EpisodeSpec, run_episode
from simroad.experiments.export import export_frames
from simroad.experiments.frames import FrameSet, collect_frames
from simroad.experiments.grid import AblationGrid, load_grid_file
from simroad.experiments.report import build_report
from simroad.experiments.results import ResultStore

__all__ = [
    "BACKENDS",
    "RECORD_KEYS",
    "AblationGrid",
    "EpisodeSpec",
    "FrameSet",
    "ResultStore",
    "build_report",
    "collect_frames",
    "export_frames",
    "load_grid_file",
    "run_ablation",
    "run_cell",
    "run_episode",
]
