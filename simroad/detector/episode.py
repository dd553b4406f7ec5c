"""An episode of road detection: what carries from one frame to the next, owned by the caller.

:meth:`RoadDetector.predict <simroad.detector.RoadDetector.predict>` reads one frame on
its own and leaves the detector as it was (scikit-learn's ``check_dict_unchanged``).
What the improved detector knows across an episode's frames lives here instead:

- the camera's ground mask (``camera.ground_valid``): pixels above the horizon are
  never road;
- the :class:`GlareMemory`: the detector saw a sun's specular lobe within the last
  :data:`GLARE_MEMORY_FRAMES` frames, so it keeps taking the road from region growth
  (the sun is still up when the car turns and the lobe leaves the view, or when the
  lobe test misses a frame; the exposure it forced lasts as well).

:meth:`RoadDetector.episode <simroad.detector.RoadDetector.episode>` returns a
:class:`DetectorEpisode` that holds both and predicts frames in order through the pure
:meth:`RoadDetector.predict_step <simroad.detector.RoadDetector.predict_step>`; the
mask driver (:class:`~simroad.control.MaskDriver`) starts one per episode. A
:class:`GlareMemory` is a frozen value: the same frames and the same memory give the
same masks and the same next memory.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, TypeGuard

import numpy as np

from simroad.detector.growth import GROW_TOLERANCE, _across_lobe, _as_uint8, _grow
from simroad.errors import InvalidParameterError

__all__ = ["GLARE_MEMORY_FRAMES", "DetectorEpisode", "GlareMemory"]

#: Frames after the light filter last removed a sun's lobe during which the improved
#: detector still takes the road from region growth (20 frames: 4 s at 5 Hz). A sun
#: that cast a lobe is still up when the car turns and the lobe leaves the view, or
#: when the lobe test misses a frame; the exposure it forced lasts as well.
GLARE_MEMORY_FRAMES = 20


@dataclass(frozen=True)
class GlareMemory:
    """What the improved detector carries from one frame of an episode to the next.

    Parameters
    ----------
    since_lobe : int or None, optional
        Frames since the light filter last removed a sun's lobe (0 on that frame);
        None (default) if it has not in this episode.
    lobe_top : float, optional
        Top row of that lobe as a fraction of the frame height, in [0, 1] (0 by
        default): without a camera, region growth stays below it (a sun's lobe lies on
        the ground; above it the bright sky meets the lobe without a step). Only frames
        predicted without a ground mask set it.
    """

    since_lobe: int | None = None
    lobe_top: float = 0.0

    def __post_init__(self) -> None:
        since = self.since_lobe
        if since is not None and (isinstance(since, bool) or not isinstance(since, int | np.integer) or since < 0):
            raise InvalidParameterError(
                f"since_lobe: expected None or an int >= 0 (frames since the last lobe), got {since!r}; "
                "start an episode with GlareMemory()."
            )
        top = self.lobe_top
        if isinstance(top, bool) or not isinstance(top, int | float | np.floating | np.integer) or not 0 <= top <= 1:
            raise InvalidParameterError(
                f"lobe_top: expected a fraction of the frame height in [0, 1], got {top!r}; "
                "start an episode with GlareMemory()."
            )

    @property
    def active(self) -> bool:
        """True within :data:`GLARE_MEMORY_FRAMES` frames of the last lobe (and on its frame)."""
        return self.since_lobe is not None and self.since_lobe <= GLARE_MEMORY_FRAMES

    def saw_lobe(self, lobe: np.ndarray, *, keep_top: bool) -> GlareMemory:
        """The memory after a frame where the light filter removed ``lobe`` (bool (H, W),
        not empty); its top row is kept unless ``keep_top`` (a frame with a ground mask)."""
        if keep_top:
            return GlareMemory(0, self.lobe_top)
        return GlareMemory(0, float(np.argmax(lobe.any(axis=1))) / lobe.shape[0])

    def next_frame(self) -> GlareMemory:
        """The memory after a frame without a lobe: one frame further from the last one."""
        if self.since_lobe is None:
            return self
        return GlareMemory(self.since_lobe + 1, self.lobe_top)

    def growth_bound(self, ground: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
        """Where region growth may go, bool ``shape``: the camera's ``ground`` when there is
        one; else the rows from the top of the last lobe (``lobe_top``) down."""
        if ground is not None:
            return ground
        bound = np.zeros(shape, bool)
        bound[int(round(self.lobe_top * shape[0])) :] = True
        return bound


def _is_ground_mask(value: Any) -> TypeGuard[np.ndarray]:
    """Whether ``value`` is a bool (H, W) array, the form of ``camera.ground_valid``."""
    return isinstance(value, np.ndarray) and value.ndim == 2 and value.dtype == np.bool_


def _check_ground(name: str, ground: Any) -> np.ndarray | None:
    """``ground`` as it is if it is None or a bool (H, W) array, else an error naming ``name``."""
    if ground is None:
        return None
    if not _is_ground_mask(ground):
        raise InvalidParameterError(
            f"{name}: expected None or a bool (H, W) ground mask (camera.ground_valid), "
            f"got {type(ground).__name__}{_shape_dtype(ground)}."
        )
    return ground


def _camera_ground(camera: Any) -> np.ndarray | None:
    """A copy of ``camera.ground_valid`` (bool (H, W), True where a pixel sees the
    ground), None for no camera, or an error naming ``camera``."""
    if camera is None:
        return None
    ground = getattr(camera, "ground_valid", None)
    if not _is_ground_mask(ground):
        raise InvalidParameterError(
            f"camera: expected a calibrated camera with a bool (H, W) ground_valid mask (env.camera), "
            f"got {type(camera).__name__}; pass the environment's camera, or None for frames without one."
        )
    return ground.copy()


def _shape_dtype(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f" of shape {value.shape} and dtype {value.dtype}"
    return f" {value!r:.60}"


def _through_glare(
    image: np.ndarray, mask: np.ndarray, lobe: np.ndarray, memory: GlareMemory, ground: np.ndarray | None
) -> tuple[np.ndarray, GlareMemory]:
    """Not §III: the road through the glare lobe the light filter removed (``lobe``, bool
    (H, W)), and on the frames the memory covers after it; the mask and the next memory.

    Under a sun's lobe the colour classifier fails beside it (the exposure dropped; lit
    verges look like road): the road is what grows from the ego's road across smooth
    colour, and the lobe where road lies both sides. Region growth stays on the camera's
    ``ground``, else below the last lobe's top (:meth:`GlareMemory.growth_bound`).
    """
    if lobe.any():
        memory = memory.saw_lobe(lobe, keep_top=ground is not None)
        bound = memory.growth_bound(ground, mask.shape)
        lobe = lobe & bound
        grown = _grow(_as_uint8(image), mask | lobe, bound, GROW_TOLERANCE, 2)
        return (grown | _across_lobe(grown, lobe) if grown.any() else mask), memory
    memory = memory.next_frame()
    if memory.active and mask.any():  # the sun is still up
        grown = _grow(_as_uint8(image), mask, memory.growth_bound(ground, mask.shape), GROW_TOLERANCE, 2)
        if grown.any():
            return grown, memory
    return mask, memory


class _StepPredictor(Protocol):
    """What a :class:`DetectorEpisode` needs of its detector (:class:`~simroad.detector.RoadDetector`)."""

    def predict_step(
        self, image: np.ndarray, memory: GlareMemory, *, ground: np.ndarray | None = None, exact: bool = False
    ) -> tuple[np.ndarray, GlareMemory]: ...  # pragma: no cover - protocol


class DetectorEpisode:
    """One episode of a :class:`~simroad.detector.RoadDetector`: its frames, in order.

    Get one from :meth:`RoadDetector.episode <simroad.detector.RoadDetector.episode>`
    (the mask driver starts one at every episode). It is a detector of the protocol of
    :mod:`simroad.detector.registry` (``predict``, ``reset``, ``name``, ``version``)
    that remembers what the detector itself does not: the camera's ground mask and the
    :class:`GlareMemory`. The detector is used, never changed: several episodes of one
    detector may run side by side.

    Parameters
    ----------
    detector : RoadDetector
        Fitted or loaded.
    camera : PinholeCamera or None, optional
        The calibrated camera the frames come from (any object with a bool (H, W)
        ``ground_valid``; its mask is copied). With the ``"improved"`` variant and
        ``morphology`` on, pixels above its horizon are never road; frames of another
        size are read without it. None (default): frames or photographs without a
        camera.

    Attributes
    ----------
    detector : RoadDetector
    ground : ndarray, bool, (H, W), or None
        The camera's ``ground_valid``.
    memory : GlareMemory
        What the frames so far left for the next one.
    """

    def __init__(self, detector: _StepPredictor, camera: Any = None) -> None:
        if not callable(getattr(detector, "predict_step", None)):
            raise InvalidParameterError(
                f"detector: expected a RoadDetector (with predict_step), got {type(detector).__name__}; "
                "start the episode with detector.episode(camera)."
            )
        self.detector = detector
        self.ground = _camera_ground(camera)
        self.memory = GlareMemory()

    @property
    def name(self) -> str:
        """The detector's ``name`` (its class name if it has none), for the records."""
        return str(getattr(self.detector, "name", type(self.detector).__name__))

    @property
    def version(self) -> str:
        """The detector's ``version`` (``""`` if it has none), for the records."""
        return str(getattr(self.detector, "version", ""))

    def predict(self, image: np.ndarray, *, exact: bool = False) -> np.ndarray:
        """The road mask of the episode's next frame, and the memory it leaves.

        Parameters
        ----------
        image : ndarray, (H, W, 3), uint8 or float32/float64 in [0, 1]
            The next RGB frame of the episode.
        exact : bool, optional
            Evaluate the SVM at every pixel instead of the lookup table (see
            :meth:`RoadDetector.predict <simroad.detector.RoadDetector.predict>`).

        Returns
        -------
        ndarray, bool, (H, W)
            True on road.
        """
        mask, self.memory = self.detector.predict_step(image, self.memory, ground=self.ground, exact=exact)
        return mask

    def reset(self) -> DetectorEpisode:
        """Forget the frames so far (the camera stays): the next frame starts an episode."""
        self.memory = GlareMemory()
        return self

    def __repr__(self) -> str:
        camera = "none" if self.ground is None else f"ground {self.ground.shape}"
        return f"DetectorEpisode({self.detector!r}, camera={camera}, memory={self.memory})"
