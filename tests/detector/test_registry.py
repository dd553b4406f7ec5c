"""Finding a detector by name, entry point, module or file; options; the filters in front."""

from __future__ import annotations

import importlib.metadata
import textwrap

import numpy as np
import pytest

from simroad.detector import registry
from simroad.detector.registry import (
    FilteredDetector,
    available_detectors,
    check_prediction,
    clear_detector_cache,
    describe,
    load_detector,
    parse_detector_options,
    register,
    resolve_factory,
)
from simroad.errors import SimroadError
from simroad.filters import apply_filters


class Half:
    """The lower half of the frame is road (a constant detector for the tests)."""

    name = "half"
    version = "1"

    def __init__(self, fraction: float = 0.5) -> None:
        self.fraction = fraction
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def predict(self, image: np.ndarray) -> np.ndarray:
        mask = np.zeros(image.shape[:2], bool)
        mask[int(image.shape[0] * (1 - self.fraction)) :] = True
        return mask


@pytest.fixture(autouse=True)
def _fresh_cache():
    clear_detector_cache()
    yield
    clear_detector_cache()
    registry._REGISTRY.pop("half_registered", None)


def test_paper_is_built_in_and_describes_itself():
    det = load_detector("paper")
    assert describe(det)["name"] == "paper" and describe(det)["version"].startswith("simroad ")
    assert load_detector("paper") is det  # built once per process
    assert load_detector("paper", filters=("shadow",)) is not det
    assert available_detectors()["paper"] == "built in"


def test_module_spec_with_options_and_the_cache():
    det = load_detector(f"{__name__}:Half", {"fraction": 0.25})
    assert isinstance(det, Half) and det.fraction == 0.25
    assert load_detector(f"{__name__}:Half", {"fraction": 0.25}) is det
    assert load_detector(f"{__name__}:Half", {"fraction": 0.75}) is not det


def test_file_spec(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(
        textwrap.dedent(
            """
            import numpy as np
            def make(threshold=0.5):
                class Bright:
                    def predict(self, image):
                        return image.mean(axis=2) > 255 * threshold
                return Bright()
            """
        )
    )
    det = load_detector(f"{path}:make", {"threshold": 0.2})
    img = np.zeros((16, 16, 3), np.uint8)
    img[8:] = 200
    assert det.predict(img)[8:].all() and not det.predict(img)[:8].any()
    assert describe(det)["name"] == f"{path}:make"  # named by its spec when it has no name


def test_register_and_entry_points(monkeypatch):
    register("half_registered", Half)
    assert isinstance(load_detector("half_registered"), Half)
    ep = importlib.metadata.EntryPoint("half_ep", f"{__name__}:Half", registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "_entry_points", lambda: {"half_ep": ep})
    assert isinstance(load_detector("half_ep", {"fraction": 0.1}), Half)
    assert available_detectors()["half_ep"] == f"entry point {__name__}:Half"


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("nosuch", "unknown detector 'nosuch'"),
        ("", "expected a detector spec"),
        ("no_such_module_x:Thing", "cannot import 'no_such_module_x'"),
        (f"{__name__}:Nope", "has no attribute 'Nope'"),
        ("/no/such/file.py:make", "no file"),
        (f"{__name__}:np", "not a class or factory"),
        (":Thing", "names no importable module before ':'"),  # was importlib's ValueError
        (".relative:Thing", "names no importable module before ':'"),  # was importlib's TypeError
        ("json:loads", "missing a required argument: 's'"),  # checked before it is called
    ],
)
def test_bad_specs_are_refused_by_name(spec, message):
    with pytest.raises(SimroadError, match="detector") as err:
        load_detector(spec)
    assert message in str(err.value)
    if spec in ("nosuch", ""):  # says what would work
        assert "paper" in str(err.value) and "path/to/file.py:attr" in str(err.value)


def test_bad_options_name_the_signature():
    with pytest.raises(SimroadError, match=r"did not accept \['width'\].*Half\(fraction"):
        load_detector(f"{__name__}:Half", {"width": 3})
    with pytest.raises(SimroadError, match="--detector-option: expected key=value"):
        parse_detector_options(["fraction"])


def test_options_from_the_command_line_are_python_literals():
    opts = parse_detector_options(["a=3", "b=0.5", "c=True", "d=hello", "e=[1, 2]"])
    assert opts == {"a": 3, "b": 0.5, "c": True, "d": "hello", "e": [1, 2]}


def test_filters_run_in_front_of_any_detector():
    class Echo:
        def predict(self, image):
            self.seen = image
            return np.ones(image.shape[:2], bool)

    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    echo = Echo()
    wrapped = FilteredDetector(echo, ("shadow", "rain_snow"))
    wrapped.predict(img)
    assert np.array_equal(echo.seen, apply_filters(img, ("shadow", "rain_snow")))
    assert describe(wrapped)["name"] == "Echo"
    half = load_detector(f"{__name__}:Half", filters=("light",))
    assert isinstance(half, FilteredDetector) and describe(half) == {"name": "half", "version": "1"}
    episode = half.episode()
    assert isinstance(episode, FilteredDetector) and describe(episode) == {"name": "half", "version": "1"}
    assert half.detector.resets == 1  # the wrapped detector's episode starts with its reset()
    assert np.array_equal(episode.predict(img), half.predict(img))


def test_check_mask_refuses_what_is_not_a_mask():
    det = Half()
    assert check_prediction(np.ones((4, 5), np.uint8), (4, 5), det).dtype == bool
    with pytest.raises(SimroadError, match=r"'half'.*shape \(5, 4\)"):
        check_prediction(np.ones((5, 4), bool), (4, 5), det)
    with pytest.raises(SimroadError, match="float64, expected a bool mask"):
        check_prediction(np.ones((4, 5)), (4, 5), det)


def test_resolve_factory_finds_the_class():
    assert resolve_factory(f"{__name__}:Half") is Half


class _Broken:
    def __init__(self, fraction: float = 0.5):
        raise RuntimeError(f"no model for {fraction}")


def test_a_detector_whose_constructor_raises_is_refused_by_name():
    with pytest.raises(SimroadError, match=r"^detector: building '.*:_Broken' .*RuntimeError: no model for 0.2") as err:
        load_detector(f"{__name__}:_Broken", {"fraction": 0.2})
    assert isinstance(err.value.__cause__, RuntimeError)  # the user's traceback stays reachable
