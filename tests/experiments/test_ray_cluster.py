"""The Ray backend on a real two-node cluster on this machine: a node killed mid-sweep
costs nothing; a bad or silent ``--ray-address`` is refused in seconds, before any episode.

The cluster is what ``ray start`` builds for users: a head node and a second node that
joins it, each its own raylet with one CPU, in a private ``--temp-dir`` and with a token
made for the test (so nothing else on the machine can join it or find it). Each node is
``ray start --block`` in a session of its own, so "kill the node" is SIGKILL to every
process of that session, and cleanup can prove that no process of either node survives.
"""

from __future__ import annotations

import importlib.util
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

import pytest

from simroad.cli.main import main
from simroad.errors import SimroadError
from simroad.experiments.ablate import run_ablation
from simroad.experiments.grid import AblationGrid, cell_key

sys.path.insert(0, str(Path(__file__).parent))
from stub_cell import FAILING_DRIVER, FAILING_SEED, stub_cell

needs_ray = pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="Ray not installed")

ROOT = Path(__file__).resolve().parents[2]
RAY = Path(sys.executable).with_name("ray") if Path(sys.executable).with_name("ray").exists() else shutil.which("ray")
#: 8 cells (oracle and detector, racetrack and winding, clear and rain), about 1 s each.
GRID = AblationGrid(
    scenarios=("racetrack", "winding"),
    noises=("clear", "rain"),
    severities=(0.6,),
    filters=("none",),
    seeds=1,
    steps=15,
)
GRID_FLAGS = ["--scenarios", "racetrack,winding", "--noises", "clear,rain", "--severities", "0.6", "--filters", "none",
              "--seeds", "1", "--steps", "15"]  # fmt: skip
TIMING = {"detect_ms_median", "step_ms_median", "wall_s"}


def _metrics(records):
    return {cell_key(r): {k: v for k, v in r.items() if k not in TIMING} for r in records}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _session(sid: int) -> list[int]:
    """PIDs whose session id is ``sid`` (the processes of one node)."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            state, _ppid, _pgrp, session = stat.rsplit(")", 1)[1].split()[:4]
            if int(session) == sid and state != "Z":  # a zombie is dead, only not yet reaped
                pids.append(int(entry))
    return pids


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


class _Node:
    """One Ray node: ``ray start --block`` in its own session, with free ports."""

    def __init__(self, env: dict[str, str], log: Path, *args: str) -> None:
        ports = {f"--{name}-port": str(_free_port()) for name in
                 ("node-manager", "object-manager", "metrics-export", "dashboard-agent-listen", "dashboard-agent-grpc",
                  "runtime-env-agent")}  # fmt: skip
        cmd = [str(RAY), "start", "--block", "--num-cpus", "1", "--node-ip-address", "127.0.0.1",
               "--disable-usage-stats", *(x for kv in ports.items() for x in kv), *args]  # fmt: skip
        self.log = log
        self.proc = subprocess.Popen(
            cmd, env=env, start_new_session=True, stdout=log.open("w"), stderr=subprocess.STDOUT
        )

    def wait_started(self, timeout_s: float = 60.0) -> None:
        deadline = time.monotonic() + timeout_s
        while "Ray runtime started" not in self.log.read_text():
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"ray start failed:\n{self.log.read_text()[-3000:]}")
            time.sleep(0.2)

    def pids(self) -> list[int]:
        return _session(self.proc.pid)

    def kill(self) -> None:
        """SIGKILL every process of the node at once, as a machine that loses power."""
        for pid in self.pids():
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.proc.wait(timeout=10)
        deadline = time.monotonic() + 5
        while self.pids() and time.monotonic() < deadline:
            time.sleep(0.05)

    def stop(self) -> None:
        """SIGTERM, then SIGKILL what is left after 10 s."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                pass
        deadline = time.monotonic() + 5
        while self.pids() and time.monotonic() < deadline:
            for pid in self.pids():
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            time.sleep(0.2)
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture(scope="module")
def local_records(tmp_path_factory):
    return run_ablation(GRID, tmp_path_factory.mktemp("local"), workers=1, progress=False)


@pytest.mark.slow
@needs_ray
@pytest.mark.skipif(RAY is None, reason="the ray command line is not installed")
def test_node_killed_mid_sweep_every_cell_once_and_metrics_equal_local(local_records, tmp_path):
    temp = Path(tempfile.mkdtemp(prefix="srray-", dir="/tmp"))  # short: Ray's socket paths must fit 107 bytes
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32),
           "RAY_USAGE_STATS_ENABLED": "0"}  # fmt: skip
    env.pop("RAY_ADDRESS", None)
    port = _free_port()
    nodes: list[_Node] = []
    driver = None
    try:
        head = _Node(env, temp / "head.log", "--head", "--port", str(port), "--temp-dir", str(temp),
                     "--include-dashboard", "false", "--dashboard-port", str(_free_port()))  # fmt: skip
        nodes.append(head)
        head.wait_started()
        worker = _Node(env, temp / "worker.log", "--address", f"127.0.0.1:{port}")
        nodes.append(worker)
        worker.wait_started()

        out = tmp_path / "sweep"
        cmd = [sys.executable, "-m", "simroad", "ablate", *GRID_FLAGS, "--backend", "ray",
               "--ray-address", f"127.0.0.1:{port}", "--out", str(out), "--quiet"]  # fmt: skip
        driver = subprocess.Popen(cmd, env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

        # Kill the worker node once a row is written and it is running a cell (a worker process of
        # that node titled with the task's name): the cell in flight dies with it.
        results = out / "results.jsonl"
        deadline = time.monotonic() + 120
        while True:
            rows = len(results.read_text().splitlines()) if results.exists() else 0
            busy = any(_cmdline(pid).startswith("ray::_ray_cell") for pid in worker.pids())
            if rows >= 1 and busy:
                break
            assert driver.poll() is None, f"the sweep ended before the node could be killed: {driver.communicate()}"
            assert time.monotonic() < deadline, "no row and no cell on the worker node within 120 s"
            time.sleep(0.05)
        worker.kill()
        assert rows < len(GRID.specs()) and not worker.pids()

        stdout, stderr = driver.communicate(timeout=180)
        assert driver.returncode == 0, stderr[-3000:]
        assert "Traceback" not in stderr and f"{len(GRID.specs())} episodes" in stdout and "(0 failed)" in stdout

        lines = results.read_text().splitlines()
        records = [json.loads(line) for line in lines]
        keys = [cell_key(r) for r in records]
        assert len(keys) == len(set(keys)) == len(GRID.specs())  # every cell exactly once
        assert set(keys) == {cell_key(s) for s in GRID.specs()}
        assert not any(r["error"] for r in records)
        assert _metrics(records) == _metrics(local_records)
        # The cell in flight on the killed node was rerun by Ray (the driver's core-worker log says so).
        driver_log = "".join(
            p.read_text(errors="replace") for p in temp.glob("session_*/logs/python-core-driver-*.log")
        )
        assert ("NODE_DIED" in driver_log or "WORKER_DIED" in driver_log) and "resubmit task" in driver_log.lower()
    finally:
        if driver is not None and driver.poll() is None:
            driver.kill()
            driver.wait()
        for node in reversed(nodes):
            node.stop()
        left = [(pid, _cmdline(pid)) for node in nodes for pid in node.pids()]
        left += [(pid, _cmdline(pid)) for pid in map(int, _pgrep(str(temp)))]
        shutil.rmtree(temp, ignore_errors=True)
        assert not left, f"Ray processes left behind: {left}"


def _pgrep(pattern: str) -> list[str]:
    """PIDs whose command line contains ``pattern`` (only this cluster's temp dir is ever passed)."""
    found = subprocess.run(["pgrep", "-f", pattern], capture_output=True, text=True)
    return [p for p in found.stdout.split() if int(p) != os.getpid()]


@needs_ray
def test_unreachable_address_is_refused_in_seconds_naming_the_flag(tmp_path):
    address = f"127.0.0.1:{_free_port()}"  # nothing listens there
    start = time.monotonic()
    with pytest.raises(SimroadError, match=r"--ray-address.*no Ray cluster answers.*ray start --head") as err:
        run_ablation(GRID, tmp_path / "a", backend="ray", ray_address=address, progress=False)
    assert address in str(err.value) and time.monotonic() - start < 15
    assert not (tmp_path / "a" / "results.jsonl").exists()


@needs_ray
@pytest.mark.parametrize("address", ["", "  ", "localhost", "10.0.0.5:", "host:port", "host:0", "host:70000", ":6379"])
def test_malformed_address_is_refused_by_the_cli(address, tmp_path, capsys):
    code = main(["ablate", "--scenarios", "highway", "--noises", "clear", "--seeds", "1", "--steps", "2",
                 "--backend", "ray", "--ray-address", address, "--out", str(tmp_path / "m"), "--quiet"])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert "--ray-address" in err and "HOST:PORT" in err and "Traceback" not in err


def _raising_cell(counter: Path, spec):
    """A cell function that raises past :func:`run_cell` for the detector cells (counting every call)."""
    with counter.open("a") as fh:
        fh.write(cell_key(spec) + "\n")
    if spec.driver == "detector":
        raise RuntimeError("escaped the cell")
    return stub_cell(spec)


@pytest.fixture
def callers_ray():
    """A Ray the caller started: the sweep must use it and leave it running."""
    import ray
    from ray import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers need not import this file
    cloudpickle.register_pickle_by_value(sys.modules["stub_cell"])
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


@pytest.mark.slow
@needs_ray
def test_an_episode_error_is_a_row_and_a_lost_cell_is_never_retried(callers_ray, tmp_path):
    grid = AblationGrid(scenarios=("racetrack",), noises=("clear",), filters=("none",), seeds=2, seed_start=12)
    records = run_ablation(grid, tmp_path / "rows", backend="ray", cell_fn=stub_cell, progress=False)
    assert sorted(cell_key(r) for r in records) == sorted(cell_key(s) for s in grid.specs())
    failed = [r for r in records if r["error"]]
    assert [(r["seed"], r["driver"]) for r in failed] == [(FAILING_SEED, FAILING_DRIVER)]
    assert failed[0]["error"].startswith("RuntimeError: boom")
    assert callers_ray.is_initialized()  # not ours to shut down

    counter = tmp_path / "calls.txt"
    with pytest.raises(
        SimroadError, match=r"2 cell\(s\) did not run: racetrack\|clear\|0\|none\|detector\|paper\|1[23].*resume"
    ):
        run_ablation(grid, tmp_path / "lost", backend="ray", cell_fn=partial(_raising_cell, counter), progress=False)
    calls = counter.read_text().splitlines()
    assert sorted(calls) == sorted(cell_key(s) for s in grid.specs())  # once each: an exception is not retried
    rows = [json.loads(line) for line in (tmp_path / "lost" / "results.jsonl").read_text().splitlines()]
    assert sorted(r["driver"] for r in rows) == ["oracle", "oracle"]  # the cells that ran are kept
    assert callers_ray.is_initialized()


@pytest.mark.slow
@needs_ray
def test_a_cluster_without_cpu_ends_the_sweep_instead_of_hanging(monkeypatch, tmp_path):
    import ray

    from simroad.experiments import _ray_backend

    monkeypatch.setattr(_ray_backend, "NO_CPU_TIMEOUT_S", 2.0)
    grid = AblationGrid(scenarios=("racetrack",), noises=("clear",), filters=("none",), seeds=1, oracle=False)
    ray.init(address="local", num_cpus=0, include_dashboard=False, log_to_driver=False)
    try:
        start = time.monotonic()
        with pytest.raises(SimroadError, match=r"no node with a CPU for 2 s.*resume"):
            run_ablation(grid, tmp_path, backend="ray", cell_fn=stub_cell, progress=False)
        assert time.monotonic() - start < 30
    finally:
        ray.shutdown()


def test_a_node_with_another_simroad_version_refuses_the_cell():
    from simroad.experiments._ray_backend import _ray_cell

    def never(spec):
        raise AssertionError("must not run")

    with pytest.raises(SimroadError, match=r"install simroad 0\.0\.0 on every node"):
        _ray_cell(never, GRID.specs()[0], "0.0.0")


def test_address_forms():
    from simroad.experiments._ray_backend import check_ray_address

    assert check_ray_address(None) is None
    assert check_ray_address(" 10.0.0.5:6379 ") == "10.0.0.5:6379"
    assert check_ray_address("auto") == "auto"
    assert check_ray_address("ray://head:10001") == "ray://head:10001"
    assert check_ray_address("[::1]:6379") == "[::1]:6379"
    with pytest.raises(SimroadError, match="ray_address"):
        check_ray_address(6379)
