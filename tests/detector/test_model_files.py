"""Model files prove they are whole.

Every damaged file -- truncated, bit-flipped, empty, wrong arrays, shapes, dtypes or
values, a pickle -- raises one SimroadError at ``load`` naming the file; none is ever
unpickled; none loads and predicts differently from what was saved. Damage that the
zip's CRC-32 and zlib cannot see (an archive rebuilt around a changed array) is caught
by the SHA-256 checksum; a file whose checksum was forged to match is still caught by
the format checks.
"""

from __future__ import annotations

import io
import json
import pickle
import struct
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from simroad.detector import RoadDetector, check_model_destination, default_model_path
from simroad.detector.persistence import FORMAT_VERSION, PARAM_NAMES, array_checksum, read_arrays
from simroad.errors import SimroadError

IMG = np.random.default_rng(5).integers(0, 256, (40, 48, 3), dtype=np.uint8)
ERROR = r"^path: '.*' is not a simroad road-detector model, or a damaged one: "


@pytest.fixture(scope="module")
def shipped() -> RoadDetector:
    return RoadDetector.load(default_model_path())


@pytest.fixture(scope="module")
def model_bytes(shipped, tmp_path_factory) -> bytes:
    path = tmp_path_factory.mktemp("model") / "m.npz"
    shipped.save(path)
    return path.read_bytes()


@pytest.fixture(scope="module")
def model_arrays(model_bytes, tmp_path_factory) -> dict[str, np.ndarray]:
    path = tmp_path_factory.mktemp("arrays") / "m.npz"
    path.write_bytes(model_bytes)
    return read_arrays(path)


def assert_same_model(loaded: RoadDetector, ref: RoadDetector) -> None:
    """Same parameters, same fitted arrays, same predictions (table and exact SVM)."""
    assert loaded.get_params() == ref.get_params()
    for a, b in [
        (loaded.feature_mean_, ref.feature_mean_), (loaded.feature_scale_, ref.feature_scale_),
        (loaded.svm_.support_vectors, ref.svm_.support_vectors), (loaded.svm_.dual_coef, ref.svm_.dual_coef),
        (loaded.lut_.coarse, ref.lut_.coarse), (loaded.lut_.refined_cells, ref.lut_.refined_cells),
        (loaded.lut_.fine, ref.lut_.fine),
    ]:  # fmt: skip
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert (loaded.svm_.intercept, loaded.svm_.gamma) == (ref.svm_.intercept, ref.svm_.gamma)
    np.testing.assert_array_equal(loaded.predict(IMG), ref.predict(IMG))
    np.testing.assert_array_equal(loaded.predict(IMG[:12, :12], exact=True), ref.predict(IMG[:12, :12], exact=True))


def write_arrays(path: Path, arrays: dict[str, np.ndarray], *, reseal: bool) -> Path:
    """Write an npz of ``arrays``; ``reseal`` recomputes the checksum (a forged, well-formed file)."""
    arrays = dict(arrays)
    if reseal and "checksum" in arrays:
        arrays["checksum"] = np.array(array_checksum(arrays))
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return path


def with_meta(arrays: dict[str, np.ndarray], edit: Callable[[dict], None]) -> dict[str, np.ndarray]:
    meta = json.loads(str(arrays["meta"]))
    edit(meta)
    return {**arrays, "meta": np.array(json.dumps(meta))}


def member_data_ranges(blob: bytes) -> dict[str, tuple[int, int]]:
    """Byte range of each member's compressed data inside the zip."""
    out = {}
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        for info in zf.infolist():
            n, m = struct.unpack("<HH", blob[info.header_offset + 26 : info.header_offset + 30])
            start = info.header_offset + 30 + n + m
            out[info.filename[:-4]] = (start, start + info.compress_size)
    return out


def flip(blob: bytes, offset: int, bit: int = 0) -> bytes:
    b = bytearray(blob)
    b[offset] ^= 1 << bit
    return bytes(b)


def load_fails(path: Path, match: str = "") -> SimroadError:
    with pytest.raises(SimroadError, match=ERROR + ".*" + match) as info:
        RoadDetector.load(path)
    assert str(path) in str(info.value)
    return info.value


# ---------------------------------------------------------------- whole files
def test_the_shipped_model_is_format_3_with_a_valid_checksum():
    arrays = read_arrays(default_model_path())
    meta = json.loads(str(arrays["meta"]))
    assert meta["version"] == FORMAT_VERSION == 3
    assert meta["params"]["normalize"] == "road_ahead"
    assert str(arrays["checksum"]) == array_checksum(arrays)


def _without_normalize(meta: dict, version: int) -> None:
    meta["params"].pop("normalize")
    meta["version"] = version


def test_version_2_files_load_with_absolute_colours(model_arrays, tmp_path):
    """Files written before ``normalize`` existed classified absolute colours."""
    v2 = with_meta(dict(model_arrays), lambda m: _without_normalize(m, 2))
    det = RoadDetector.load(write_arrays(tmp_path / "v2.npz", v2, reseal=True))
    assert det.normalize == "none"


def test_version_3_files_must_say_how_colours_are_normalised(model_arrays, tmp_path):
    v3 = with_meta(dict(model_arrays), lambda m: _without_normalize(m, 3))
    load_fails(write_arrays(tmp_path / "v3.npz", v3, reseal=True), "missing \\['normalize'\\]")


def test_a_saved_model_loads_and_predicts_exactly_as_saved(shipped, model_bytes, tmp_path):
    path = tmp_path / "m.npz"
    path.write_bytes(model_bytes)
    assert_same_model(RoadDetector.load(path), shipped)


def test_param_names_are_the_estimators():
    assert set(RoadDetector().get_params()) == PARAM_NAMES


def test_version_1_files_still_load(shipped, model_arrays, tmp_path):
    v1 = with_meta({k: v for k, v in model_arrays.items() if k != "checksum"}, lambda m: m.update(version=1))
    assert_same_model(RoadDetector.load(write_arrays(tmp_path / "v1.npz", v1, reseal=False)), shipped)


def test_version_1_files_get_every_check_but_the_checksum(model_arrays, tmp_path):
    v1 = with_meta({k: v for k, v in model_arrays.items() if k != "checksum"}, lambda m: m.update(version=1))
    v1["lut"] = v1["lut"][:3]  # the issue's case: one lookup table cut to 3 bytes
    load_fails(write_arrays(tmp_path / "v1.npz", v1, reseal=False), "array 'lut' is uint8 \\(3,\\)")


@pytest.mark.parametrize("cut", [1, 8, 30, 100, 0.5, -22, -1])
def test_truncated_files_are_refused(model_bytes, tmp_path, cut):
    n = int(len(model_bytes) * cut) if isinstance(cut, float) else cut % len(model_bytes)
    path = tmp_path / "cut.npz"
    path.write_bytes(model_bytes[:n])
    load_fails(path)


def test_an_empty_file_is_refused(tmp_path):
    (tmp_path / "e.npz").write_bytes(b"")
    load_fails(tmp_path / "e.npz", r"the file is empty \(0 bytes\)")


# ---------------------------------------------------------------- bit flips
def load_fails_or_is_exact(path: Path, ref: RoadDetector) -> bool:
    """One clear error (True), or a model exactly equal to ``ref`` (False)."""
    try:
        loaded = RoadDetector.load(path)
    except SimroadError as exc:
        assert str(exc).startswith("path: ") and str(path) in str(exc)
        return True
    assert_same_model(loaded, ref)
    return False


@pytest.mark.parametrize(
    ("offset", "bit", "must_fail"),
    [(0, 0, True), (2, 3, True), (8, 1, False), (14, 7, False), (18, 2, False), (26, 0, True), (30, 2, True)],
)
def test_bit_flips_in_the_zip_header_are_refused_or_harmless(shipped, model_bytes, tmp_path, offset, bit, must_fail):
    """Magic, compression method, CRC-32, size, name length, name of the first member's local header.

    zipfile reads the method, CRC and sizes from the central directory, so flips in the
    local copies change nothing; flips in the magic or the name are refused.
    """
    path = tmp_path / "f.npz"
    path.write_bytes(flip(model_bytes, offset, bit))
    refused = load_fails_or_is_exact(path, shipped)
    assert refused or not must_fail


MEMBERS = ["support_vectors", "dual_coef", "intercept", "gamma", "feature_mean", "feature_scale", "meta",
           "lut", "lut_bits", "lut_refined_cells", "lut_fine", "checksum"]  # fmt: skip


@pytest.mark.parametrize("where", ["start", "middle", "last"])
@pytest.mark.parametrize("member", MEMBERS)
def test_bit_flips_inside_each_arrays_data_are_refused(shipped, model_bytes, tmp_path, member, where):
    """Inside the compressed data of every array: refused (zlib, CRC-32 or checksum).

    The last byte may hold only the deflate stream's padding bits after its end
    marker; a flip there changes no array, and the model must then load exactly.
    """
    start, end = member_data_ranges(model_bytes)[member]
    offset = {"start": start, "middle": (start + end) // 2, "last": end - 1}[where]
    path = tmp_path / "f.npz"
    path.write_bytes(flip(model_bytes, offset, 4))
    if where == "last":
        load_fails_or_is_exact(path, shipped)
    else:
        load_fails(path)


def test_a_bit_flip_anywhere_is_refused_or_harmless(shipped, model_bytes, tmp_path):
    """Every 53rd byte: either one clear error, or (zip timestamps, padding) the exact model."""
    path = tmp_path / "f.npz"
    harmless = 0
    for offset in range(0, len(model_bytes), 53):
        path.write_bytes(flip(model_bytes, offset, offset % 8))
        harmless += not load_fails_or_is_exact(path, shipped)
    assert harmless < len(model_bytes) // 53 // 10  # almost every byte matters


@pytest.mark.parametrize("member", MEMBERS[:-1])
def test_changed_arrays_that_zip_cannot_see_fail_the_checksum(model_arrays, tmp_path, member):
    """The archive is rebuilt around one flipped bit, so its CRC-32 and zlib stream are valid."""
    arrays = dict(model_arrays)
    raw = bytearray(np.ascontiguousarray(arrays[member]).tobytes())
    if member == "meta":  # change one digit of the JSON text: still valid JSON, another number
        at = next(i for i in range(len(raw) // 2, len(raw)) if chr(raw[i]).isdigit())
        raw[at] = ord("7") if raw[at] != ord("7") else ord("3")
    else:
        raw[len(raw) // 2] ^= 0x01
    arrays[member] = np.frombuffer(bytes(raw), dtype=arrays[member].dtype).reshape(arrays[member].shape)
    load_fails(write_arrays(tmp_path / "f.npz", arrays, reseal=False), "checksum mismatch")


def test_an_edited_parameter_fails_the_checksum(model_arrays, tmp_path):
    arrays = with_meta(model_arrays, lambda m: m["params"].update(morphology=False))
    load_fails(write_arrays(tmp_path / "f.npz", arrays, reseal=False), "checksum mismatch")


# ------------------------------------------- forged files: the format checks
def _drop(name):
    return lambda a: {k: v for k, v in a.items() if k != name}


def _set(name, value):
    return lambda a: {**a, name: value}


def _params(**kw):
    return lambda a: with_meta(a, lambda m: m["params"].update(kw))


FORGED = {
    # wrong keys
    "missing-lut_fine": (_drop("lut_fine"), r"missing \['lut_fine'\]"),
    "missing-feature_mean": (_drop("feature_mean"), r"missing \['feature_mean'\]"),
    "missing-meta": (_drop("meta"), "missing array 'meta'"),
    "missing-checksum": (_drop("checksum"), r"missing \['checksum'\]"),
    "extra-array": (_set("extra", np.zeros(3)), r"unexpected \['extra'\]"),
    # wrong shapes
    "shape-lut-3-bytes": (lambda a: {**a, "lut": a["lut"][:3]}, r"array 'lut' is uint8 \(3,\)"),
    "shape-lut_fine": (lambda a: {**a, "lut_fine": a["lut_fine"][:-1]}, "array 'lut_fine'"),
    "shape-feature_mean": (_set("feature_mean", np.zeros(4)), r"array 'feature_mean' is float64 \(4,\)"),
    "shape-support_vectors": (lambda a: {**a, "support_vectors": a["support_vectors"][:, :2]}, "support_vectors"),
    "shape-dual_coef": (lambda a: {**a, "dual_coef": a["dual_coef"][:-1]}, "array 'dual_coef'"),
    "shape-no-support-vectors": (
        lambda a: {**a, "support_vectors": a["support_vectors"][:0], "dual_coef": a["dual_coef"][:0]},
        "support_vectors",
    ),
    "shape-gamma": (_set("gamma", np.ones(2)), "array 'gamma'"),
    "refined-cells-reordered": (
        lambda a: {**a, "lut_refined_cells": a["lut_refined_cells"][::-1].copy()},
        "boundary cells",
    ),
    "coarse-table-changed": (
        lambda a: {**a, "lut": np.bitwise_xor(a["lut"], np.uint8(1) * (np.arange(a["lut"].size) == 100))},
        "boundary cells",
    ),
    # wrong dtypes
    "dtype-feature_mean": (lambda a: {**a, "feature_mean": a["feature_mean"].astype(np.float32)}, "float32"),
    "dtype-lut": (lambda a: {**a, "lut": a["lut"].astype(np.int64)}, "array 'lut' is int64"),
    "dtype-lut_bits": (_set("lut_bits", np.float64(6)), "array 'lut_bits' is float64"),
    "dtype-refined-cells": (lambda a: {**a, "lut_refined_cells": a["lut_refined_cells"].astype(np.int64)}, "int64"),
    "dtype-meta-bytes": (lambda a: {**a, "meta": np.array(str(a["meta"]).encode())}, "array 'meta' is"),
    "dtype-support-vectors-int": (lambda a: {**a, "support_vectors": a["support_vectors"].astype(np.int64)}, "int64"),
    # NaN and out-of-range values
    "nan-gamma": (_set("gamma", np.float64("nan")), "array 'gamma' holds NaN"),
    "inf-intercept": (_set("intercept", np.float64("inf")), "array 'intercept' holds NaN or infinite"),
    "zero-gamma": (_set("gamma", np.float64(0.0)), "array 'gamma' must be > 0"),
    "zero-feature_scale": (_set("feature_scale", np.zeros(3)), "array 'feature_scale' must be > 0"),
    "nan-support-vector": (
        lambda a: {**a, "support_vectors": np.where(np.arange(3) == 1, np.nan, a["support_vectors"])},
        "holds NaN",
    ),
    "lut_bits-out-of-range": (_set("lut_bits", np.int64(9)), "array 'lut_bits' is 9"),
    "param-C-nan": (_params(C=float("nan")), "stored C: expected a finite number"),
    "param-nonroad_weight": (_params(nonroad_weight=-1.0), "stored nonroad_weight"),
    "param-lut_bits-mismatch": (_params(lut_bits=5), "parameter lut_bits is 5"),
    "param-filters": (_params(filters=["fog"]), "stored filters"),
    "param-morphology-string": (_params(morphology="no"), "stored morphology"),
    "param-random_state": (_params(random_state=-1), "stored random_state"),
    "param-unknown": (_params(colour="red"), r"stored params: .*unknown \['colour'\]"),
    "param-gamma": (_params(gamma="auto"), "stored gamma"),
    "meta-version-4": (lambda a: with_meta(a, lambda m: m.update(version=4)), "format version 4"),
    "meta-version-text": (lambda a: with_meta(a, lambda m: m.update(version="2")), "format version '2'"),
    "meta-format": (lambda a: with_meta(a, lambda m: m.update(format="other")), "format 'other'"),
    "meta-not-json": (_set("meta", np.array("{not json")), "Expecting property name"),
    "meta-n_support": (lambda a: with_meta(a, lambda m: m.update(n_support=3)), "meta says 3"),
}


@pytest.mark.parametrize("case", sorted(FORGED))
def test_forged_files_with_a_matching_checksum_fail_the_format_checks(model_arrays, tmp_path, case):
    edit, match = FORGED[case]
    load_fails(write_arrays(tmp_path / "f.npz", edit(dict(model_arrays)), reseal=True), match)


# ---------------------------------------------------------------- pickles
class _Trap:
    """Unpickling this writes a marker file: proof that code ran."""

    marker: Path

    def __reduce__(self):
        return (Path.write_text, (self.marker, "unpickled!"))


@pytest.fixture
def trap(tmp_path):
    t = _Trap()
    t.marker = tmp_path / "marker"
    return t


def test_a_pickle_file_is_refused_and_never_unpickled(trap, tmp_path):
    (tmp_path / "p.npz").write_bytes(pickle.dumps({"meta": trap}))
    load_fails(tmp_path / "p.npz", "it is a Python pickle, which simroad never loads")
    assert not trap.marker.exists()


def test_an_object_array_is_refused_and_never_unpickled(model_arrays, trap, tmp_path):
    arrays = {**model_arrays, "meta": np.array([trap], dtype=object)}
    with open(tmp_path / "o.npz", "wb") as fh:
        np.savez(fh, **arrays)
    load_fails(tmp_path / "o.npz", r"array 'meta' holds Python objects \(a pickle\)")
    assert not trap.marker.exists()


def test_an_npy_file_or_text_is_refused(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros(3))
    load_fails(tmp_path / "a.npy", "a single .npy array")
    (tmp_path / "t.npz").write_text("hello")
    load_fails(tmp_path / "t.npz", "not an .npz")


def test_a_zip_of_other_files_is_refused(tmp_path):
    with zipfile.ZipFile(tmp_path / "z.npz", "w") as zf:
        zf.writestr("readme.txt", "hi")
    load_fails(tmp_path / "z.npz", "unexpected archive member 'readme.txt'")


def test_npy_data_shorter_than_its_header_is_refused(model_arrays, tmp_path):
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.zeros(100))
    with zipfile.ZipFile(tmp_path / "s.npz", "w") as zf:
        zf.writestr("support_vectors.npy", buf.getvalue()[:-8])
    load_fails(tmp_path / "s.npz", "holds 792 bytes of data but its header declares")


@pytest.mark.parametrize(
    ("path", "match"),
    [(5, "^path: expected a model file path"), ("", "^path: expected a model file path"),
     ("/no/such/model.npz", "^path: no model file at")],
)  # fmt: skip
def test_load_names_bad_paths(path, match):
    with pytest.raises(SimroadError, match=match):
        RoadDetector.load(path)


def test_load_refuses_a_directory(tmp_path):
    with pytest.raises(SimroadError, match="is not a file"):
        RoadDetector.load(tmp_path)


# ---------------------------------------------------------------- saving
def test_save_refuses_a_missing_folder_before_writing(shipped, tmp_path):
    with pytest.raises(SimroadError, match=r"^path: the folder '.*missing' does not exist"):
        shipped.save(tmp_path / "missing" / "m.npz")
    assert not (tmp_path / "missing").exists()


def test_save_refuses_a_path_below_a_regular_file(shipped, tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(SimroadError, match="is a file, not a folder"):
        shipped.save(tmp_path / "file" / "sub" / "m.npz")
    with pytest.raises(SimroadError, match="is a file, not a folder"):
        shipped.save(tmp_path / "file" / "m.npz")


def test_save_refuses_a_directory_and_non_paths(shipped, tmp_path):
    with pytest.raises(SimroadError, match="is a directory"):
        shipped.save(tmp_path)
    with pytest.raises(SimroadError, match=r"^path: expected a file path"):
        shipped.save(3.5)


def test_save_refuses_invalid_parameters_before_writing(shipped, tmp_path):
    det = RoadDetector.load(default_model_path()).set_params(nonroad_weight=float("nan"))
    with pytest.raises(SimroadError, match=r"^nonroad_weight: expected a finite number"):
        det.save(tmp_path / "m.npz")
    assert list(tmp_path.iterdir()) == []


def test_save_leaves_no_temporary_file_and_replaces_atomically(shipped, tmp_path):
    path = tmp_path / "m.npz"
    path.write_text("old")
    shipped.save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]
    assert_same_model(RoadDetector.load(path), shipped)


def test_check_model_destination(tmp_path):
    assert check_model_destination(tmp_path / "m.npz") == tmp_path / "m.npz"
    with pytest.raises(SimroadError, match=r"^out: the folder"):
        check_model_destination(tmp_path / "a" / "b" / "m.npz", name="out")
    assert check_model_destination(tmp_path / "a" / "b" / "m.npz", make_parents=True).parent.is_dir()
    (tmp_path / "f").write_text("x")
    with pytest.raises(SimroadError, match=r"^out: cannot write .* is a file, not a folder"):
        check_model_destination(tmp_path / "f" / "m.npz", name="out", make_parents=True)
    assert (tmp_path / "f").is_file()
