"""Batched runs: N variants of one plant structure in one call, in parallel, one record per case.

A *variant* is a dictionary ``{"section.key": number}`` applied to a base plant with
:meth:`simulate.config.PlantConfig.with_overrides`; every case then runs through the same
:func:`simulate.loop.engine.run_simulation` that ``hillsim run`` uses, so a batch result is bit-identical to the single
run of the same plant. Numeric keys vary within one structure; keys that choose a model (penstock model, scenario
kind, pressure loop, characteristics: :data:`STRUCTURE_CHOICE_KEYS`) group the cases, one batch of numbers per group
with its own characteristics and compiled loop (:class:`BatchPool` and the closure optimization, whose cases share
one structure, refuse them). ``penstock.reaches`` may vary (a grid-convergence study): each case builds its own grid.

Parallelism (chosen by measurement, ``benchmarks/bench_batch.py``): the compiled loop releases the GIL, but about
half of a shipped-plant case is Python around it (the plant variant, the figures), which threads run one at a time;
``mechanism="processes"`` (the default for more than :data:`SERIAL_BELOW` cases) forks worker processes *after* the
parent has run the first case, so the workers inherit the compiled loop instead of compiling it again (about 3 s
each), and hands them chunks of cases. ``mechanism="threads"`` shares the memory instead (about 10 % slower on 2
cores); ``mechanism="serial"`` runs in the calling thread. :class:`BatchPool` keeps the workers across batches and
runs a batch for every member of an ensemble at once (:meth:`BatchPool.run_members`).

A case that fails (a value out of range, a pressure loop that does not converge, anything raised) becomes a record
with ``status`` and ``error``; the batch goes on.

The keys that may vary and the checks of their values are :mod:`simulate.studies.variants`; the records of the cases
and what is read from each run, :mod:`simulate.studies.case_results`. Their names are importable from here as well.
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, Sequence

from hillchart.errors import HillsimError, InputError
from simulate.loop.parallel import available_cores as default_workers, checked_workers
from simulate.config import PlantConfig, load_characteristics
from simulate.studies.case_results import (FIGURES, RECORD_METADATA, SERIES_NAMES, BatchResult, CaseResult,
                                           case_from_result, extrapolation_kinds, nets_domain, run_case)
from simulate.studies.variants import (OPTIONAL_SECTIONS, STRUCTURE_CHOICE_KEYS, STRUCTURE_KEYS, check_choice_value,
                                       check_key, check_value, integer_keys, numeric_keys, structure_variant,
                                       validate_variants, variant_overrides)
from simulate.studies.variants import _EXCLUSIVE  # noqa: F401 (simulate.studies.cases reads it from here)

#: Below this many cases ``mechanism="auto"`` runs serially: forking a pool of workers from a process that holds
#: the compiled loop costs about 0.2 s, more than 100 shipped-plant cases take (bench_batch.py: processes lose at
#: N = 100, win by 2x at N = 1000 on 2 cores).
SERIAL_BELOW = 200
MECHANISMS = ("auto", "serial", "processes", "threads")


# ---------------------------------------------------------------------------------------------------------------
# workers
# ---------------------------------------------------------------------------------------------------------------
_WORKER: dict = {}


_FORK_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP", "SIGXCPU") if hasattr(signal, n))


class _SignalsBlockedWhileForking:
    """Blocks SIGINT/SIGTERM/SIGHUP/SIGXCPU while a pool forks its workers: a worker is born with the parent's
    Python handlers and keeps them until its initializer resets them (:func:`_worker_signals`, which unblocks); a
    signal in between would end it with the parent's exception and a traceback. The parent receives what arrived
    once the workers exist."""

    def __enter__(self):
        self.blocked = hasattr(signal, "pthread_sigmask")
        if self.blocked:
            self.previous = signal.pthread_sigmask(signal.SIG_BLOCK, _FORK_SIGNALS)
        return self

    def __exit__(self, *exc):
        if self.blocked:
            signal.pthread_sigmask(signal.SIG_SETMASK, self.previous)


def _worker_signals() -> None:
    """A forked worker must not keep the parent's signal handlers (the CLI's raise exceptions that end in a
    traceback on stderr when the pool terminates its workers with SIGTERM): SIGTERM, SIGHUP and SIGXCPU end a
    worker quietly, SIGINT is left to the parent (it stops the pool)."""
    import signal

    for name in ("SIGTERM", "SIGHUP", "SIGXCPU"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # blocked by the parent while it forked (_SignalsBlockedWhileForking)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _FORK_SIGNALS)


def _init_worker(plant, characteristics, domain, keep_series):
    _worker_signals()
    _WORKER.update(plant=plant, characteristics=characteristics, domain=domain, keep_series=keep_series)


def _run_chunk_in_worker(chunk):
    w = _WORKER
    return [run_case(w["plant"], w["characteristics"], i, v, domain=w["domain"], keep_series=w["keep_series"])
            for i, v in chunk]


def run_chunk(plant: PlantConfig, characteristics, chunk: Sequence[tuple[int, dict]], keep_series: bool = False):
    """Run a chunk ``[(index, variant), ...]`` serially (the unit of work of every parallel mechanism, Dask too)."""
    domain = nets_domain(characteristics, plant)
    return [run_case(plant, characteristics, i, v, domain=domain, keep_series=keep_series) for i, v in chunk]


def run_batch(plant: PlantConfig, variants: Iterable[dict], *, characteristics=None, mechanism: str = "auto",
              workers: int | None = None, chunk_size: int | None = None, keep_series: bool = False,
              progress: Callable[[int, int], None] | None = None) -> BatchResult:
    """Run every variant of ``plant`` and return one :class:`CaseResult` per variant, in order.

    Parameters
    ----------
    plant : PlantConfig
        The base plant (structure shared by every case).
    variants : iterable of dict
        ``{"section.key": number}`` per case (an empty dict runs the base plant).
    characteristics : optional
        Turbine characteristics; default ``plant.turbine.characteristics`` loaded once.
    mechanism : {"auto", "serial", "processes", "threads"}
        ``auto``: serial below :data:`SERIAL_BELOW` cases or with one worker, processes otherwise.
    workers : int, optional
        Parallel workers (default: the cores this process may use).
    chunk_size : int, optional
        Cases per task (default: about four chunks per worker, at most 64 cases).
    keep_series : bool
        Keep the time series of each case in ``CaseResult.series``.
    progress : callable(done, total), optional
        Called after each chunk.

    Raises
    ------
    InputError
        A bad key or value (before anything runs). Failing cases do not raise: they are records.

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from data_synthetic import PLANT_HLA339
    >>> plant = load_plant(PLANT_HLA339, {"turbine.characteristics": "ideal", "scenario.t_end_s": 3.0,
    ...                                   "penstock.model": "rigid"})
    >>> batch = run_batch(plant, [{"governor.closing_time_s": 8.0}, {"governor.closing_time_s": -1.0}])
    >>> [c.status for c in batch.cases]
    ['ok', 'error']
    """
    if mechanism not in MECHANISMS:
        raise InputError(f"mechanism must be one of {', '.join(MECHANISMS)}, got {mechanism!r}")
    keys, variants = validate_variants(plant, variants, choices=True)
    if any(key in STRUCTURE_CHOICE_KEYS for key in keys):
        return _run_grouped(plant, keys, variants, characteristics=characteristics, mechanism=mechanism,
                            workers=workers, chunk_size=chunk_size, keep_series=keep_series, progress=progress)
    n = len(variants)
    workers = checked_workers(workers)
    if chunk_size is None:
        chunk_size = max(1, min(64, math.ceil(n / (4 * workers)))) if n else 1
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise InputError(f"chunk_size must be a positive integer, got {chunk_size!r}")
    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    domain = nets_domain(chars, plant)
    if mechanism == "auto":
        mechanism = "serial" if n < SERIAL_BELOW or workers == 1 else "processes"
    wall = time.perf_counter()
    indexed = list(enumerate(variants))
    cases: list[CaseResult] = []

    def report(done):
        if progress is not None:
            progress(done, n)

    if mechanism == "serial" or n == 0:
        for start in range(0, n, chunk_size):
            cases.extend(run_chunk(plant, chars, indexed[start:start + chunk_size], keep_series))
            report(len(cases))
    else:
        # the first case in this process: compiles the loop before the workers fork (they inherit it)
        cases.extend(run_chunk(plant, chars, indexed[:1], keep_series))
        report(1)
        rest = indexed[1:]
        chunks = [rest[s:s + chunk_size] for s in range(0, len(rest), chunk_size)]
        if not chunks:
            pass
        elif mechanism == "threads":
            with ThreadPoolExecutor(max_workers=workers) as pool:
                for part in pool.map(lambda c: run_chunk(plant, chars, c, keep_series), chunks):
                    cases.extend(part)
                    report(len(cases))
        else:
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                              else "spawn")
            with _SignalsBlockedWhileForking():
                pool = ctx.Pool(processes=min(workers, max(1, len(chunks))), initializer=_init_worker,
                                initargs=(plant, chars, domain, keep_series))
            with pool:
                for part in pool.imap_unordered(_run_chunk_in_worker, chunks):
                    cases.extend(part)
                    report(len(cases))
    cases.sort(key=lambda c: c.index)
    return BatchResult(keys=keys, cases=cases, mechanism=mechanism, workers=workers, chunk_size=chunk_size,
                       wall_time_s=time.perf_counter() - wall)


def _run_grouped(plant: PlantConfig, keys: tuple, variants: list[dict], *, characteristics, mechanism, workers,
                 chunk_size, keep_series, progress) -> BatchResult:
    """:func:`run_batch` of variants that vary :data:`STRUCTURE_CHOICE_KEYS`: the cases grouped by their model
    names, each group's plant (and characteristics, when ``turbine.characteristics`` varies) built and checked
    before anything runs, one batch of numbers per group, the records back in the variants' order."""
    choice_keys = [k for k in keys if k in STRUCTURE_CHOICE_KEYS]
    groups: dict[tuple, list[int]] = {}
    for i, variant in enumerate(variants):
        groups.setdefault(tuple(variant.get(k) for k in choice_keys), []).append(i)
    plan = []
    shared = characteristics
    for choice, indices in groups.items():
        group_plant, chars = structure_variant(plant, {k: v for k, v in zip(choice_keys, choice) if v is not None})
        if chars is None:
            if shared is None:
                shared = load_characteristics(plant.turbine, plant.base_dir)
            chars = shared
        numeric = [{k: v for k, v in variants[i].items() if k not in STRUCTURE_CHOICE_KEYS} for i in indices]
        plan.append((group_plant, chars, indices, numeric))
    wall = time.perf_counter()
    cases: list[CaseResult] = []
    done = 0
    result = None
    for group_plant, chars, indices, numeric in plan:
        def report(count, _total, offset=done):
            if progress is not None:
                progress(offset + count, len(variants))

        result = run_batch(group_plant, numeric, characteristics=chars, mechanism=mechanism, workers=workers,
                           chunk_size=chunk_size, keep_series=keep_series, progress=report)
        for case in result.cases:  # the record of the whole variant, at its place among all the variants
            index = indices[case.index]
            cases.append(dataclasses.replace(case, index=index, values=dict(variants[index])))
        done += len(indices)
    cases.sort(key=lambda c: c.index)
    return BatchResult(keys=keys, cases=cases, mechanism=result.mechanism, workers=result.workers,
                       chunk_size=result.chunk_size, wall_time_s=time.perf_counter() - wall)


def _init_pool_worker(plant, members, domains):
    _worker_signals()
    _WORKER.update(plant=plant, members=members, domains=domains)


def run_chunk_members(plant: PlantConfig, members: Sequence, domains: Sequence, chunk: Sequence[tuple[int, dict]],
                      keep_series: bool = False) -> list[list[CaseResult]]:
    """A chunk of variants for every characteristics of ``members``: each variant's plant is built once. One list
    of :class:`CaseResult` per member."""
    out: list[list[CaseResult]] = [[] for _ in members]
    for index, variant in chunk:
        try:
            case_plant = plant.with_overrides(variant_overrides(variant)) if variant else plant
        except (HillsimError, ValueError, ArithmeticError) as exc:
            for cases in out:
                cases.append(CaseResult(index=index, values=dict(variant), status="error",
                                        error=f"{type(exc).__name__}: {exc}"))
            continue
        for cases, chars, domain in zip(out, members, domains):
            cases.append(run_case(plant, chars, index, variant, domain=domain, keep_series=keep_series,
                                  case_plant=case_plant))
    return out


def _run_pool_members(task):
    members, keep_series, chunk = task
    w = _WORKER
    return run_chunk_members(w["plant"], [w["members"][m] for m in members], [w["domains"][m] for m in members],
                             chunk, keep_series)


def _run_pool_chunk(task):
    member, keep_series, chunk = task
    w = _WORKER
    return [run_case(w["plant"], w["members"][member], i, v, domain=w["domains"][member], keep_series=keep_series)
            for i, v in chunk]


class BatchPool:
    """Worker processes kept across many batches of one plant (the generations of an optimizer, say).

    The pool is forked once, after this process has run the plant once (so the workers inherit the compiled loop);
    each :meth:`run` then costs only the transfer of its chunks, which makes batches of a few dozen cases worth
    running in parallel (a fresh pool per batch pays off only from :data:`SERIAL_BELOW` cases on). ``members`` are
    the characteristics a batch can use (e.g. the members of an ensemble), chosen per :meth:`run` by index. With one
    worker everything runs in this process. Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, plant: PlantConfig, members: Sequence | None = None, *, workers: int | None = None):
        self.plant = plant
        self.members = list(members) if members else [load_characteristics(plant.turbine, plant.base_dir)]
        self.domains = [nets_domain(m, plant) for m in self.members]
        self.workers = checked_workers(workers)
        self._pool = None
        if self.workers > 1:
            run_case(plant, self.members[0], 0, {})  # compile here, before the fork
            ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                              else "spawn")
            with _SignalsBlockedWhileForking():
                self._pool = ctx.Pool(processes=self.workers, initializer=_init_pool_worker,
                                      initargs=(plant, self.members, self.domains))

    def _check_member(self, member) -> None:
        if isinstance(member, bool) or not isinstance(member, int) or not 0 <= member < len(self.members):
            raise InputError(f"member must be an index in [0, {len(self.members) - 1}], got {member!r}")

    def run(self, variants: Iterable[dict], *, member: int = 0, chunk_size: int | None = None,
            keep_series: bool = False) -> BatchResult:
        """Like :func:`run_batch` with ``characteristics = members[member]``, on the pool's workers."""
        self._check_member(member)
        keys, variants = validate_variants(self.plant, variants)
        n = len(variants)
        if chunk_size is None:
            chunk_size = max(1, math.ceil(n / (2 * self.workers))) if n else 1
        wall = time.perf_counter()
        indexed = list(enumerate(variants))
        chunks = [indexed[s:s + chunk_size] for s in range(0, n, chunk_size)]
        if self._pool is None:
            parts = [run_chunk(self.plant, self.members[member], chunk, keep_series) for chunk in chunks]
        else:
            parts = self._pool.map(_run_pool_chunk, [(member, keep_series, chunk) for chunk in chunks])
        cases = sorted((c for part in parts for c in part), key=lambda c: c.index)
        return BatchResult(keys=keys, cases=cases, mechanism="pool" if self._pool is not None else "serial",
                           workers=self.workers, chunk_size=chunk_size, wall_time_s=time.perf_counter() - wall)

    def run_members(self, variants: Iterable[dict], members: Sequence[int] | None = None, *,
                    keep_series: bool = False) -> list[BatchResult]:
        """:meth:`run` of the same variants for each of ``members`` (default all), as one batch: a chunk of variants
        runs for every member (each variant's plant built once) and the workers take the chunks of all members
        together (one wait for the slowest chunk, not one per member). One :class:`BatchResult` per member, in the
        order given."""
        members = list(range(len(self.members))) if members is None else list(members)
        for member in members:
            self._check_member(member)
        keys, variants = validate_variants(self.plant, variants)
        n = len(variants)
        chunk_size = max(1, math.ceil(n / (4 * self.workers))) if n else 1
        wall = time.perf_counter()
        indexed = list(enumerate(variants))
        tasks = [(members, keep_series, indexed[s:s + chunk_size]) for s in range(0, n, chunk_size)]
        if self._pool is None:
            parts = [run_chunk_members(self.plant, [self.members[m] for m in members],
                                       [self.domains[m] for m in members], chunk, keep_series)
                     for _, _, chunk in tasks]
        else:
            parts = self._pool.map(_run_pool_members, tasks)
        wall = time.perf_counter() - wall
        return [BatchResult(keys=keys, cases=sorted((c for part in parts for c in part[j]), key=lambda c: c.index),
                            mechanism="pool" if self._pool is not None else "serial", workers=self.workers,
                            chunk_size=chunk_size, wall_time_s=wall) for j in range(len(members))]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.close()
            self._pool.join()
            self._pool = None

    def __enter__(self) -> "BatchPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["SERIAL_BELOW", "STRUCTURE_KEYS", "STRUCTURE_CHOICE_KEYS", "MECHANISMS", "FIGURES", "CaseResult",
           "BatchResult", "BatchPool", "numeric_keys", "check_key", "check_value", "check_choice_value",
           "variant_overrides", "extrapolation_kinds", "nets_domain", "case_from_result", "run_case", "run_chunk",
           "run_chunk_members", "run_batch", "structure_variant", "validate_variants", "default_workers",
           "OPTIONAL_SECTIONS", "SERIES_NAMES", "RECORD_METADATA", "integer_keys"]
