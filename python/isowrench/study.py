"""isowrench.study: uncertainty studies, sweeps and many fits as tasks, on a Dask cluster or on
local threads.

    import isowrench, isowrench.study as study
    m = isowrench.load("urdf/rat_hindlimb_5dof.urdf")
    r = study.uncertainty(m, "GP", inputs=["angle:hip_rz=normal:2", "max_force=normal:0.2"],
                          samples=100_000)                      # local threads, no Dask needed
    from dask.distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
        r2 = study.uncertainty(m, "GP", inputs=[...], samples=100_000, client=client)
    assert r2 == r | {"seconds": r2["seconds"]}                 # the same numbers, bit for bit
    # (and equal to m.uncertainty(...) bit for bit unless the model has rotated frames: see
    # uncertainty()'s docstring)

How the same bits come out however the work is spread (docs/uncertainty.md): every random
number is a function of (seed, sample, design matrix, dimension) only, the samples are cut into
fixed blocks of 2048, a task runs a range of blocks and returns its per-block partial sums as
bytes, and the partial sums are added in block order when the tasks are merged. Tasks are pure
functions of their arguments, so a task lost with a dying worker is simply run again elsewhere
(Dask reschedules it; `retries` covers exceptions too) and the result does not change.

Each task carries the model as URDF text and the spec as JSON (the fit's covariance inside), so
workers need no access to the user's files. Without a client the tasks run on local threads
(the C++ code releases the GIL); `client` may be a dask.distributed.Client or a scheduler
address, connected with `connect_timeout` seconds (an unreachable scheduler raises
ConnectionError after that time, it does not hang).

Progress: `progress=True` prints "task i/n" lines on stderr as tasks finish; a callable gets
(done, total).
"""

from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Callable, Iterable, List, Optional, Sequence, Union

import numpy as np

from . import _core

__all__ = ["uncertainty", "sweep", "fit_sessions", "connect", "DEFAULT_CONNECT_TIMEOUT"]

#: Seconds to wait for a scheduler given by address before raising ConnectionError.
DEFAULT_CONNECT_TIMEOUT = 10.0

Progress = Union[bool, Callable[[int, int], None], None]


def connect(client, connect_timeout: float = DEFAULT_CONNECT_TIMEOUT):
    """The dask.distributed.Client for `client`: a Client is returned as it is; an address
    ("tcp://host:8786") is connected to within `connect_timeout` seconds, else ConnectionError
    naming the address. None stays None (local threads)."""
    if client is None or not isinstance(client, str):
        return client
    from dask.distributed import Client  # only when a cluster is asked for

    try:
        return Client(client, timeout=connect_timeout)
    except (OSError, TimeoutError) as e:
        raise ConnectionError(
            f"isowrench.study: cannot reach the Dask scheduler at {client} within "
            f"{connect_timeout:g} s ({type(e).__name__}: {e})"
        ) from None


def _reporter(progress: Progress, label: str):
    if callable(progress):
        return progress
    if progress:
        def report(done: int, total: int) -> None:
            print(f"isowrench.study {label}: task {done}/{total}", file=sys.stderr, flush=True)
        return report
    return lambda done, total: None


def _run_tasks(function, argument_list: Sequence[tuple], client, threads: int, progress: Progress,
               label: str, retries: int) -> list:
    """function(*arguments) for every entry, results in the entries' order, on `client` (Dask)
    or on `threads` local threads."""
    report = _reporter(progress, label)
    total = len(argument_list)
    results: list = [None] * total
    done = 0
    if client is None:
        with ThreadPoolExecutor(max_workers=max(1, threads)) as pool:
            futures = {pool.submit(function, *args): i for i, args in enumerate(argument_list)}
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                done += 1
                report(done, total)
        return results
    from dask.distributed import as_completed as dask_as_completed

    futures = [client.submit(function, *args, pure=True, retries=retries) for args in argument_list]
    index = {future.key: i for i, future in enumerate(futures)}
    for future in dask_as_completed(futures):
        results[index[future.key]] = future.result()
        done += 1
        report(done, total)
    return results


def _uncertainty_task(urdf: str, muscle: str, postures: np.ndarray, spec: str, options: dict,
                      first: int, last: int) -> bytes:
    return _core._uncertainty_run(urdf, muscle, postures, spec, options, first, last, 1)


def uncertainty(model, muscle: Optional[str] = None, *, inputs: Optional[Iterable] = None,
                spec=None, from_fit: Optional[str] = None, q=None, postures=None,
                samples: int = 4096, seed: int = 1, sobol: bool = True, activation: float = 1.0,
                exact_percentile_values: float = 2e7, max_endpoint_fraction: float = 1e-3,
                max_joint_rotation: float = 0.01, rank_tolerance: float = 1e-12,
                client=None, threads: int = 0,
                blocks_per_task: Optional[int] = None, progress: Progress = False,
                retries: int = 3, connect_timeout: float = DEFAULT_CONNECT_TIMEOUT) -> dict:
    """Model.uncertainty as tasks: the same arguments, the same dict (the keys of
    `isowrench uncertainty --json`), on `client` (a dask.distributed.Client or a scheduler
    address) or on `threads` local threads (0: every core), the same numbers to the last bit
    however the work is spread. Each task runs `blocks_per_task` blocks of 2048 samples
    (default: about 4 tasks per worker thread).

    Tasks rebuild the model from `model.urdf_text`. URDF text spells rotations as rpy angles,
    and a rotation matrix read back from the rpy written for it can differ from the original in
    its last bit: with a rotated transducer or rotated joint origins the numbers equal
    `model.uncertainty(...)` to ~1e-13 relative (measured: 3e-14 N), not bit for bit; without
    rotations they are identical."""
    if muscle is None:
        muscle = model.muscles[0]
    spec_json = model.uncertainty_spec(inputs=inputs, spec=spec, from_fit=from_fit)
    if postures is None:
        rows = np.atleast_2d(np.asarray(_posture(model, q), dtype=float))
    else:
        rows = np.asarray(postures, dtype=float)
    options = {"samples": int(samples), "seed": int(seed), "sobol": bool(sobol),
               "activation": float(activation),
               "exact_percentile_values": float(exact_percentile_values),
               "max_endpoint_fraction": float(max_endpoint_fraction),
               "max_joint_rotation": float(max_joint_rotation),
               "rank_tolerance": float(rank_tolerance)}
    urdf = model.urdf_text
    blocks, _ = _core._uncertainty_blocks(urdf, muscle, rows, spec_json, options)
    client = connect(client, connect_timeout)
    if threads <= 0:
        import os
        threads = os.cpu_count() or 1
    workers = threads
    if client is not None:
        workers = max(1, sum(client.nthreads().values()))
    if blocks_per_task is None:
        blocks_per_task = max(1, math.ceil(blocks / (4 * workers)))
    ranges = [(first, min(blocks, first + blocks_per_task))
              for first in range(0, blocks, blocks_per_task)]
    start = time.perf_counter()
    parts = _run_tasks(_uncertainty_task,
                       [(urdf, muscle, rows, spec_json, options, a, b) for a, b in ranges],
                       client, threads, progress, "uncertainty", retries)
    seconds = time.perf_counter() - start
    return _core._uncertainty_finish(urdf, muscle, rows, spec_json, options, parts, seconds)


def _posture(model, q):
    if q is None:
        return model.default_posture
    if isinstance(q, dict):
        out = np.array(model.default_posture, dtype=float)
        for name, value in q.items():
            out[model.coordinates.index(name)] = value
        return out
    return np.asarray(q, dtype=float)


def _sweep_task(urdf: str, muscle: str, rows: np.ndarray, activation: float) -> np.ndarray:
    import isowrench
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "model.urdf")
        with open(path, "w", encoding="utf-8") as f:
            f.write(urdf)
        model = isowrench.load(path)
    return model.wrench_batch(muscle, rows, activation=activation, threads=1)


def sweep(model, muscle: str, Q, *, activation: float = 1.0, client=None, threads: int = 0,
          rows_per_task: int = 4096, progress: Progress = False, retries: int = 3,
          connect_timeout: float = DEFAULT_CONNECT_TIMEOUT) -> np.ndarray:
    """Model.wrench_batch(muscle, Q) as tasks of `rows_per_task` postures (rounded up to a
    multiple of 4, the engine's lane groups, so that every posture is evaluated exactly as in
    one call): (N, 6) N and N·m, transducer axes, equal to the single call bit for bit."""
    Q = np.ascontiguousarray(np.asarray(Q, dtype=float))
    if Q.ndim != 2 or Q.shape[1] != len(model.coordinates):
        raise ValueError(f"Q must be (N, {len(model.coordinates)}) in rad / m")
    rows_per_task = max(4, int(math.ceil(rows_per_task / 4) * 4))
    client = connect(client, connect_timeout)
    if threads <= 0:
        import os
        threads = os.cpu_count() or 1
    urdf = model.urdf_text
    chunks = [(urdf, muscle, Q[i:i + rows_per_task], activation)
              for i in range(0, Q.shape[0], rows_per_task)]
    parts = _run_tasks(_sweep_task, chunks, client, threads, progress, "sweep", retries)
    return np.concatenate(parts, axis=0) if parts else np.zeros((0, 6))


def _fit_task(urdf: str, csv: str, fit_options: dict) -> dict:
    import isowrench
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "model.urdf")
        with open(path, "w", encoding="utf-8") as f:
            f.write(urdf)
        model = isowrench.load(path)
    result = isowrench.fit(model, csv, **fit_options)
    result["csv"] = csv
    return result


def fit_sessions(model, csv_files: Iterable[str], *, client=None, threads: int = 0,
                 max_fit_trials: int = 20000, sample_seed: int = 1, progress: Progress = False,
                 retries: int = 3, connect_timeout: float = DEFAULT_CONNECT_TIMEOUT,
                 **fit_options) -> List[dict]:
    """isowrench.fit of every trial CSV (a lab's folder of sessions), one task each, results in
    the files' order (each dict gains 'csv'). Workers read the CSV paths: on a cluster they must
    see the same files (a shared filesystem). Other keywords go to every isowrench.fit call as
    they are (rounds=, candidates=, loss=, delimiter=';', decimal_comma=True, ...); a progress
    callable of the fit itself cannot cross to a worker process, so progress= is the study's."""
    files = [str(f) for f in csv_files]
    fit_options = dict(fit_options, max_fit_trials=max_fit_trials, sample_seed=sample_seed)
    client = connect(client, connect_timeout)
    if threads <= 0:
        import os
        threads = os.cpu_count() or 1
    urdf = model.urdf_text
    return _run_tasks(_fit_task, [(urdf, f, fit_options) for f in files], client,
                      threads, progress, "fit", retries)
