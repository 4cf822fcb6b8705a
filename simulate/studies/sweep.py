"""Parameter sweeps: ``--vary`` specifications and ``cases.csv`` -> variants -> a batch (local or Dask) -> files.

``KEY=START:STOP:COUNT`` is COUNT evenly spaced values with both ends included (``4:20:9`` is 4, 6, ..., 20);
``KEY=v1,v2,...`` a list. Several ``--vary`` make the Cartesian product (the first key varies slowest).
``cases.csv`` has one header line naming the keys (``section.key``) and one row of numbers per case; with
``--vary`` as well, every row is combined with every ``--vary`` combination.

Outputs of :func:`write_sweep` in the output folder: ``results.csv`` (one row per case, columns of
:meth:`simulate.studies.batch.BatchResult.rows`), ``sweep.json`` (settings, counts, wall time) and ``sweep.png`` (each
maximum against each varied key).
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from hillchart.errors import InputError
from simulate.studies.batch import (STRUCTURE_CHOICE_KEYS, BatchResult, check_choice_value, check_key, check_value,
                            default_workers, nets_domain, run_batch, run_chunk, structure_variant,
                            validate_variants)
from simulate.components.turbine.component import characteristics_of
from simulate.config import PlantConfig

#: Largest number of cases one sweep accepts (a typo such as 4:20:90000 x 3 keys should not start).
MAX_CASES = 1_000_000
#: Figures drawn against the varied keys in sweep.png (those with no finite value are skipped).
PLOTTED = (("max_speed_rise", "max speed rise (fraction)"), ("max_head_rise", "max head rise (fraction)"),
           ("min_head_m", "min head at turbine (m)"), ("min_pressure_head_m", "min pressure head along penstock (m)"))


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{what}: {text.strip()!r} must be finite")
    return value


def parse_vary(text: str) -> tuple[str, list]:
    """``"KEY=START:STOP:COUNT"`` or ``"KEY=v1,v2,..."`` -> (key, values); for a key that selects a model
    (:data:`simulate.studies.batch.STRUCTURE_CHOICE_KEYS`) ``"KEY=name1,name2"`` -> (key, names).

    Examples
    --------
    >>> parse_vary("governor.closing_time_s=4:20:9")
    ('governor.closing_time_s', [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0])
    >>> parse_vary("scenario.initial_power_mw=100,160,225")
    ('scenario.initial_power_mw', [100.0, 160.0, 225.0])
    >>> parse_vary("penstock.model=moc,rigid")
    ('penstock.model', ['moc', 'rigid'])
    >>> parse_vary("governor.kp=1:2:0")
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: --vary governor.kp=1:2:0: COUNT must be an integer >= 1, got '0'
    """
    if not isinstance(text, str) or "=" not in text:
        raise InputError(f"--vary expects KEY=START:STOP:COUNT or KEY=v1,v2,..., got {text!r}")
    key, spec = (s.strip() for s in text.split("=", 1))
    what = f"--vary {key}={spec}"
    if not key:
        raise InputError(f"--vary {text!r}: the key before '=' is empty (e.g. governor.closing_time_s)")
    if not spec:
        raise InputError(f"{what}: no values after '='; give START:STOP:COUNT or v1,v2,...")
    if key in STRUCTURE_CHOICE_KEYS:  # a model's name per value (the sweep groups its cases by it)
        names = [v.strip() for v in spec.split(",")]
        if not all(names):
            raise InputError(f"{what}: an empty name in the list; give names separated by commas")
        if len(set(names)) != len(names):
            raise InputError(f"{what}: a name is repeated; each name once")
        return key, names
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise InputError(f"{what}: a range is START:STOP:COUNT (three fields), got {len(parts)} fields")
        start, stop = _number(parts[0], f"{what} START"), _number(parts[1], f"{what} STOP")
        count_text = parts[2].strip()
        if not count_text.isdigit() or int(count_text) < 1:
            raise InputError(f"{what}: COUNT must be an integer >= 1, got {count_text!r}")
        count = int(count_text)
        if count > MAX_CASES:
            raise InputError(f"{what}: COUNT must be <= {MAX_CASES}, got {count}")
        if count == 1 and start != stop:
            raise InputError(f"{what}: COUNT 1 needs START == STOP (both ends are included), got {start!r} and "
                             f"{stop!r}")
        if count > 1 and start == stop:
            raise InputError(f"{what}: START == STOP gives {count} equal values; use COUNT 1 or a list")
        values = [float(v) for v in np.linspace(start, stop, count)]
    else:
        values = [_number(v, f"{what} value {i + 1}") for i, v in enumerate(spec.split(","))]
    if len(set(values)) != len(values):
        dup = next(v for v in values if values.count(v) > 1)
        raise InputError(f"{what}: value {dup!r} is repeated; each value once")
    return key, values


def cartesian(varies: Sequence[tuple[str, list[float]]]) -> list[dict]:
    """The Cartesian product of ``[(key, values), ...]`` as variants (first key slowest); duplicate keys refused.

    Examples
    --------
    >>> cartesian([("a.x", [1.0, 2.0]), ("b.y", [5.0])])
    [{'a.x': 1.0, 'b.y': 5.0}, {'a.x': 2.0, 'b.y': 5.0}]
    """
    keys = [k for k, _ in varies]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError(f"--vary {k} is given more than once; give each key once (a list or range)")
    total = math.prod(len(v) for _, v in varies) if varies else 0
    if total > MAX_CASES:
        raise InputError(f"the --vary product has {total} cases, more than {MAX_CASES}; reduce COUNT or values")
    if not varies:
        return []
    return [dict(zip(keys, combo)) for combo in itertools.product(*(v for _, v in varies))]


def load_cases_csv(path: str | Path, plant: PlantConfig) -> list[dict]:
    """Read ``cases.csv``: a header naming the varied keys, one row of numbers per case.

    Raises
    ------
    InputError
        Unreadable or non-UTF-8 file, empty file, no rows, empty/duplicate/unknown/structure column, a row with the
        wrong number of cells, a non-numeric or non-finite cell (the message names the file, row and column).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark is accepted
    except UnicodeDecodeError as exc:
        from hillchart.io.tabular import not_utf8_detail

        raise InputError(f"--cases {str(path)!r} is not UTF-8 text {not_utf8_detail(exc)}") from None
    except OSError as exc:
        raise InputError(f"cannot read --cases file {str(path)!r}: {exc.strerror}") from None
    from hillchart.io.tabular import decimal_commas, numbered_rows

    # a spreadsheet's semicolon- or tab-separated export, perhaps with decimal commas, reads as every CSV input does
    # (hillchart.io.tabular); rows are numbered as the file's lines
    delimiter, rows = numbered_rows(text, f"--cases {str(path)!r}")
    if not rows:
        raise InputError(f"--cases {str(path)!r} is empty; it needs a header of keys (section.key) and one row "
                         f"per case")
    header = [h.strip() for h in rows[0][1]]
    for j, key in enumerate(header):
        if not key:
            raise InputError(f"--cases {str(path)!r}: column {j + 1} of the header is empty")
        if header.count(key) > 1:
            raise InputError(f"--cases {str(path)!r}: column {key!r} appears more than once")
        try:
            check_key(plant, key, choices=True)
        except InputError as exc:
            raise InputError(f"--cases {str(path)!r} column {j + 1}: {exc}") from None
    if len(rows) < 2:
        raise InputError(f"--cases {str(path)!r} has a header but no case rows")
    for i, row in rows[1:]:
        if len(row) != len(header):
            raise InputError(f"--cases {str(path)!r} row {i}: {len(row)} cells, the header has {len(header)}")
    decimal_comma, note = decimal_commas(f"--cases {str(path)!r}", delimiter,
                                         (cell for _, row in rows[1:] for key, cell in zip(header, row)
                                          if key not in STRUCTURE_CHOICE_KEYS))
    if note:
        warnings.warn(note, UserWarning, stacklevel=2)
    out = []
    for i, row in rows[1:]:
        out.append({key: cell.strip() if key in STRUCTURE_CHOICE_KEYS else
                    _number(cell.replace(",", ".") if decimal_comma else cell,
                            f"--cases {str(path)!r} row {i} column {key!r}") for key, cell in zip(header, row)})
    return out


def build_variants(plant: PlantConfig, varies: Sequence[str] = (), cases_csv: str | Path | None = None) -> list[dict]:
    """Variants of a sweep from ``--vary`` texts and an optional ``cases.csv`` (rows x product); keys validated
    (each key before its values are read, so a misspelt key or one that takes a name is named as such, not reported
    as a value that is not a number)."""
    for text in varies:
        key = text.split("=", 1)[0].strip() if isinstance(text, str) and "=" in text else ""
        if key:
            check_key(plant, key, choices=True)
    parsed = [parse_vary(t) for t in varies]
    for key, values in parsed:
        for v in values:
            check_choice_value(key, v) if key in STRUCTURE_CHOICE_KEYS else check_value(key, v)
    product = cartesian(parsed)
    if cases_csv is None:
        if not product:
            raise InputError("a sweep needs at least one --vary KEY=... or --cases cases.csv")
        variants = product
    else:
        rows = load_cases_csv(cases_csv, plant)
        clash = sorted(set(rows[0]) & {k for k, _ in parsed})
        if clash:
            raise InputError(f"key {clash[0]!r} is both a --cases column and a --vary; give it once")
        variants = [{**row, **combo} for row in rows for combo in (product or [{}])]
        if len(variants) > MAX_CASES:
            raise InputError(f"the sweep has {len(variants)} cases, more than {MAX_CASES}")
    keys, variants = validate_variants(plant, variants, choices=True)  # integer keys (penstock.reaches) as ints
    for key in (k for k in keys if k in STRUCTURE_CHOICE_KEYS):  # every model name checked before anything runs
        for name in dict.fromkeys(v[key] for v in variants if key in v):
            structure_variant(plant, {key: name})
    return variants


# ---------------------------------------------------------------------------------------------------------------
# Dask
# ---------------------------------------------------------------------------------------------------------------
DASK_MISSING = ("--scheduler dask needs dask.distributed, which is not installed; install it with "
                "pip install 'hillsim[dask]' (or pip install dask distributed)")


def run_batch_dask(plant: PlantConfig, variants, *, characteristics=None, address: str | None = None,
                   n_workers: int = 2, processes: bool = True, chunk_size: int | None = None,
                   keep_series: bool = False, progress: Callable[[int, int], None] | None = None,
                   connect_timeout_s: float = 10.0) -> BatchResult:
    """Like :func:`simulate.studies.batch.run_batch`, with chunks of cases as Dask tasks.

    ``address`` connects to a running scheduler (``tcp://host:8786``); without it a ``LocalCluster`` of
    ``n_workers`` single-threaded workers (``processes=False``: threads of this process) runs the sweep. Each task is
    :func:`simulate.studies.batch.run_chunk` on a chunk, so the cases run exactly as in a local batch.
    """
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise InputError(DASK_MISSING) from None
    keys, variants = validate_variants(plant, variants)  # one structure: the model choices run locally (grouped)
    if isinstance(n_workers, bool) or not isinstance(n_workers, int) or n_workers < 1:
        raise InputError(f"n_workers must be a positive integer, got {n_workers!r}")
    n = len(variants)
    if chunk_size is None:
        chunk_size = max(1, min(64, math.ceil(n / (4 * n_workers)))) if n else 1
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise InputError(f"chunk_size must be a positive integer, got {chunk_size!r}")
    chars = characteristics_of(plant, characteristics)
    indexed = list(enumerate(variants))
    chunks = [indexed[s:s + chunk_size] for s in range(0, n, chunk_size)]
    wall = time.perf_counter()
    cluster = None
    try:
        if address is None:
            cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=processes,
                                   dashboard_address=None, silence_logs=logging.CRITICAL)
            client = Client(cluster)
        else:
            try:
                client = Client(address, timeout=f"{connect_timeout_s}s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"--scheduler dask {address}: cannot connect to the Dask scheduler ({exc}); give "
                                 f"its address as tcp://HOST:PORT") from None
        with client:
            plant_f = client.scatter(plant, broadcast=True)
            chars_f = client.scatter(chars, broadcast=True)
            futures = [client.submit(run_chunk, plant_f, chars_f, chunk, keep_series, pure=False)
                       for chunk in chunks]
            cases = []
            for future in as_completed(futures):
                cases.extend(future.result())
                if progress is not None:
                    progress(len(cases), n)
            workers = len(client.scheduler_info().get("workers", {})) or n_workers
    finally:
        if cluster is not None:
            cluster.close()
    cases.sort(key=lambda c: c.index)
    return BatchResult(keys=keys, cases=cases, mechanism="dask", workers=workers, chunk_size=chunk_size,
                       wall_time_s=time.perf_counter() - wall)


# ---------------------------------------------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------------------------------------------
def plot_sweep(batch: BatchResult, path: str | Path) -> Path | None:
    """Each plotted figure (rows) against each varied key (columns); colour = the next varied key. Failed cases are
    left out (they are in results.csv). Returns None when no case succeeded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = np.array([c.ok for c in batch.cases])
    if not ok.any() or not batch.keys:
        return None
    figures = [(name, label) for name, label in PLOTTED if np.isfinite(batch.column(name)[ok]).any()]
    keys = list(batch.keys)
    fig, axes = plt.subplots(len(figures), len(keys), figsize=(4.2 * len(keys), 3.0 * len(figures)),
                             squeeze=False)
    for j, key in enumerate(keys):
        x = batch.column(key)[ok]  # a model's name: a categorical axis
        colour_key = keys[(j + 1) % len(keys)] if len(keys) > 1 else None
        if colour_key in STRUCTURE_CHOICE_KEYS:
            colour_key = None  # a colour scale needs numbers
        colour = batch.column(colour_key)[ok] if colour_key else None
        for i, (name, label) in enumerate(figures):
            ax = axes[i, j]
            sc = ax.scatter(x, batch.column(name)[ok], c=colour, s=14, cmap="viridis" if colour is not None else None)
            ax.grid(True, alpha=0.3)
            if j == 0:
                ax.set_ylabel(label)
            if i == len(figures) - 1:
                ax.set_xlabel(key)
            if colour_key and i == 0:
                fig.colorbar(sc, ax=ax, label=colour_key)
    fig.suptitle(f"sweep: {int(ok.sum())} of {len(batch.cases)} cases ok")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def write_sweep(batch: BatchResult, out_dir: str | Path, *, plant_file: str | None = None, plot: bool = True,
                extra: dict[str, Any] | None = None) -> dict[str, Path]:
    """Write results.csv, sweep.json and (``plot``) sweep.png into ``out_dir``; returns the paths written."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    paths = {"results": out / "results.csv", "summary": out / "sweep.json"}
    batch.to_csv(paths["results"])
    statuses = [c.status for c in batch.cases]
    extrapolated = [c.index for c in batch.cases if c.extrapolated]
    info = {"plant_file": plant_file, "keys": list(batch.keys), "cases": len(batch.cases),
            "ok": statuses.count("ok"), "failed": statuses.count("failed"), "error": statuses.count("error"),
            "extrapolated_cases": extrapolated, "mechanism": batch.mechanism, "workers": batch.workers,
            "chunk_size": batch.chunk_size, "wall_time_s": batch.wall_time_s, "case_steps": batch.case_steps}
    info.update(extra or {})
    paths["summary"].write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
    if plot:
        png = plot_sweep(batch, out / "sweep.png")
        if png is not None:
            paths["plot"] = png
    return paths


def run_sweep(plant: PlantConfig, variants, *, scheduler: str = "local", address: str | None = None,
              workers: int | None = None, chunk_size: int | None = None, dask_processes: bool = True,
              progress: Callable[[int, int], None] | None = None, characteristics=None) -> BatchResult:
    """Run the variants locally (:func:`simulate.studies.batch.run_batch`) or on Dask (:func:`run_batch_dask`)."""
    if scheduler not in ("local", "dask"):
        raise InputError(f"--scheduler must be local or dask, got {scheduler!r}")
    if scheduler == "local":
        if address is not None:
            raise InputError(f"--scheduler local takes no address, got {address!r}")
        return run_batch(plant, variants, characteristics=characteristics, workers=workers, chunk_size=chunk_size,
                         progress=progress)
    return run_batch_dask(plant, variants, characteristics=characteristics, address=address,
                          n_workers=workers or default_workers(), processes=dask_processes, chunk_size=chunk_size,
                          progress=progress)


__all__ = ["MAX_CASES", "DASK_MISSING", "parse_vary", "cartesian", "load_cases_csv", "build_variants",
           "run_batch_dask", "run_sweep", "plot_sweep", "write_sweep", "nets_domain"]
