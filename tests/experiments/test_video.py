"""Episode videos decode to the frames written, with the mask tint, GT outline and inset."""

from __future__ import annotations

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest

from simroad import SimroadError
from simroad.envs import RoadCamEnv
from simroad.experiments.video import EpisodeVideo, overlay_frame

W, H, N = 160, 90, 3


@pytest.fixture(scope="module")
def steps():
    """Three consecutive (obs, info) of a small racetrack episode, and the env."""
    env = RoadCamEnv(scenario="racetrack", width=W, height=H, traffic=False)
    obs, info = env.reset(seed=4)
    out = [(obs, info)]
    for _ in range(N - 1):
        obs, _, _, _, info = env.step(np.array([0.0], np.float32))
        out.append((obs, info))
    yield env, out
    env.close()


def _outline(gt: np.ndarray) -> np.ndarray:
    contours, _ = cv2.findContours(gt.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
    canvas = np.zeros(gt.shape, np.uint8)
    cv2.drawContours(canvas, contours, -1, 1, 1)
    return canvas.astype(bool)


def test_overlay_tints_the_prediction_green_and_outlines_the_gt_in_yellow(steps):
    _, ((obs, info), *_) = steps
    gt = info["road_mask"]
    pred = np.zeros_like(gt)
    pred[H // 2 :, : W // 2] = True
    out = overlay_frame(obs, gt, pred)
    assert out.shape == obs.shape and out.dtype == np.uint8 and not np.shares_memory(out, obs)
    edge = _outline(gt)
    assert edge.any() and (out[edge] == (255, 230, 0)).all()
    inside = pred & ~edge
    want = (0.6 * obs[inside].astype(np.float32) + 0.4 * np.array([40, 220, 60], np.float32)).astype(np.uint8)
    assert np.array_equal(out[inside], want)
    untouched = ~pred & ~edge
    assert np.array_equal(out[untouched], obs[untouched])


def _decode(path) -> np.ndarray:
    return np.stack([np.asarray(f)[..., :3] for f in imageio.mimread(path)])


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_written_video_has_every_frame_with_overlay_and_inset(steps, tmp_path, suffix):
    env, pairs = steps
    video = EpisodeVideo(tmp_path / "sub" / f"ep{suffix}", env)
    for obs, info in pairs:
        video.add(obs, info, info["road_mask"])
    path = video.close()
    assert path == tmp_path / "sub" / f"ep{suffix}"
    frames = _decode(path)
    assert frames.shape == (N, H, W, 3)

    tol = 40 if suffix == ".mp4" else 12  # lossy H.264 / 256-colour GIF palette
    for got, want in zip(frames, video.frames):
        assert np.abs(got.astype(int) - want.astype(int)).mean() < tol / 4
    obs, info = pairs[0]
    gt = info["road_mask"]
    inset_w, inset_h = max(32, H * 2 // 5), max(32, H * 3 // 5)
    outside_inset = np.ones(gt.shape, bool)
    outside_inset[: inset_h + 2, -inset_w - 2 :] = False
    road = gt & ~_outline(gt) & outside_inset
    road = cv2.erode(road.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    # the road is tinted green: greener than the raw camera view
    green_gain = frames[0][road][:, 1].astype(int) - frames[0][road][:, 0].astype(int)
    raw_gain = obs[road][:, 1].astype(int) - obs[road][:, 0].astype(int)
    assert green_gain.mean() > raw_gain.mean() + 30
    # the ground-truth outline is yellow (the GIF keeps 1-pixel lines; H.264 blurs their chroma)
    if suffix == ".gif":
        edge = _outline(gt) & outside_inset
        px = frames[0][edge].astype(int)
        yellow = (px[:, 0] > 200) & (px[:, 1] > 180) & (px[:, 2] < 90)
        assert edge.sum() > 50 and yellow.mean() > 0.9
    # the bird's-eye inset sits top right inside a white frame
    border = frames[0][0, -inset_w:]
    assert (border.min(axis=1) > 255 - tol).mean() > 0.9


def test_bad_video_path_and_empty_video_are_clear_errors(steps, tmp_path):
    env, _ = steps
    with pytest.raises(SimroadError, match=r"\.mp4 or \.gif"):
        EpisodeVideo(tmp_path / "ep.avi", env)
    with pytest.raises(SimroadError, match="no frames"):
        EpisodeVideo(tmp_path / "ep.gif", env).close()


def test_a_mask_beside_makes_two_labelled_views_of_the_same_frame(steps):
    """Without/with filters: the left view tints ``beside``, the right one ``pred`` and keeps the inset."""
    env, ((obs, info), *_) = steps
    gt = info["road_mask"]
    left_half = np.zeros_like(gt)
    left_half[:, : W // 2] = True
    video = EpisodeVideo("unused.gif", env, labels=("filters none", "filters all"))
    video.add(obs, info, ~left_half, beside=left_half)
    frame = video.frames[0]
    assert frame.shape == (H, 2 * W + 2, 3) and (frame[:, W : W + 2] == 255).all()
    left, right = frame[:, :W], frame[:, W + 2 :]
    rows = slice(H // 2, H - 15)  # below the inset, above the labels
    greener = lambda view, cols: (view[rows, cols, 1].astype(int) - obs[rows, cols, 1]).mean()  # noqa: E731
    as_seen = lambda view, cols: (view[rows, cols] == obs[rows, cols]).all(axis=-1).mean()  # noqa: E731
    west, east = slice(5, W // 2 - 5), slice(W // 2 + 5, W - 5)
    assert greener(left, west) > 20 and as_seen(left, east) > 0.9  # untouched but the yellow outline
    assert greener(right, east) > 20 and as_seen(right, west) > 0.9
    assert (left[-3:, :20] < obs[-3:, :20]).any()  # the label's dark band
    single = EpisodeVideo("unused.gif", env)
    single.add(obs, info, ~left_half)
    np.testing.assert_array_equal(single.frames[0][:, :, :][rows], right[rows])  # the same right view


def test_run_episode_shows_the_detector_without_filters_beside(tmp_path):
    from simroad.experiments.episode import EpisodeSpec, run_episode

    spec = EpisodeSpec(scenario="racetrack", noise="shadow", severity=0.7, filters="all", seed=1, steps=3,
                       env_options={"width": W, "height": H})  # fmt: skip
    alone = run_episode(spec)
    shown = run_episode(spec, video=str(tmp_path / "ab.gif"), video_compare="none")
    timing = ("detect_ms_median", "step_ms_median", "wall_s")
    assert {k: v for k, v in shown.items() if k not in timing} == {k: v for k, v in alone.items() if k not in timing}
    assert _decode(tmp_path / "ab.gif").shape == (3, H, 2 * W + 2, 3)
    with pytest.raises(SimroadError, match="video_compare"):
        run_episode(spec, video_compare="none")  # no video to show it in
