"""Run a sweep's cells on Ray: one task per cell, retried when a node dies, rows returned to the driver.

The driver (the process that calls :func:`simroad.experiments.ablate.run_ablation`)
submits one task per cell and yields each record as it arrives; it alone writes
``results.jsonl``. A task only computes a record, so running it twice is harmless:
when a worker process or a whole node dies, Ray reruns the task elsewhere (up to
:data:`MAX_RETRIES` times, system failures only). An episode's own exception is not a
system failure: :func:`~simroad.experiments.ablate.run_cell` turns it into a record
with ``error`` set, as on the local backend. A cell that Ray still loses, a node
running another simroad version, or a cluster left without a CPU ends the sweep with
one :class:`~simroad.SimroadError` after every other cell has been collected; the rows
written are kept and the same command resumes the rest.

``ray_address`` is ``None`` (a private Ray on this machine with ``workers`` CPUs),
``"auto"`` (the cluster ``ray start`` runs on this machine) or ``HOST:PORT`` (the
head node's GCS, as ``ray start --head`` prints it). An address that does not answer
is refused within seconds, before any episode (Ray itself would wait for minutes).
A Ray the caller already initialised is used as it is (``ray_address`` is then not
consulted) and left running; only a Ray this module started is shut down.
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections.abc import Callable, Iterator
from typing import Any

import simroad
from simroad.errors import InvalidParameterError, MissingDependencyError, SimroadError
from simroad.experiments.episode import EpisodeSpec
from simroad.experiments.grid import cell_key

__all__ = ["CONNECT_TIMEOUT_S", "MAX_RETRIES", "NO_CPU_TIMEOUT_S", "check_ray_address", "run_on_ray"]

#: Reruns of a cell whose worker process or node died (Ray's ``max_retries``).
MAX_RETRIES = 3
#: Seconds to wait for the head node's port to accept a TCP connection.
CONNECT_TIMEOUT_S = 5.0
#: Seconds the cluster may have no CPU at all before the sweep gives up.
NO_CPU_TIMEOUT_S = 60.0
_POLL_S = 1.0
_FLAG = "ray_address (--ray-address)"
_HOW = (
    "Start a cluster with `ray start --head --port=6379` on the head machine and "
    "`ray start --address=HEAD:6379` on each other machine, then pass the address `ray start --head` "
    "printed (HOST:PORT); or leave --ray-address out to run Ray on this machine only."
)


def check_ray_address(address: Any) -> str | None:
    """Validate the form of a Ray address (not whether it answers).

    Parameters
    ----------
    address : str or None
        None, ``"auto"``, ``"local"``, ``HOST:PORT`` or ``ray://HOST:PORT``.

    Returns
    -------
    str or None
        The address without surrounding blanks.

    Raises
    ------
    SimroadError
        Not a string, empty, or no numeric port in 1-65535.
    """
    if address is None:
        return None
    if not isinstance(address, str) or not address.strip():
        raise InvalidParameterError(
            f"{_FLAG}: expected HOST:PORT (e.g. 10.0.0.5:6379) or 'auto', got {address!r}. {_HOW}"
        )
    address = address.strip()
    if address not in ("auto", "local"):
        _host_port(address)
    return address


def _host_port(address: str) -> tuple[str, int]:
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise InvalidParameterError(
            f"{_FLAG}: expected HOST:PORT with a port in 1-65535 (e.g. 10.0.0.5:6379) or 'auto', "
            f"got {address!r}. {_HOW}"
        )
    return host.strip("[]"), int(port)


def _check_reachable(address: str) -> None:
    """Refuse an address whose port does not accept a connection (Ray would retry for minutes)."""
    if address in ("auto", "local"):
        return
    try:
        socket.create_connection(_host_port(address), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise InvalidParameterError(f"{_FLAG}: no Ray cluster answers at {address!r} ({why}). {_HOW}") from None


def _connect(ray: Any, address: str | None, workers: int) -> bool:
    """``ray.init`` unless Ray is already initialised; return whether this call did it."""
    if ray.is_initialized():
        return False
    if address is None:
        # "local": a private instance even if a cluster runs on this machine (RAY_ADDRESS ignored).
        ray.init(address="local", num_cpus=workers, include_dashboard=False, log_to_driver=False)
        return True
    _check_reachable(address)
    auth_error = getattr(ray.exceptions, "AuthenticationError", ())
    try:
        ray.init(address=address, log_to_driver=False)
    except auth_error as exc:
        raise InvalidParameterError(
            f"{_FLAG}: the Ray cluster at {address!r} refused this driver's token ({exc.args[0] if exc.args else exc}). "
            "Give the driver the cluster's token: RAY_AUTH_MODE=token and RAY_AUTH_TOKEN (or ~/.ray/auth_token) "
            "as on the nodes; see https://docs.ray.io/en/latest/ray-security/token-auth.html"
        ) from None
    except (ConnectionError, ray.exceptions.RayError) as exc:
        raise InvalidParameterError(f"{_FLAG}: could not join the Ray cluster at {address!r} ({exc}). {_HOW}") from None
    return True


def _one_opencv_thread() -> None:
    import cv2

    cv2.setNumThreads(1)


def _ray_cell(cell_fn: Callable[[EpisodeSpec], dict], spec: EpisodeSpec, version: str) -> dict:
    """One Ray task: run one cell with one OpenCV thread, on the driver's simroad version only."""

    if simroad.__version__ != version:
        raise InvalidParameterError(
            f"this Ray node runs simroad {simroad.__version__}, the driver {version}: "
            f"install simroad {version} on every node of the cluster."
        )
    _one_opencv_thread()
    return cell_fn(spec)


def _capacity_lost(ray: Any, since: float | None) -> float | None:
    """Track how long the cluster has had no CPU; raise after :data:`NO_CPU_TIMEOUT_S`."""
    if ray.cluster_resources().get("CPU", 0) >= 1:
        return None
    now = time.monotonic()
    if since is not None and now - since > NO_CPU_TIMEOUT_S:
        raise InvalidParameterError(
            f"backend ray: the cluster has had no node with a CPU for {NO_CPU_TIMEOUT_S:g} s, so the remaining "
            "cells cannot run. The rows already written are kept; add nodes (ray start --address=HEAD:PORT) "
            "and run the same command again to resume."
        )
    return now if since is None else since


def _outcome(ray: Any, ref: Any, spec: EpisodeSpec) -> dict | str:
    """The cell's record, or why Ray could not produce it."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as exc:
        cause = getattr(exc, "cause", exc)
        if isinstance(cause, SimroadError):
            return f"{cell_key(spec)}: {cause}"
        return (
            f"{cell_key(spec)}: a Ray worker could not run it ({type(cause).__name__}: {cause}); "
            "every node needs simroad installed at the driver's version"
        )
    except ray.exceptions.RayError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return f"{cell_key(spec)}: lost after {MAX_RETRIES} retries ({type(exc).__name__}: {first})"


def run_on_ray(
    specs: list[EpisodeSpec],
    *,
    workers: int,
    address: str | None,
    cell_fn: Callable[[EpisodeSpec], dict],
) -> Iterator[dict]:
    """Run every cell as a Ray task; yield each record as it finishes (any order).

    Parameters
    ----------
    specs : list of EpisodeSpec
        The cells to run.
    workers : int
        CPUs of the private Ray started when ``address`` is None (ignored on a
        cluster: every CPU of the cluster is used).
    address : str or None
        See the module docstring.
    cell_fn : callable
        ``spec -> record``, a picklable top-level function.

    Yields
    ------
    dict
        One record per cell that finished.

    Raises
    ------
    SimroadError
        Ray missing, the address malformed or unreachable, or (after every other cell
        was yielded) cells Ray could not run.
    """
    address = check_ray_address(address)
    try:
        import ray
    except ImportError:
        raise MissingDependencyError(
            "backend: Ray is not installed; install the extra with pip install 'simroad[ray]'."
        ) from None

    started = _connect(ray, address, workers)
    remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_ray_cell)
    spec_of = {remote.remote(cell_fn, s, simroad.__version__): s for s in specs}
    pending = list(spec_of)
    failures: list[str] = []
    no_cpu_since: float | None = None
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1, timeout=_POLL_S)
            if not done:
                no_cpu_since = _capacity_lost(ray, no_cpu_since)
                continue
            no_cpu_since = None
            for ref in done:
                outcome = _outcome(ray, ref, spec_of[ref])
                if isinstance(outcome, str):
                    failures.append(outcome)
                else:
                    yield outcome
    finally:
        if started:
            ray.shutdown()
        else:
            for ref in pending:  # Ray stays up for the caller: stop what this sweep queued
                with contextlib.suppress(Exception):
                    ray.cancel(ref)
    if failures:
        raise InvalidParameterError(
            f"backend ray: {len(failures)} cell(s) did not run: " + "; ".join(failures[:3])
            + (" ..." if len(failures) > 3 else "")
            + ". The rows already written are kept; fix the cluster and run the same command again to resume."
        )  # fmt: skip
