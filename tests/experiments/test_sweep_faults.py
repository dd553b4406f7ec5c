"""Faults that could lose or mix a sweep's rows: two sweeps on one directory, Ctrl-C twice."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from simroad import SimroadError
from simroad.errors import OutputInUseError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid, cell_key
from simroad.experiments.outlock import LOCK_NAME, OutputLock
from simroad.experiments.results import read_results

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
import stub_cell as stub  # noqa: E402
from stub_cell import stub_cell  # noqa: E402

GRID_A = AblationGrid(scenarios=("racetrack",), noises=("clear", "rain"), filters=("none",), seeds=3, steps=5)
GRID_B = AblationGrid(scenarios=("racetrack",), noises=("clear", "rain"), filters=("none",), seeds=3, steps=5,
                      seed_start=100)  # fmt: skip


def _dead_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


# --- the lock ------------------------------------------------------------------------------------


def test_a_second_lock_is_refused_naming_the_holder_and_the_way_out(tmp_path):
    with OutputLock(tmp_path):
        holder = json.loads((tmp_path / LOCK_NAME).read_text())
        assert holder["pid"] == os.getpid() and holder["host"] == socket.gethostname() and holder["started"]
        with pytest.raises(OutputInUseError) as err:
            OutputLock(tmp_path).acquire()
        msg = str(err.value)
        assert f"PID {os.getpid()}" in msg and f"kill -INT {os.getpid()}" in msg and LOCK_NAME in msg
        assert "another --out" in msg and isinstance(err.value, SimroadError)
    assert not (tmp_path / LOCK_NAME).exists()
    with OutputLock(tmp_path):  # free again
        pass


def test_a_stale_lock_of_a_dead_process_is_taken_over_with_a_message(tmp_path):
    dead = _dead_pid()
    info = {"pid": dead, "host": socket.gethostname(), "started": "yesterday", "token": "x"}
    (tmp_path / LOCK_NAME).write_text(json.dumps(info))
    said: list[str] = []
    with OutputLock(tmp_path, log=said.append):
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    assert len(said) == 1 and f"from PID {dead}" in said[0] and "no longer runs" in said[0]


def test_a_lock_held_from_another_host_is_never_taken_over(tmp_path):
    info = {"pid": _dead_pid(), "host": "another-machine", "started": "now", "token": "x"}
    (tmp_path / LOCK_NAME).write_text(json.dumps(info))
    with pytest.raises(OutputInUseError, match="on host another-machine"):
        OutputLock(tmp_path).acquire()
    assert json.loads((tmp_path / LOCK_NAME).read_text()) == info


def test_the_lock_is_taken_before_grid_json_is_read_and_released_after_a_failure(tmp_path):
    (tmp_path / "grid.json").write_text("not json")
    with OutputLock(tmp_path):
        with pytest.raises(OutputInUseError):  # not the damaged grid.json: the lock comes first
            run_ablation(GRID_A, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    assert (tmp_path / "grid.json").read_text() == "not json"
    with pytest.raises(SimroadError, match=r"grid\.json' is damaged"):
        run_ablation(GRID_A, tmp_path, workers=1, progress=False, cell_fn=stub_cell)
    assert not (tmp_path / LOCK_NAME).exists()


@pytest.mark.slow
def test_cli_ablate_on_a_locked_directory_exits_2_naming_the_holder(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(HERE)]))
    cmd = [sys.executable, str(HERE / "stub_cli.py"), "ablate", "--scenarios", "racetrack", "--noises", "clear", "--filters",
           "none", "--seeds", "2", "--steps", "5", "--workers", "1", "--out", str(tmp_path), "--quiet"]  # fmt: skip
    with OutputLock(tmp_path):
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert f"is in use by another sweep (PID {os.getpid()}" in proc.stderr
    assert not (tmp_path / "grid.json").exists() and not (tmp_path / "results.jsonl").exists()


# --- two sweeps at once --------------------------------------------------------------------------

# A fork server, not fork: this pytest worker may hold threads (a Ray driver, OpenCV)
# whose locks a forked child would inherit taken; the server is a clean process. There
# is one fork server per process, and a preload counts only if it is set before the
# server starts: the sweep pool starts it too once this worker has run Ray
# (simroad.experiments.pool), so it is set here, at collection, before any test runs.
# Without it every contender imports simroad itself (seconds each, 24 per test).
multiprocessing.set_forkserver_preload(["stub_cell", "simroad.experiments.ablate"])


def _race(out: Path, grids: tuple[AblationGrid, AblationGrid]) -> list[tuple[int, str, str]]:
    ctx = multiprocessing.get_context("forkserver")
    start = ctx.Barrier(2)
    procs = []
    for grid in grids:
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=stub.contender, args=(str(out), grid, start, child))
        proc.start()
        procs.append((proc, parent))
    outcomes = []
    for proc, conn in procs:
        assert conn.poll(60), "a contender hung"
        outcomes.append((proc.pid, *conn.recv()))
        proc.join(10)
    return outcomes


@pytest.mark.slow
@pytest.mark.parametrize("same_grid", [True, False], ids=["same-grid", "different-grids"])
def test_two_concurrent_sweeps_on_one_directory_never_duplicate_lose_or_mix_rows(tmp_path, same_grid):
    grids = (GRID_A, GRID_A) if same_grid else (GRID_A, GRID_B)
    locked = 0
    for trial in range(12):
        out = tmp_path / f"t{trial}"
        outcomes = _race(out, grids)
        assert not [o for o in outcomes if o[1] == "crash"], outcomes
        kinds = sorted(kind for _, kind, _ in outcomes)
        # the documented behaviour: one runs; the other is refused while the first holds the
        # lock, or (if it came after) finds the cells done (same grid) or another grid there
        assert kinds in (["done", "locked"], ["done", "done" if same_grid else "refused"]), outcomes
        for pid, kind, msg in outcomes:
            if kind == "locked":
                other = next(p for p, k, _ in outcomes if p != pid)
                assert f"PID {other} " in msg and "is in use by another sweep" in msg
                locked += 1
            if kind == "refused":
                assert "holds results of a different grid" in msg
        meta = json.loads((out / "grid.json").read_text())
        winner = next(g for g in grids if g.fingerprint() == meta["fingerprint"])
        rows, bad = read_results(out / "results.jsonl")
        assert bad == [] and len((out / "results.jsonl").read_text().splitlines()) == len(rows)
        assert sorted(cell_key(r) for r in rows) == sorted(cell_key(s) for s in winner.specs())
        assert not (out / LOCK_NAME).exists()
    assert locked >= 6  # the trials did overlap


# --- Ctrl-C twice --------------------------------------------------------------------------------


def _tree(pid: int) -> list[int]:
    """``pid`` and all its descendants (from /proc)."""
    kids = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            kids += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return [pid] + [p for kid in kids for p in _tree(kid)]


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


# (second-interrupt delay in s or None for one Ctrl-C only, SIGINT to the whole process
# group as a terminal sends it or to the parent only); each trial takes ~5 s: the command
# starts (~2.5 s of imports) and its two workers, 2 of 20 cells of 0.3 s are written, the
# interrupt, and the resume in this process.
_TRIALS = [pytest.param(0.2, True, id="twice-0.2s-group")] + [
    pytest.param(d, g, id=f"{f'twice-{d}s' if d else 'once'}-{'group' if g else 'parent'}")
    for d, g in ((0.05, False), (0.1, True), (0.15, False), (0.3, True), (0.4, False), (0.5, True), (None, False))
]


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs /proc to find the worker processes")
@pytest.mark.parametrize("second, group", _TRIALS)
def test_ctrl_c_twice_ends_the_whole_process_tree_within_3_s_and_rows_stay_valid(tmp_path, second, group):
    out = tmp_path / "sweep"
    grid = AblationGrid(scenarios=("racetrack",), noises=("clear",), filters=("none",), seeds=10, steps=5)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(HERE)]), SIMROAD_STUB_DELAY_S="0.3")
    cmd = [sys.executable, str(HERE / "stub_cli.py"), "ablate", "--scenarios", "racetrack", "--noises", "clear", "--filters",
           "none", "--seeds", "10", "--steps", "5", "--workers", "2", "--out", str(out), "--quiet"]  # fmt: skip
    err = tmp_path / "stderr.txt"
    with open(err, "w") as fh:
        proc = subprocess.Popen(cmd, env=env, stderr=fh, start_new_session=True)
    path = out / "results.jsonl"
    try:
        deadline = time.monotonic() + 60
        while not (path.exists() and path.read_bytes().count(b"\n") >= 2):
            assert time.monotonic() < deadline and proc.poll() is None, err.read_text()
            time.sleep(0.02)
        tree = _tree(proc.pid)
        assert len(tree) >= 3  # the parent and its two workers
        interrupt = (lambda: os.killpg(proc.pid, signal.SIGINT)) if group else (lambda: proc.send_signal(signal.SIGINT))
        interrupt()
        if second is not None:
            time.sleep(second)
            interrupt()
        t0 = time.monotonic()
        while any(_running(p) for p in tree) and time.monotonic() - t0 < 3.0:
            time.sleep(0.02)
        alive = [p for p in tree if _running(p)]
        assert alive == [], f"still running 3 s after the last Ctrl-C: {alive}"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == 130 and "Traceback" not in err.read_text(), err.read_text()
    assert not (out / LOCK_NAME).exists()
    rows, bad = read_results(path)
    assert all(b.torn and b.number == len(rows) + 1 for b in bad) and len(bad) <= 1
    assert 2 <= len(rows) < 20
    # the resume completes the grid: exactly one row per cell (in this process: the
    # interrupted sweep's pool is what the trial tests)
    records = run_ablation(grid, out, workers=1, progress=False, cell_fn=stub_cell)
    rows, bad = read_results(path)
    assert bad == [] and len(path.read_text().splitlines()) == 20 == len(rows) == len(records)
    assert sorted(cell_key(r) for r in rows) == sorted(cell_key(s) for s in grid.specs())


# --- the worker pool -----------------------------------------------------------------------------


def _square_or_die(x: int) -> dict:
    if x == 3:
        os._exit(7)  # a worker killed mid-cell (e.g. by the OOM killer)
    if x == 4:
        raise ValueError("bad cell 4")
    return {"x": x * x}


def test_pool_yields_every_result_and_reports_a_dead_worker_or_a_raised_error():
    from simroad.experiments.pool import run_in_workers

    assert sorted(r["x"] for r in run_in_workers([0, 1, 2, 5, 6], 2, _square_or_die)) == [0, 1, 4, 25, 36]
    assert list(run_in_workers([], 2, _square_or_die)) == []
    with pytest.raises(RuntimeError, match="worker died \\(exit code 7\\) while running 3"):
        list(run_in_workers([0, 3, 1], 2, _square_or_die))
    with pytest.raises(ValueError, match="bad cell 4"):
        list(run_in_workers([4, 0], 2, _square_or_die))
