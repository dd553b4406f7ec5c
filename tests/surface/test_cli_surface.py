"""Every flag of every ``simroad`` subcommand, fed wrong types, out-of-range values,
malformed files and flags that do not apply: each must exit with status 2, name the
flag (or config key), print no traceback, and start no episode, frame, sweep or
training (the ``no_work`` guard turns any of those into a failure).

Cases are generated from the parser itself: each option's ``type=`` function is traced
back to the :mod:`simroad.cli.types` factory (or library check) that made it, and
:data:`BAD_INPUTS` lists the values that factory's types refuse, so a new flag with a
known type is covered automatically; a flag without cases there or in ``EXTRA`` fails
:func:`test_every_flag_has_cases`. The ablate grid file's cases are
generated from :class:`AblationGrid`'s fields and the run keys.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
from collections.abc import Callable

import cv2
import numpy as np
import pytest

from simroad.cli.main import main
from simroad.cli.parser import build_parser
from simroad.experiments.grid import RUN_KEY_TYPES, AblationGrid


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(action.choices)


SUBCOMMANDS = _subcommands()

#: A valid command line per subcommand: positionals, then required options.
BASE: dict[str, tuple[list[str], dict[str, str]]] = {
    "frames": ([], {"--out": "{ok}/frames"}),
    "episode": ([], {}),
    "ablate": ([], {"--out": "{ok}/sweep"}),
    "report": (["{dir}"], {}),
    "train-detector": ([], {"--out": "{ok}/model.npz"}),
    "evaluate-detector": ([], {}),
    "filter-effect": ([], {}),
    "figure": (["camera"], {"--out": "{ok}/figure.png"}),
    "videos": ([], {"--out": "{ok}/videos"}),
    "realism": ([], {"--out": "{ok}/realism"}),
    "calibrate": ([], {"--photos": "{dir}", "--masks": "{dir}", "--out": "{ok}/camera.toml"}),
}

#: Values refused by the argparse types of each :mod:`simroad.cli.types` factory (or each
#: library check wrapped by ``checked``), from the factory's arguments: (why, value).
#: ``{file}``, ``{dir}``, ``{missing}`` stand for a regular file, a directory and a path
#: that does not exist.
BAD_INPUTS: dict[str, Callable[..., list[tuple[str, str]]]] = {
    "int_in": lambda low, high, **_: [
        ("wrong type", "abc"), ("not an integer", "1.5"),
        ("below the range", str(low - 1)), ("above the range", str(high + 1)),
    ],
    "finite_float": lambda **_: [("wrong type", "abc"), ("not finite", "inf"), ("not a number", "nan")],
    "float_in": lambda low, high, **_: [
        ("wrong type", "abc"), ("not finite", "nan"),
        ("below the range", str(low - 1)), ("above the range", str(high + 1)),
    ],
    "float_list": lambda low, high, **_: [
        ("wrong type", "abc"), ("one item not a number", f"{low:g},x"), ("empty", ","),
        ("empty item", f"{low:g},,{high:g}"), ("repeated", f"{high:g},{high:g}"),
        ("above the range", str(high + 1)), ("not finite", "nan"),
    ],
    "choice": lambda **_: [("unknown name", "bogus"), ("wrong type", "5"), ("empty", "")],
    "choice_list": lambda valid, **_: [
        ("unknown name", "bogus"), ("one unknown name", f"{valid[0]},bogus"), ("empty", ","), ("wrong type", "5"),
        ("empty item", f"{valid[0]},,{valid[-1]}"), ("repeated", f"{valid[0]},{valid[0]}"),
    ],
    "weather": lambda **_: [("unknown name", "rian"), ("repeated", "rain+rain"), ("empty", "")],
    "weather_list": lambda **_: [
        ("unknown name", "clear,rian"), ("empty", ","), ("empty item", "rain,,snow"), ("repeated", "rain,rain"),
    ],
    "filter_set": lambda **_: [("unknown name", "bogus"), ("wrong type", "5")],
    "filter_set_list": lambda **_: [
        ("unknown name", "none,bogus"), ("empty", ","), ("empty item", "none,"), ("repeated", "none,none"),
    ],
    "text": lambda **_: [("empty", ""), ("blank", "  ")],
    "output_dir": lambda **_: [("below a regular file", "{file}/sub"), ("a regular file", "{file}")],
    "output_file": lambda suffixes, **_: [
        ("below a regular file", "{file}/sub/out.png"), ("a directory", "{dir}"),
        *([] if suffixes is None else [("unsupported file type", "{dir}/out.xyz")]),
    ],
    "input_dir": lambda **_: [("missing", "{missing}"), ("a regular file", "{file}")],
    "input_file": lambda **_: [("missing", "{missing}"), ("a directory", "{dir}")],
    "detector_spec": lambda **_: [("unknown name", "bogus"), ("empty", ""), ("no such file", "/no/x.py:D")],
    "detector_specs": lambda **_: [("unknown name", "paper,bogus"), ("empty", ","), ("repeated", "paper,paper")],
    "detector_option": lambda **_: [("no value", "fraction"), ("no key", "=3"), ("bad key", "a b=3")],
    # library checks the parser wraps with ``checked``
    "_mu": lambda **_: [("wrong type", "abc"), ("zero", "0"), ("above the range", "2"), ("not finite", "nan")],
    "_wiper_period": lambda **_: [
        ("unknown name", "sometimes"), ("shorter than a cycle", "0.5"), ("negative", "-1"), ("not finite", "nan"),
    ],
    "check_ray_address": lambda **_: [("empty", ""), ("no port", "localhost"), ("port", "host:0")],
    "_profile": lambda **_: [
        ("missing", "{missing}"), ("a directory", "{dir}"), ("not TOML", "{file}"),
        ("unknown key", "{bad_profile}"), ("out of range", "{wide_profile}"),
    ],
}  # fmt: skip


def _bad_inputs(type_fn: Callable[[str], object]) -> list[tuple[str, str]]:
    """:data:`BAD_INPUTS` of the factory that made ``type_fn`` (its ``<locals>`` prefix),
    called with the factory's arguments as the closure holds them; a type made by
    ``checked`` is traced to the check it wraps."""
    factory = type_fn.__qualname__.split(".<locals>")[0]
    args = inspect.getclosurevars(type_fn).nonlocals
    if factory == "checked":
        return _bad_inputs(args["check"])
    return BAD_INPUTS[factory](**args) if factory in BAD_INPUTS else []


#: Cases for flags whose type has no :data:`BAD_INPUTS` (or that need more): (why, value).
EXTRA: dict[tuple[str, str], list[tuple[str, str]]] = {
    ("frames", "scenario"): [("unknown name", "higway"), ("wrong type", "5")],
    ("episode", "scenario"): [("unknown name", "higway"), ("wrong type", "5")],
    ("frames", "width"): [("above the camera's range", "5000")],
    ("frames", "height"): [("below the camera's range", "8")],
    ("episode", "width"): [("below the camera's range", "8")],
    ("episode", "height"): [("above the camera's range", "5000")],
    ("frames", "hfov"): [("out of range", "500")],
    ("episode", "hfov"): [("out of range", "-10")],
    ("frames", "pitch"): [("out of range", "400")],
    ("episode", "pitch"): [("out of range", "-400")],
    ("episode", "require"): [("malformed", "fnr<<1"), ("unknown key", "bogus<=1"), ("not a number", "fnr<=1.2.3")],
    ("train-detector", "out"): [("below a regular file", "{file}/model.npz"), ("a directory", "{dir}")],
    ("ablate", "config"): [("malformed TOML", "{bad_toml}"), ("not text", "{binary}")],
    ("evaluate-detector", "model"): [("text file", "{file}")],
    ("realism", "reference"): [("not a quantile table", "{file}")],
    ("realism", "photos"): [("no photo with a mask", "{dir}")],
    ("videos", "compare"): [("unknown filter", "bogus"), ("a list", "none,all")],
    **{
        (cmd, "road_colour"): [("not a colour", "red"), ("out of range", "300,0,0"), ("two channels", "255,0")]
        for cmd in ("evaluate-detector", "realism", "calibrate")
    },
}

#: Damaged model files (refused by name at load: a checksummed, validated format).
EXTRA_MODEL_FILES: dict[tuple[str, str], list[tuple[str, str]]] = {
    ("evaluate-detector", "model"): [("garbage npz", "{garbage}"), ("empty file", "{empty}")],
}


def _flag(action: argparse.Action) -> str:
    longs = [o for o in action.option_strings if o.startswith("--")]
    return longs[0] if longs else action.dest


def _argv(cmd: str, action: argparse.Action, value: str | None) -> list[str]:
    positionals, options = BASE[cmd]
    positionals, options = list(positionals), dict(options)
    sub = SUBCOMMANDS[cmd]
    extra: list[str] = []
    if not action.option_strings:  # a positional: replace it
        pos_actions = [a for a in sub._actions if not a.option_strings]
        positionals[pos_actions.index(action)] = value or ""
    elif value is None:  # a store_true flag given a value
        extra = [f"{_flag(action)}=yes"]
    else:
        options.pop(_flag(action), None)
        extra = [_flag(action), value]
    out = list(positionals)
    for k, v in options.items():
        out += [k, v]
    return [cmd, *out, *extra]


def _flag_cases() -> list:
    cases = []
    for cmd, sub in SUBCOMMANDS.items():
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            names = (_flag(action), action.dest)
            if isinstance(action, argparse._StoreTrueAction):
                cases.append(pytest.param(_argv(cmd, action, None), names, id=f"{cmd} {_flag(action)}: given a value"))
            for why, value in _bad_inputs(action.type) if action.type is not None else ():
                cases.append(pytest.param(_argv(cmd, action, value), names, id=f"{cmd} {_flag(action)}: {why}"))
            if action.choices is not None and action.type is None:
                for why, value in (("unknown choice", "bogus"), ("empty", "")):
                    cases.append(pytest.param(_argv(cmd, action, value), names, id=f"{cmd} {_flag(action)}: {why}"))
            for why, value in EXTRA.get((cmd, action.dest), ()):
                cases.append(pytest.param(_argv(cmd, action, value), names, id=f"{cmd} {_flag(action)}: {why}"))
            for why, value in EXTRA_MODEL_FILES.get((cmd, action.dest), ()):
                cases.append(pytest.param(_argv(cmd, action, value), names, id=f"{cmd} {_flag(action)}: {why}"))
    return cases


FLAG_CASES = _flag_cases()


def _run(argv: list[str], capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # only --help exits this way
        code = exc.code
    return code, capsys.readouterr().err


def _assert_refused(code, err: str, names) -> None:
    assert code == 2, f"exit status {code}, stderr: {err}"
    assert "Traceback" not in err
    spelled = {n for name in names for n in (name, name.lstrip("-"), name.replace("_", "-"), name.replace("-", "_"))}
    assert any(n in err for n in spelled), f"the message names none of {sorted(spelled)}: {err}"


@pytest.fixture
def files(paths, write):
    paths = dict(paths)
    paths["bad_toml"] = write("bad.toml", "scenarios = [[[ not toml")
    paths["binary"] = write("binary.toml", b"\xff\xfe\x00\x00garbage")
    paths["bad_profile"] = write("bad_profile.toml", "[camera_profile]\ntone_gama = 1.3\n")
    paths["wide_profile"] = write("wide_profile.toml", "[camera_profile]\nasphalt_scale = 9.0\n")
    return paths


@pytest.mark.parametrize(("argv", "names"), FLAG_CASES)
def test_every_flag_refuses_bad_values(argv, names, files, no_work, capsys):
    argv = [a.format(**files) if "{" in a else a for a in argv]
    code, err = _run(argv, capsys)
    _assert_refused(code, err, names)


def test_every_flag_has_cases():
    """A new flag needs a type with :data:`BAD_INPUTS` or an EXTRA entry (two cases at
    least: a wrong type and an out-of-range value; one for a plain on/off flag)."""
    counts: dict[tuple[str, str], int] = {}
    for case in FLAG_CASES:
        argv = case.values[0]
        cmd = argv[0]
        key = case.id.split(":")[0].split(" ", 1)[1]
        counts[(cmd, key)] = counts.get((cmd, key), 0) + 1
    missing = []
    for cmd, sub in SUBCOMMANDS.items():
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            need = 1 if isinstance(action, argparse._StoreTrueAction) else 2
            if counts.get((cmd, _flag(action)), 0) < need:
                missing.append(f"{cmd} {_flag(action)}")
    assert not missing, f"flags without enough surface cases: {missing}"


# -- flags that do not apply in the chosen mode, and combined values -------------------

MODE_CASES = [
    *(
        pytest.param(["evaluate-detector", "--images", "{dir}", "--masks", "{dir}", flag, value], (flag,),
                     id=f"evaluate-detector --images with {flag}")
        for flag, value in (("--scenario", "racetrack"), ("--seeds", "1"), ("--seed-start", "100"), ("--frames", "2"))
    ),
    # --noise puts the weather on the photos; without it a severity has nothing to scale.
    pytest.param(["evaluate-detector", "--images", "{dir}", "--masks", "{dir}", "--severity", "0.5"], ("--severity",),
                 id="evaluate-detector --images with --severity and no --noise"),
    *(
        pytest.param(["evaluate-detector", flag, value], (flag,), id=f"evaluate-detector {flag} without --images")
        for flag, value in (("--hfov", "90"), ("--pitch", "3"), ("--mount-height", "1.5"), ("--weather-seed", "3"),
                            ("--plot", "{ok}/p.png"))
    ),
    pytest.param(["evaluate-detector", "--noise", "rain,snow"], ("--noise",),
                 id="evaluate-detector a list of weathers without --images"),
    pytest.param(["evaluate-detector", "--masks", "{dir}"], ("--images",), id="evaluate-detector --masks alone"),
    pytest.param(["evaluate-detector", "--images", "{dir}"], ("--masks",), id="evaluate-detector --images alone"),
    pytest.param(["episode", "--driver", "oracle", "--filters", "all"], ("--filters",), id="episode oracle with --filters"),
    pytest.param(["ablate", "--out", "{ok}/s", "--ray-address", "auto"], ("--ray-address",),
                 id="ablate --ray-address without --backend ray"),
    pytest.param(["ablate", "--out", "{ok}/s", "--backend", "ray", "--ray-address", "auto", "--workers", "2"],
                 ("--workers",), id="ablate --workers with --ray-address"),
    pytest.param(["figure", "weather", "--out", "{ok}/w.pdf"], ("--out",), id="figure weather as pdf"),
    pytest.param(["evaluate-detector", "--seed-start", "2147483647", "--seeds", "3"], ("--seed-start",),
                 id="evaluate-detector seeds past the largest"),
    pytest.param(["train-detector", "--out", "{ok}/m.npz", "--seed-start", "2147483646", "--seeds", "5"],
                 ("--seed-start",), id="train-detector seeds past the largest"),
    pytest.param(["filter-effect", "--seed-start", "2147483647", "--seeds", "2"], ("--seed-start",),
                 id="filter-effect seeds past the largest"),
    pytest.param(["ablate", "--out", "{ok}/s", "--seed-start", "2147483647", "--seeds", "2"], ("seed_start",),
                 id="ablate seeds past the largest"),
    pytest.param(["ablate"], ("--out",), id="ablate without --out"),
    pytest.param(["realism", "--photos", "{dir}"], ("--masks",), id="realism --photos alone"),
    pytest.param(["realism", "--masks", "{dir}"], ("--photos",), id="realism --masks alone"),
    pytest.param(["realism", "--photos", "{dir}", "--masks", "{dir}", "--reference", "{file}"], ("--reference",),
                 id="realism --reference with --photos"),
    pytest.param(["realism", "--photos", "{images}", "--masks", "{images}"], ("photos",),
                 id="realism unreadable photos"),
    pytest.param(["evaluate-detector", "--images", "{images}", "--masks", "{images}"], ("images",),
                 id="evaluate-detector unreadable images"),
    pytest.param(["calibrate", "--photos", "{images}", "--masks", "{images}", "--out", "{ok}/c.toml"], ("photos",),
                 id="calibrate unreadable photos"),
    pytest.param(["calibrate", "--photos", "{dir}", "--masks", "{dir}", "--out", "{ok}/c.toml"], ("photos",),
                 id="calibrate no photos"),
    pytest.param(["figure", "friction", "--out", "{ok}/f.png", "--camera-profile", "{profile}"], ("--camera-profile",),
                 id="figure friction with --camera-profile"),
    pytest.param(["evaluate-detector", "--images", "{dir}", "--masks", "{dir}", "--camera-profile", "{profile}"],
                 ("--camera-profile",), id="evaluate-detector --images with --camera-profile"),
]  # fmt: skip


@pytest.fixture
def image_folder(tmp_path):
    d = tmp_path / "images"
    d.mkdir()
    (d / "frame_0000.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage, not an image")
    cv2.imwrite(str(d / "road_0000.png"), np.full((8, 8), 255, np.uint8))  # its mask: the image is what fails
    return str(d)


@pytest.mark.parametrize(("argv", "names"), MODE_CASES)
def test_flags_that_do_not_apply_are_refused(argv, names, files, image_folder, write, no_work, capsys):
    files = {**files, "images": image_folder, "profile": write("camera.toml", "tone_gamma = 1.3\n")}
    argv = [a.format(**files) if "{" in a else a for a in argv]
    code, err = _run(argv, capsys)
    _assert_refused(code, err, names)


# -- the sweep's TOML file: every grid field and run key, wrong type and out of range ---

_TOML_BAD = {
    "tuple[str, ...]": [("wrong type", "5"), ("unknown name", '["bogus"]')],
    "dict": [("wrong type", "5"), ("not a grid detector", "{{ bogus = {{ a = 1 }} }}")],  # braces: str.format
    "tuple[float, ...]": [("not a number", '[0.5, "x"]'), ("out of range", "[2.0]")],
    "int": [("wrong type", '"3"'), ("out of range", "-1")],
    "bool": [("string boolean", '"no"'), ("integer", "3")],
    "CameraProfile | None": [
        ("wrong type", "5"),
        ("unknown key", "{{ tone_gama = 1.3 }}"),
        ("out of range", "{{ asphalt_scale = 9.0 }}"),
        ("missing file", '"nowhere.toml"'),
    ],
}
_RUN_BAD = {
    "workers": [("wrong type", '"2"'), ("out of range", "0")],
    "backend": [("wrong type", "5"), ("unknown name", '"bogus"')],
    "ray_address": [("wrong type", "5"), ("empty", '""')],
    "out": [("wrong type", "5"), ("empty", '""')],
}


def _toml_cases() -> list:
    cases = []
    for f in dataclasses.fields(AblationGrid):
        for why, value in _TOML_BAD.get(str(f.type), ()):
            cases.append(pytest.param(f"{f.name} = {value}\nout = '{{ok}}/s'\n", f.name, id=f"{f.name}: {why}"))
    for key, bad in _RUN_BAD.items():
        for why, value in bad:
            text = f"{key} = {value}\n" + ("" if key == "out" else "out = '{ok}/s'\n")
            cases.append(pytest.param(text, key, id=f"{key}: {why}"))
    cases.append(pytest.param("seed-strat = 3\nout = '{ok}/s'\n", "seed-strat", id="unknown key"))
    cases.append(pytest.param("severities = 0.5, 0.7\n", "config", id="not TOML"))
    return cases


TOML_CASES = _toml_cases()


@pytest.mark.parametrize(("text", "key"), TOML_CASES)
def test_grid_file_refuses_bad_values(text, key, files, write, no_work, capsys):
    path = write("grid.toml", text.format(**files))
    code, err = _run(["ablate", "--config", path], capsys)
    _assert_refused(code, err, (key,))


def test_every_grid_field_and_run_key_has_toml_cases():
    keys = {c.values[1] for c in TOML_CASES}
    missing = [f.name for f in dataclasses.fields(AblationGrid) if f.name not in keys]
    missing += [k for k in RUN_KEY_TYPES if k not in keys]
    assert not missing, f"grid-file keys without cases (add their type to _TOML_BAD or _RUN_BAD): {missing}"


def test_help_still_exits_zero():
    with pytest.raises(SystemExit) as exit_:
        main(["frames", "--help"])
    assert exit_.value.code == 0
