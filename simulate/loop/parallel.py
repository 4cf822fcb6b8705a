"""Several whole runs at once on threads: the members of an ensemble, the load cases of a study.

The compiled loop releases the GIL (``nogil=True``, :mod:`simulate.loop.assembly`), so while one thread steps its
run another prepares or finishes its own; each run is :func:`simulate.loop.engine.run_simulation` itself, so a
result is the one a single run gives. Threads rather than processes because the callers keep the whole
:class:`simulate.results.result.SimulationResult` (series included) and run a handful of cases: a pool of processes
would cost more to start and to send the series back than the runs take (ten members of the shipped plant: about
30 ms on 2 threads, 48 ms in one). For thousands of cases that keep only their figures, see
:mod:`simulate.studies.batch`.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Sequence

from hillchart.errors import HillsimError


def available_cores() -> int:
    """CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def checked_workers(workers) -> int:
    """``workers`` (a positive integer), or the cores this process may use when None; anything else is an
    :class:`~hillchart.errors.InputError`."""
    if workers is None:
        return available_cores()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        from hillchart.errors import InputError

        raise InputError(f"workers must be a positive integer, got {workers!r}")
    return workers


def run_all(jobs: Sequence[tuple], *, workers: int | None = None, raise_on_failure: bool = True) -> list:
    """Run every ``(plant, characteristics)`` of ``jobs`` and return, in the same order, its
    :class:`~simulate.results.result.SimulationResult` or the :class:`~hillchart.errors.HillsimError` it raised (a
    failing run does not stop the others; the caller reports it).

    Parameters
    ----------
    jobs : sequence of (PlantConfig, characteristics or None)
    workers : int, optional
        Threads (default: the cores this process may use; 1 runs in the calling thread).
    raise_on_failure : bool
        Passed to :func:`~simulate.loop.engine.run_simulation`.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> plants = [load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0,
    ...                                     "scenario.initial_power_mw": p}) for p in (150.0, 225.0, 330.0)]
    >>> [type(r).__name__ for r in run_all([(p, None) for p in plants], workers=2)]
    ['SimulationResult', 'SimulationResult', 'InputError']
    """
    from simulate.loop.engine import run_simulation

    jobs = list(jobs)
    workers = checked_workers(workers)

    def one(job):
        plant, characteristics = job
        try:
            return run_simulation(plant, characteristics=characteristics, raise_on_failure=raise_on_failure)
        except HillsimError as exc:
            return exc

    if workers == 1 or len(jobs) <= 1:
        return [one(job) for job in jobs]
    first = one(jobs[0])  # loads (or compiles) the loop once, before the threads share it
    with ThreadPoolExecutor(max_workers=min(workers, len(jobs) - 1)) as pool:
        return [first] + list(pool.map(one, jobs[1:]))
