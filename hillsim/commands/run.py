"""``hillsim run plant.toml --out DIR [--set section.key=value ...]``: simulate a plant's scenario.

Writes ``DIR/timeseries.csv``, ``DIR/summary.json``, ``DIR/envelope.csv`` and the figures ``DIR/transient.png`` and
``DIR/envelope.png`` (all files are written by :func:`write_run_outputs`, after the simulation). Warnings (time step,
extrapolation outside the characteristics' trusted domain, column separation) go to stderr and into
``summary.json``. Ctrl-C stops the run within about a second with exit code 130, writing nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from hillsim import progress
from hillsim.commands import add_set_option, load_command_plant


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "run", help="simulate a plant file's scenario (load rejection, closure law, frequency/load/opening steps)",
        description="Simulate the scenario of a plant TOML file and write timeseries.csv, summary.json, "
                    "envelope.csv, transient.png and envelope.png into --out.")
    parser.add_argument("plant", type=Path, help="plant TOML file")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    add_set_option(parser)
    parser.add_argument("--no-plot", action="store_true", help="do not write transient.png and envelope.png")
    parser.add_argument("--check-step", action="store_true",
                        help="rerun at half the time step (twice penstock.reaches for moc) and report the change of "
                             "each summary figure (stdout and summary.json \"step_check\"): a converged result "
                             "changes by little")
    parser.add_argument("--uncertainty", action="store_true",
                        help="also run the scenario once per ensemble member of the nets and add the 5-95 %% band "
                             "of max speed rise and max/min head to summary.json")
    parser.set_defaults(func=run_command)


class FigureProcess:
    """Draws a run's two figures in a forked child process (POSIX), so that on a multi-core machine matplotlib's
    import (about 0.5 s) runs while this process imports numba and simulates, and the drawing (about 0.5 s) while
    it writes the data files (``hillsim run`` <= 2 s). Matplotlib is not thread-safe and its
    work holds the GIL, hence a process; forked, it needs no second interpreter start-up and sees the same modules.

    The child reads the result (pickled, without the characteristics object) from a pipe, writes the PNGs and
    answers "ok" or its traceback; it ends with ``os._exit`` (never this process's clean-up, e.g. the output set).
    :meth:`close` without a finished :meth:`draw` (an error, Ctrl-C) stops the child. Where fork is unavailable, or
    the child is gone or failed (``failure`` keeps its traceback), the figures are drawn here.
    """

    def __init__(self):
        self.pid = None
        self.failure = ""
        if not hasattr(os, "fork"):
            return
        import signal

        job_r, job_w = os.pipe()
        done_r, done_w = os.pipe()
        # no Ctrl-C / SIGTERM may land while the process forks: a signal caught half-way (its Python handler
        # pending in both processes) once ended the parent by SIGINT instead of the CLI's exit 130
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        pid = os.fork()
        if pid == 0:  # pragma: no cover - runs in the child (its coverage is not collected)
            answer = b""
            try:
                signal.signal(signal.SIGINT, signal.SIG_DFL)  # Ctrl-C / SIGTERM end the child quietly
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
                os.close(job_w)
                os.close(done_r)
                import matplotlib.backends.backend_agg  # noqa: F401  (the import is the work done ahead)
                import matplotlib.figure  # noqa: F401

                with os.fdopen(job_r, "rb") as pipe:
                    job = pipe.read()
                if job:
                    import pickle

                    from simulate.results.envelope import plot_envelope

                    result, transient_png, envelope_png, band = pickle.loads(job)
                    result.plot(transient_png, band=band)
                    plot_envelope(result, envelope_png)
                    answer = b"ok"
            except BaseException:  # noqa: BLE001 - reported to the parent, which raises it
                import traceback

                answer = traceback.format_exc().encode("utf-8", "replace")
            finally:
                try:
                    os.write(done_w, answer)
                finally:
                    os._exit(0)
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        os.close(job_r)
        os.close(done_w)
        self.pid, self._job, self._done = pid, job_w, done_r

    def draw(self, result, transient_png: Path, envelope_png: Path, band=None) -> None:
        """Draw ``result``'s figures into the two paths (in the child when there is one) and wait for them;
        ``band``: the ensemble's trace band for ``transient.png`` (``--uncertainty``)."""
        if self.pid is not None:
            import dataclasses
            import pickle

            job = pickle.dumps((dataclasses.replace(result, characteristics=None), transient_png, envelope_png,
                                band), protocol=pickle.HIGHEST_PROTOCOL)
            try:
                with os.fdopen(self._job, "wb") as pipe:
                    self._job = None
                    pipe.write(job)
                answer = self._answer()
            except BrokenPipeError:  # the child is gone (it could not start matplotlib): draw here
                answer = None
            self._reap()
            if answer == b"ok":
                return
            # the child failed (its traceback is kept in ``failure``): draw here, so that the error, if it is one
            # (e.g. an unwritable file), is raised with its own type for the CLI's message
            self.failure = answer.decode("utf-8", "replace")
        from simulate.results.envelope import plot_envelope

        result.plot(transient_png, band=band)
        plot_envelope(result, envelope_png)

    def _answer(self) -> bytes:
        chunks = []
        while True:
            chunk = os.read(self._done, 65536)
            if not chunk:
                return b"".join(chunks)
            chunks.append(chunk)

    def _reap(self) -> None:
        for fd in (self._job, self._done):
            if fd is not None:
                os.close(fd)
        self._job = self._done = None
        os.waitpid(self.pid, 0)
        self.pid = None

    def close(self) -> None:
        """Stop the child if it is still there (an error or an interrupt before :meth:`draw` finished)."""
        if self.pid is None:
            return
        import signal

        try:
            os.kill(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self._reap()


def write_run_outputs(result, out: Path, *, plot: bool = True, figures: FigureProcess | None = None,
                      band=None) -> list[Path]:
    """Every file of a run, in one place: timeseries.csv, envelope.csv, the figures, summary.json last.

    ``figures``: a :class:`FigureProcess` started earlier (the figures are then drawn there; default: here).
    ``band``: the ensemble's :class:`simulate.studies.uncertainty.TraceBand`, drawn on transient.png."""
    from simulate.results.envelope import plot_envelope, write_envelope_csv

    written = [result.to_csv(out / "timeseries.csv"), write_envelope_csv(result, out / "envelope.csv")]
    if plot:
        if figures is not None:
            figures.draw(result, out / "transient.png", out / "envelope.png", band=band)
        else:
            result.plot(out / "transient.png", band=band)
            plot_envelope(result, out / "envelope.png")
        written += [out / "transient.png", out / "envelope.png"]
    written.append(result.to_json(out / "summary.json"))
    return written


def run_command(args: argparse.Namespace) -> int:
    from simulate.loop.engine import run_simulation

    out = args.outputs.folder("--out", args.out,
                              stale=("transient.png", "envelope.png"))  # checked now, in place at the end
    plant = load_command_plant("run", args.plant, args.overrides)
    if getattr(args, "check_step", False):  # its half-step rerun must be allowed before the first run starts
        from simulate.studies.step_check import check_halving_allowed

        check_halving_allowed(plant)
    reached = [0.0]

    def on_progress(step, n_steps):
        reached[0] = step / n_steps

    figures = None if args.no_plot else FigureProcess()  # imports matplotlib meanwhile (in a child process)
    try:
        progress.start(f"simulating {plant.scenario.kind}, {plant.scenario.t_end_s:g} s")
        try:
            result = run_simulation(plant, raise_on_failure=False, progress=on_progress)
        except KeyboardInterrupt:
            # the CLI turns this into its one-line message and exit 130, discarding the output set
            raise KeyboardInterrupt(f"after {100 * reached[0]:.0f} % of the run") from None
        progress.done()
        ensemble = None
        if getattr(args, "uncertainty", False) and result.success:
            from simulate.studies.uncertainty import run_ensemble

            progress.start("simulating once per ensemble member")
            ensemble = run_ensemble(plant)  # (summary band, trace band): N runs for N members
            progress.done()
        step_check = None
        if getattr(args, "check_step", False) and result.success:
            from simulate.studies.step_check import check_step

            progress.start("simulating again at half the step")
            step_check = check_step(plant, result)
            progress.done()
        write_run_outputs(result, out, plot=not args.no_plot, figures=figures,
                          band=None if ensemble is None else ensemble[1])
    finally:
        if figures is not None:
            figures.close()
    summary = result.summary()
    for line in summary.get("warnings", []):
        print(f"hillsim run: warning: {line}", file=sys.stderr)
    print(f"{plant.scenario.kind}: {summary['steps']} steps of {summary['dt_s']:.6g} s, "
          f"max speed rise {100 * summary['max_speed_rise']:.2f} %, max head rise "
          f"{100 * summary['max_head_rise']:.2f} %, min head drop {100 * summary['min_head_drop']:.2f} %, "
          f"mean iterations {summary['mean_iterations']:.2f}; wrote {args.out}")
    if summary.get("max_reverse_speed_rpm") is not None:  # a unit whose characteristics' kind can reverse
        print(four_quadrant_line(summary))
    if ensemble is not None:
        _add_uncertainty(ensemble[0], out / "summary.json")
    if step_check is not None:
        _add_step_check(step_check, out / "summary.json")
    if summary.get("frequency_recovery_time_s") is not None:  # the sub-transient generator after a load change
        print(f"frequency back within +-{summary['frequency_recovery_band_hz']} Hz of rated "
              f"{summary['frequency_recovery_time_s']:.2f} s after the load change at "
              f"{summary['frequency_event_time_s']:g} s (nadir {summary['min_frequency_hz']:.3f} Hz)")
    if not result.success:
        args.outputs.commit()  # the series up to the failure are a result too
        raise_message = f"{result.message} (series up to the failure written to {args.out})"
        from hillchart.errors import NumericalError
        raise NumericalError(raise_message)
    return 0


def four_quadrant_line(summary: dict) -> str:
    """The run's line of the four-quadrant figures (:func:`simulate.results.reversal.reversal_figures`).

    Examples
    --------
    >>> print(four_quadrant_line({"max_reverse_speed_rpm": 0.0, "max_reverse_speed_pct": 0.0,
    ...                           "max_reverse_flow_m3_s": 10.05, "t_flow_reversal_s": 5.69, "t_runaway_s": None}))
    four-quadrant: max reverse speed 0.0 r/min (0.00 % of rated), max reverse flow 10.05 m^3/s, first flow \
reversal at 5.69 s, no runaway (the vanes moved or no speed peak)
    """
    def at(value, what):
        return f"{what} at {value:.2f} s" if value is not None else None

    reversal = at(summary["t_flow_reversal_s"], "first flow reversal") or "no flow reversal"
    runaway = at(summary["t_runaway_s"], "runaway (first speed peak)") or "no runaway (the vanes moved or no speed " \
                                                                         "peak)"
    return (f"four-quadrant: max reverse speed {summary['max_reverse_speed_rpm']:.1f} r/min "
            f"({summary['max_reverse_speed_pct']:.2f} % of rated), max reverse flow "
            f"{summary['max_reverse_flow_m3_s']:.2f} m^3/s, {reversal}, {runaway}")


def _add_step_check(check: dict, summary_path: Path) -> None:
    """The comparison of :func:`simulate.studies.step_check.check_step` goes into summary.json and onto stdout."""
    import json

    from hillchart.io.tidy import tidy_floats

    print(f"step check: dt = {check['dt_s']:.6g} s against dt = {check['half_dt_s']:.6g} s; largest change "
          f"{check['max_change_points']:.3g} points of percent")
    for name, fig in check["figures"].items():
        print(f"  {name}: {fig['value']:.6g} -> {fig['half_step']:.6g} (change {fig['change']:+.3g} {fig['unit']})")
    summary = json.loads(summary_path.read_text(encoding="utf-8"))
    summary["step_check"] = tidy_floats(check)
    summary_path.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def _add_uncertainty(band: dict, summary_path: Path) -> None:
    """The band of :func:`simulate.studies.uncertainty.run_ensemble` goes into summary.json (and one line on stdout)."""
    import json

    summary = json.loads(summary_path.read_text(encoding="utf-8"))
    from hillchart.io.tidy import tidy_floats

    summary["uncertainty"] = tidy_floats(band)
    summary_path.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    for line in band.get("warnings", []):
        print(f"hillsim run: warning: {line}", file=sys.stderr)
    print(f"ensemble of {band['members']} ({len(band['failed'])} failed): max speed rise "
          f"{100 * band['max_speed_rise']['low']:.2f}-{100 * band['max_speed_rise']['high']:.2f} %, max head rise "
          f"{100 * band['max_head_rise']['low']:.2f}-{100 * band['max_head_rise']['high']:.2f} %, min head drop "
          f"{100 * band['min_head_drop']['low']:.2f}-{100 * band['min_head_drop']['high']:.2f} % (5-95 %)"
          + ("".join(f", {label} {band[name]['low']:.2f}-{band[name]['high']:.2f} {unit}"
                     for name, label, unit in (("min_draft_tube_pressure_head_m", "min draft-tube pressure head",
                                                "m absolute"),
                                               ("max_reverse_speed_pct", "max reverse speed", "% of rated"),
                                               ("max_reverse_flow_m3_s", "max reverse flow", "m^3/s"),
                                               ("t_runaway_s", "runaway at", "s")) if name in band)))
