"""Bad input and faults that once lost data, extrapolated silently, refused good input or ended in a traceback.

Each destructive case checks that every input is intact afterwards (bytes compared); each former traceback is a
one-line ``hillsim CMD: error: ...`` with exit code 2. Where it helps, the refused case sits beside the accepted one.
"""

import argparse
import hashlib
import json
import os
import shutil
import signal
import stat
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from hillchart.errors import InputError
from hillsim.cli import main, run_command
from hillsim.outputs import MANIFEST, OutputSet
from tests.scripts import load_script

REPO = Path(__file__).resolve().parents[2]
CHART = REPO / "data_synthetic" / "francis"
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"


def _digest(folder: Path) -> dict:
    """Relative path -> sha256 of every file below ``folder`` (or of ``folder`` itself when it is a file)."""
    if folder.is_file():
        return {"": hashlib.sha256(folder.read_bytes()).hexdigest()}
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if ".hillsim-tmp-" in p.name or ".hillsim-lock" in p.name)


def _one_line_error(err: str, command: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err
    assert lines and lines[-1].startswith(f"hillsim {command}: error: "), err
    return lines[-1]


def _earlier_run(folder: Path, files: dict) -> None:
    """A folder as a committed hillsim run leaves it: the files and the manifest listing them."""
    folder.mkdir()
    for name, text in files.items():
        (folder / name).write_text(text)
    (folder / MANIFEST).write_text(json.dumps({"files": sorted(files)}))


# ------------------------------------------------------------------------------ outputs never destroy inputs


def test_identify_out_holding_its_data_is_refused_and_the_data_kept(tmp_path, capsys):
    run = tmp_path / "r"
    _earlier_run(run, {"timeseries.csv": "time_s,speed_rpm\n0,200\n", "summary.json": "{}"})
    before = _digest(run)
    code = main(["identify", str(PLANT), "--data", str(run / "timeseries.csv"), "--out", str(run), "--quiet"])
    line = _one_line_error(capsys.readouterr().err, "identify")
    assert code == 2 and "--out" in line and "--data" in line and "timeseries.csv" in line
    assert _digest(run) == before and _leftovers(tmp_path) == []


@pytest.mark.parametrize("option, name", [("--closure", "closure.json"), ("--sweep", "sweep.json")])
def test_report_out_that_is_its_closure_or_sweep_folder_is_refused(tmp_path, capsys, option, name):
    results = tmp_path / "results"
    _earlier_run(results, {name: "{}", "results.csv": "a\n1\n"})
    before = _digest(results)
    code = main(["report", str(PLANT), option, str(results), "--out", str(results), "--quiet"])
    line = _one_line_error(capsys.readouterr().err, "report")
    assert code == 2 and f"is the input {option}" in line
    assert _digest(results) == before and _leftovers(tmp_path) == []


def test_extend_onto_its_own_flow_csv_is_refused_and_the_chart_kept(tmp_path, capsys):
    chart = tmp_path / "c"
    shutil.copytree(CHART, chart)
    before = _digest(chart)
    code = main(["extend", str(chart), "--out", str(chart / "flow.csv"), "--quiet"])
    line = _one_line_error(capsys.readouterr().err, "extend")
    assert code == 2 and "flow.csv" in line and "read" in line
    assert _digest(chart) == before and _leftovers(tmp_path) == []
    # beside it, a new file in the chart folder is fine
    assert main(["extend", str(chart), "--out", str(chart / "extended.csv"), "--quiet"]) == 0
    assert (chart / "extended.csv").is_file() and _digest(chart) == {**before, "extended.csv": ANY}


def test_train_onto_its_own_flow_csv_is_refused_before_training(tmp_path, capsys, monkeypatch):
    """train trained, printed "wrote" and only then refused; now it stops once the chart is read, naming the input,
    and the chart is intact. Beside it, nets.json in the chart folder (not an input of train) is written."""
    import hillchart.nets.training as training

    chart = tmp_path / "c"
    shutil.copytree(CHART, chart)
    (chart / "nets.json").unlink()
    before = _digest(chart)
    trained = []
    real_train = training.train_nets
    monkeypatch.setattr(training, "train_nets", lambda *a, **k: trained.append(1) or real_train(*a, **k))
    code = main(["train", str(chart), "--out", str(chart / "flow.csv"), "--quiet"])
    captured = capsys.readouterr()
    line = _one_line_error(captured.err, "train")
    assert code == 2 and trained == [] and "wrote" not in captured.out + captured.err
    assert line == (f"hillsim train: error: --out '{chart / 'flow.csv'}' is the input '{chart / 'flow.csv'}' this "
                    f"command read; choose another output (nothing was written)")
    assert _digest(chart) == before and _leftovers(tmp_path) == []
    assert main(["train", str(chart), "--out", str(chart / "nets.json"), "--quiet"]) == 0 and trained == [1]
    assert _digest(chart) == {**before, "nets.json": ANY}


class _Any:
    def __eq__(self, other):
        return True


ANY = _Any()


def test_an_input_beside_its_results_is_allowed_but_not_one_an_earlier_run_wrote(tmp_path):
    run = tmp_path / "run"
    _earlier_run(run, {"timeseries.csv": "x\n"})
    (run / "plant.toml").write_text("[x]\n")  # the user's own file, in no manifest: a commit never touches it
    OutputSet(inputs=[("PLANT_TOML", run / "plant.toml")]).folder("--out", run)
    with pytest.raises(InputError, match=r"--out '.*run' holds the input --data '.*timeseries.csv'"):
        OutputSet(inputs=[("--data", run / "timeseries.csv")]).folder("--out", run)
    with pytest.raises(InputError, match=r"--out '.*a.csv' is the input --data"):
        OutputSet(inputs=[("--data", tmp_path / "a.csv")]).file("--out", tmp_path / "a.csv") if \
            (tmp_path / "a.csv").write_text("x") else None


def test_an_output_options_own_earlier_value_is_not_an_input(tmp_path):
    (tmp_path / "e.csv").write_text("old")
    outputs = OutputSet(inputs=[("--out", tmp_path / "e.csv")])
    outputs.file("--out", tmp_path / "e.csv").write_text("new")
    outputs.commit()
    assert (tmp_path / "e.csv").read_text() == "new"


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="POSIX device nodes")
def test_a_device_or_fifo_output_is_written_in_place_never_replaced(tmp_path):
    outputs = OutputSet()
    assert outputs.file("--out", "/dev/null") == Path("/dev/null")  # written directly, no temporary
    outputs.commit()
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    outputs = OutputSet()
    assert outputs.file("--out", fifo) == fifo
    outputs.commit()
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and _leftovers(tmp_path) == []


def test_a_symlink_output_replaces_its_target_not_the_link(tmp_path):
    (tmp_path / "real.csv").write_text("old")
    (tmp_path / "link.csv").symlink_to(tmp_path / "real.csv")
    outputs = OutputSet()
    outputs.file("--out", tmp_path / "link.csv").write_text("new")
    outputs.commit()
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_text() == "new"


@pytest.mark.parametrize("argv, word", [
    (["extend", str(CHART), "--out", ""], "argument --out: is empty"),
    (["synth", ""], "argument OUT_DIR: is empty"),
    (["run", str(PLANT), "--out", "  "], "argument --out: is empty"),  # --out is a Path there: Path("") is "."
    (["extend", str(CHART), "--out", "e.csv/"], "ends with '/'"),
])
def test_empty_or_folder_like_output_names_are_errors(tmp_path, monkeypatch, capsys, argv, word):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(argv)
    except SystemExit as exc:  # a usage error from the parser
        code = exc.code
    assert code == 2
    assert word in _one_line_error(capsys.readouterr().err, argv[0])
    assert list(tmp_path.iterdir()) == []


def test_an_empty_output_is_still_refused_by_the_output_set(tmp_path):
    with pytest.raises(InputError, match="--out is empty"):
        OutputSet().file("--out", "")
    with pytest.raises(InputError, match="--out is empty"):
        OutputSet().folder("--out", " ")


def _args(func, command="fake") -> argparse.Namespace:
    return argparse.Namespace(command=command, func=func, quiet=True)


@pytest.mark.parametrize("sig", [s for s in (getattr(signal, "SIGHUP", None), getattr(signal, "SIGXCPU", None),
                                             signal.SIGTERM) if s is not None])
def test_hangup_and_cpu_limit_end_like_sigterm_and_leave_nothing(tmp_path, capsys, sig):
    previous = signal.signal(sig, signal.SIG_DFL)  # as in a terminal (the test runner may ignore SIGHUP, as nohup)

    def func(args):
        out = args.outputs.folder("--out", tmp_path / "run")
        (out / "timeseries.csv").write_text("partial")
        signal.raise_signal(sig)
        return 0

    try:
        assert run_command(_args(func)) == 128 + int(sig)
    finally:
        signal.signal(sig, previous)
    assert "terminated; no outputs written" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
def test_a_run_under_nohup_survives_the_terminal_closing(tmp_path, capsys):
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # what nohup does
    try:
        def func(args):
            (args.outputs.folder("--out", tmp_path / "run") / "a.csv").write_text("done")
            signal.raise_signal(signal.SIGHUP)  # the terminal closes: ignored, the run goes on
            return 0

        assert run_command(_args(func)) == 0
    finally:
        signal.signal(signal.SIGHUP, previous)
    assert (tmp_path / "run" / "a.csv").read_text() == "done"


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_second_signal_during_the_cleanup_is_recorded_not_raised(tmp_path, capsys, monkeypatch, sig, code):
    real_discard = OutputSet.discard

    def discard_hit_again(self):
        signal.raise_signal(sig)  # the user presses Ctrl-C again while the temporaries are removed
        real_discard(self)

    monkeypatch.setattr(OutputSet, "discard", discard_hit_again)

    def func(args):
        (args.outputs.folder("--out", tmp_path / "run") / "a.csv").write_text("partial")
        signal.raise_signal(sig)
        return 0

    assert run_command(_args(func)) == code
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("hillsim fake:") == 1
    assert list(tmp_path.iterdir()) == []
    for s in (signal.SIGINT, signal.SIGTERM):  # the CLI leaves the repeat ignored; restore for the next tests
        signal.signal(s, signal.default_int_handler if s == signal.SIGINT else signal.SIG_DFL)


def test_stale_temporaries_of_a_dead_run_are_removed_and_others_kept(tmp_path):
    stale_file = tmp_path / ".e.hillsim-tmp-abcd1234.csv"
    stale_folder = tmp_path / ".run.hillsim-tmp-abcd1234"
    other = tmp_path / ".e.hillsim-tmp-abcd1234.png"  # another output's temporary: not ours to remove
    stale_file.write_text("x" * 100)
    stale_folder.mkdir()
    (stale_folder / "timeseries.csv").write_text("x")
    other.write_text("x")
    outputs = OutputSet()
    outputs.file("--out", tmp_path / "e.csv")
    outputs.folder("--dir", tmp_path / "run")
    assert not stale_file.exists() and not stale_folder.exists() and other.exists()
    outputs.discard()


def test_temporaries_of_a_live_writer_are_kept(tmp_path):
    first = OutputSet()
    temporary = first.file("--out", tmp_path / "e.csv")
    with pytest.raises(InputError, match="being written by another hillsim process|same file"):
        OutputSet().file("--out", tmp_path / "e.csv")
    assert temporary.exists()
    first.discard()


@pytest.mark.parametrize("mask, file_mode, folder_mode", [(0o022, 0o644, 0o755), (0o077, 0o600, 0o700)])
def test_outputs_follow_the_umask(tmp_path, mask, file_mode, folder_mode):
    old = os.umask(mask)
    try:
        outputs = OutputSet()
        outputs.file("--out", tmp_path / "e.csv").write_text("x")
        (outputs.folder("--dir", tmp_path / "run") / "a.csv").write_text("x")
        outputs.commit()
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "e.csv").st_mode) == file_mode
    assert stat.S_IMODE(os.stat(tmp_path / "run").st_mode) == folder_mode


def test_the_same_file_through_a_symlinked_folder_is_named_as_such(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    outputs = OutputSet()
    outputs.file("--out", tmp_path / "real" / "e.csv")
    with pytest.raises(InputError, match="is also given as --out") as info:
        outputs.file("--plot", tmp_path / "alias" / "e.csv")
    assert "another hillsim process" not in str(info.value)
    outputs.discard()


def test_a_full_disk_names_the_output_even_when_the_error_names_no_file(tmp_path, capsys):
    def func(args):
        args.outputs.folder("--out", tmp_path / "run")
        raise OSError(28, "No space left on device")  # as a write() into an open file raises it

    assert run_command(_args(func)) == 2
    line = _one_line_error(capsys.readouterr().err, "fake")
    assert f"--out '{tmp_path / 'run'}'" in line and "No space left on device" in line


# ------------------------------------------------------------------------------ extrapolation is never silent


def _nets_with_region(tmp_path: Path, region: bool) -> Path:
    from hillchart.nets.hill_nets import load_nets
    from hillchart.io.samples import load_chart
    from simulate.loop.domain import convex_hull

    nets = load_nets(CHART / "nets.json")
    nets.digitized_region = None  # nets written before the region was recorded in nets.json
    if region:
        chart = load_chart(CHART)
        nets.digitized_region = convex_hull(np.column_stack((chart.flow_n11, chart.flow_opening)))
    path = tmp_path / "elsewhere" / "nets.json"
    path.parent.mkdir()
    nets.save(path)
    return path


def test_nets_json_round_trips_the_digitized_region_and_validates_it(tmp_path):
    from hillchart.nets.hill_nets import HillNets, load_nets

    path = _nets_with_region(tmp_path, region=True)
    back = load_nets(path)
    assert back.digitized_region.shape[1] == 2 and len(back.digitized_region) >= 3
    assert HillNets.from_json(back.to_json()).to_json() == back.to_json()
    doc = json.loads(path.read_text())
    doc["digitized_region"] = [[1.0, 2.0], [3.0, float("nan")]]
    with pytest.raises(InputError, match="digitized_region must be a list of at least 3"):
        HillNets.from_dict(doc)


def _run_warnings(tmp_path: Path, capsys, name: str, *extra: str) -> str:
    code = main(["run", str(PLANT), "--out", str(tmp_path / name), "--quiet", "--set", "scenario.t_end_s=8", *extra])
    assert code == 0
    return capsys.readouterr().err


def test_a_run_with_nets_outside_the_chart_folder_warns_exactly_as_inside(tmp_path, capsys):
    inside = _run_warnings(tmp_path, capsys, "inside")
    assert "outside the digitized region of the chart for 32.1 % of the time from t = 5.45 s" in inside
    nets = _nets_with_region(tmp_path, region=True)  # as hillsim train writes it: the region inside nets.json
    assert _run_warnings(tmp_path, capsys, "outside", "--set", f"turbine.characteristics=\"{nets}\"") == inside
    # nets written before the region was recorded, away from their chart: the run says it cannot judge
    old = _nets_with_region(tmp_path / "old", region=False) if (tmp_path / "old").mkdir() is None else None
    err = _run_warnings(tmp_path, capsys, "old", "--set", f"turbine.characteristics=\"{old}\"")
    assert "the digitized region of the chart is unknown" in err and "retrain" in err


def test_report_warns_only_for_kinds_the_run_entered(tmp_path):
    from simulate.studies.batch import extrapolation_kinds
    from simulate.loop.domain import TrustedDomain, extrapolation_record

    domain = TrustedDomain((0.0, 130.0), (0.0, 32.0), np.array([[40.0, 5.0], [110.0, 5.0], [110.0, 30.0],
                                                                [40.0, 30.0]]), "flow.csv")
    t = np.linspace(0.0, 10.0, 11)
    inside = extrapolation_record(domain, t, np.full(11, 70.0), np.full(11, 20.0), np.full(11, 0.5))
    assert extrapolation_kinds(inside) == {}  # checked, intervals_s, training ranges are not kinds
    opening = np.where(t >= 5.0, 1.0, 20.0)  # below the digitized region from t = 5 s
    outside = extrapolation_record(domain, t, np.full(11, 70.0), opening, np.full(11, 0.5))
    assert extrapolation_kinds(outside) == {"digitized_region": pytest.approx(0.6)}  # 6 of 10 steps end outside


# ------------------------------------------------------------------------------ good input is not refused


def test_an_opening_steps_series_with_sensor_noise_passes_the_series_checks():
    from simulate.config import load_plant
    from simulate.loop.engine import run_simulation
    from simulate.identification.series_checks import check_measured_table

    plant = load_plant(PLANT, {"scenario.kind": "opening-steps", "scenario.initial_power_mw": 180.0,
                               "scenario.opening_steps": [0.05, -0.05], "scenario.step_times_s": [2.0, 6.0],
                               "scenario.t_end_s": 10.0})
    r = run_simulation(plant)
    columns = {k: np.asarray(getattr(r, k), dtype=float)
               for k in ("time_s", "speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s")}
    rows = np.arange(2, r.time_s.size + 2)
    check_measured_table("steps.csv", columns, rows, sample_time_s=0.05)  # the physical torque jump: no outlier
    rng = np.random.default_rng(0)
    noisy = {k: (v if k == "time_s" else v * (1 + 1e-3 * rng.standard_normal(v.size))) for k, v in columns.items()}
    check_measured_table("noisy.csv", noisy, rows, sample_time_s=0.05)  # 0.1 % sensor noise: no outlier
    spiked = dict(columns, torque_nm=columns["torque_nm"].copy())
    spiked["torque_nm"][100] = 0.0  # a dropout is still caught
    with pytest.raises(InputError, match="torque_nm.*isolated outlier"):
        check_measured_table("spiked.csv", spiked, rows, sample_time_s=0.05)


def test_the_default_opening_steps_series_with_sensor_noise_passes_and_a_dropout_is_still_caught():
    """The plant's own opening-steps series (60 s) with 0.1 % noise was refused as holding isolated outliers: the speed
    barely moves, so the floor (a quarter of the window medians' range, 0.35 r/min) was below the noise (0.2 r/min)
    and a 7-sample window's MAD often far below it. The column's noise (from successive differences) now bounds the
    floor; the physical torque jump persists, so the window median follows it and it is never flagged."""
    from simulate.config import load_plant
    from simulate.identification.series_checks import check_measured_table, hampel_outliers
    from simulate.loop.engine import run_simulation

    r = run_simulation(load_plant(PLANT, {"scenario.kind": "opening-steps"}))
    columns = {k: np.asarray(getattr(r, k), dtype=float)
               for k in ("time_s", "speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s")}
    rows = np.arange(2, r.time_s.size + 2)
    rng = np.random.default_rng(0)
    noisy = {k: (v if k == "time_s" else v * (1 + 1e-3 * rng.standard_normal(v.size))) for k, v in columns.items()}
    check_measured_table("noisy.csv", noisy, rows, sample_time_s=0.2)
    jump = int(np.flatnonzero(np.abs(np.diff(columns["opening"])) > 1e-3)[0]) + 1  # the torque jumps with the vanes
    assert abs(columns["torque_nm"][jump] - columns["torque_nm"][jump - 1]) > 1e5
    assert hampel_outliers(noisy["torque_nm"]).size == 0 and hampel_outliers(noisy["speed_rpm"]).size == 0
    for column, value in (("speed_rpm", 150.0), ("torque_nm", 1e308), ("torque_nm", 0.0)):
        spiked = dict(noisy, **{column: noisy[column].copy()})
        spiked[column][jump + 1] = value  # beside the physical jump, a dropout or spike is still an outlier
        with pytest.raises(InputError, match=rf"column '{column}': isolated outlier\(s\) at row {jump + 3} "):
            check_measured_table("spiked.csv", spiked, rows, sample_time_s=0.2)


def test_a_byte_order_mark_is_accepted_in_sweep_cases(tmp_path):
    from simulate.config import load_plant
    from simulate.studies.sweep import build_variants

    plant = load_plant(PLANT)
    cases = tmp_path / "cases.csv"
    cases.write_bytes("\ufeffgovernor.closing_time_s\n8\n10\n".encode("utf-8"))
    assert [v["governor.closing_time_s"] for v in build_variants(plant, [], cases)] == [8.0, 10.0]


def test_a_byte_order_mark_is_accepted_in_fccm_tables(tmp_path):
    from hillchart.fccm.table import load_test_table

    table = tmp_path / "bulb"
    assert main(["synth", str(table), "--turbine", "bulb", "--quiet"]) == 0
    plain = load_test_table(table)
    for name in ("table.csv", "table.toml"):
        path = table / name
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    with_bom = load_test_table(table)
    assert with_bom.n_rows == plain.n_rows and with_bom.info == plain.info


# ------------------------------------------------------------------------------ one-line errors, not tracebacks


@pytest.mark.parametrize("content, word", [
    (b"# caf\xe9\n", "byte 0xe9 at offset 5"),                    # a Latin-1 byte in a comment
    ("[turbine]\n".encode("utf-16"), "UTF-16"),                   # Notepad's "Unicode"
    (b"\x7fELF\x02\x01\x01\x00\x00\x00\x00\xff\xfe", "binary"),    # not text at all
])
def test_a_plant_file_not_in_utf8_is_a_one_line_error(tmp_path, capsys, content, word):
    plant = tmp_path / "plant.toml"
    plant.write_bytes(content + (PLANT.read_bytes() if word.startswith("byte") else b""))
    assert main(["run", str(plant), "--out", str(tmp_path / "run")]) == 2
    line = _one_line_error(capsys.readouterr().err, "run")
    assert word in line and "save it as UTF-8" in line and "plant.toml" in line


@pytest.mark.parametrize("value", ['["m3/s"]', '{unit = "m3/s"}'])
def test_a_chart_unit_given_as_a_list_or_table_is_a_one_line_error(tmp_path, capsys, value):
    chart = tmp_path / "c"
    shutil.copytree(CHART, chart)
    text = (chart / "chart.toml").read_text()
    (chart / "chart.toml").write_text("\n".join(f"q11_unit = {value}" if line.startswith("q11_unit") else line
                                                for line in text.splitlines()) + "\n")
    assert main(["extend", str(chart), "--out", str(tmp_path / "e.csv")]) == 2
    assert "q11_unit must be a string" in _one_line_error(capsys.readouterr().err, "extend")


def test_an_oversized_csv_cell_is_a_one_line_error(tmp_path, capsys):
    chart = tmp_path / "c"
    shutil.copytree(CHART, chart)
    lines = (chart / "flow.csv").read_text().splitlines()
    lines[1] += "x" * 200_000  # over the csv module's 128 KiB field limit, as a 20 MB cell is
    (chart / "flow.csv").write_text("\n".join(lines) + "\n")
    assert main(["extend", str(chart), "--out", str(tmp_path / "e.csv")]) == 2
    line = _one_line_error(capsys.readouterr().err, "extend")
    assert "flow.csv" in line and "field limit" in line


@pytest.mark.parametrize("command", ["chart", "run", "linearize", "run-bulb"])
def test_a_nets_json_nested_200000_deep_is_a_one_line_error_in_every_command(tmp_path, capsys, command):
    """chart refused it already; run and linearize first asked the file whether it holds three-input nets with
    their own json.loads, which raised RecursionError. Now every nets.json is read by one function."""
    nets = tmp_path / "nets.json"
    nets.write_text("[" * 200_000 + "]" * 200_000)
    before = _digest(tmp_path)
    chars = ["--set", f"turbine.characteristics={json.dumps(str(nets))}"]
    argv = {"chart": ["chart", str(nets), "--out", str(tmp_path / "c.png")],
            "run": ["run", str(PLANT), "--out", str(tmp_path / "r"), *chars],
            "linearize": ["linearize", str(nets), "--plant", str(PLANT), "--stroke", "0.6"],
            "run-bulb": ["run", str(REPO / "data_synthetic" / "plant_bulb.toml"), "--out", str(tmp_path / "r"),
                         *chars]}[command]
    assert main(argv + ["--quiet"]) == 2
    line = _one_line_error(capsys.readouterr().err, argv[0])
    assert line.endswith(f"{nets}: nested too deeply to be a nets file (a NET block is 2 levels deep)")
    assert _digest(tmp_path) == before and _leftovers(tmp_path) == []


@pytest.mark.parametrize("seed", ["-1", "4294967296"])
def test_a_seed_outside_numpys_range_is_a_one_line_error(tmp_path, capsys, seed):
    code = main(["optimize-closure", str(PLANT), "--out", str(tmp_path / "o"), "--seed", seed])
    line = _one_line_error(capsys.readouterr().err, "optimize-closure")
    assert code == 2 and f"--seed must be an integer in [0, 4294967295], got {seed}" in line
    assert list(tmp_path.iterdir()) == []


def test_pool_workers_drop_the_cli_signal_handlers():
    from simulate.studies.batch import _worker_signals

    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        signal.signal(signal.SIGTERM, lambda *a: None)  # as the CLI's handler would be, inherited by fork
        _worker_signals()
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # a terminated worker ends quietly
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # Ctrl-C is the parent's to handle
    finally:
        for s, h in saved.items():
            signal.signal(s, h)


# ------------------------------------------------------------------------------ guards against absurd input


def test_identify_tau_is_bounded_by_the_memory_it_needs():
    from simulate.identification.experiment import ExperimentSettings

    ExperimentSettings(sample_time_s=0.2)  # the default: 2 111 samples
    with pytest.raises(InputError, match=r"sample_time_s = 1e-06 s .* 4.22e\+08 samples, about .* GiB .* --tau"):
        ExperimentSettings(sample_time_s=1e-6)


def test_a_huge_sweep_is_estimated_and_refused_unless_asked(tmp_path, capsys):
    code = main(["sweep", str(PLANT), "--vary", "governor.kp=1:2:100000", "--out", str(tmp_path / "sw"), "--quiet"])
    line = _one_line_error(capsys.readouterr().err, "sweep")
    assert code == 2 and "100000 cases" in line and "--allow-large" in line and list(tmp_path.iterdir()) == []


def test_a_small_sweep_prints_its_estimate_and_the_final_folder(tmp_path, capsys):
    code = main(["sweep", str(PLANT), "--vary", "governor.kp=1,2", "--out", str(tmp_path / "sw"), "--quiet",
                 "--no-plot", "--workers", "1", "--set", "scenario.t_end_s=2.5"])
    out = capsys.readouterr().out
    assert code == 0 and "2 cases on local cores (about 131 time steps each" in out
    assert f"to {tmp_path / 'sw'}" in out and "hillsim-tmp" not in out


def test_workers_are_capped_at_the_cores(capsys):
    from hillsim.commands.sweep import cap_workers
    from simulate.studies.batch import default_workers

    assert cap_workers(1) == 1 and cap_workers(None) is None
    assert cap_workers(10**6) == default_workers()
    assert f"--workers 1000000 is more than the {default_workers()} core(s) available" in capsys.readouterr().err


@pytest.mark.parametrize("k, ok", [("0.002", True), ("1e300", False)])
def test_an_absurd_zero_opening_k_is_refused_naming_a_plausible_bound(tmp_path, capsys, k, ok):
    code = main(["extend", str(CHART), "--out", str(tmp_path / "e.csv"), "--quiet", "--zero-opening-k", k])
    if ok:
        assert code == 0
        return
    line = _one_line_error(capsys.readouterr().err, "extend")
    assert code == 2 and "zero_opening_k = 1e+300" in line and "a plausible K is below" in line


@pytest.mark.parametrize("unit, value, ok", [("mm", 32.0, True), ("mm", 1e5, False), ("deg", 120.0, False),
                                             ("%", 100.0, True)])
def test_an_implausible_opening_max_is_refused(unit, value, ok):
    from hillchart.io.samples import ChartInfo

    make = lambda: ChartInfo(name="t", opening_unit=unit, opening_max=value, q11_unit="m3/s",  # noqa: E731
                             efficiency_unit="fraction")
    if ok:
        make()
    else:
        with pytest.raises(InputError, match=rf"opening_max = {value!r} {unit} is implausible"):
            make()


def _chart_with(tmp_path: Path, row: int, column: str, value: str) -> Path:
    chart = tmp_path / "c"
    shutil.copytree(CHART, chart)
    lines = (chart / "efficiency.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    (chart / "efficiency.csv").write_text("\n".join(lines) + "\n")
    return chart


def test_an_efficiency_contour_at_one_warns_and_a_contour_point_at_standstill_is_refused(tmp_path):
    from hillchart.io.samples import load_chart

    with pytest.warns(UserWarning, match=r"efficiency.csv: row 3: efficiency 1.0 is implausible"):
        load_chart(_chart_with(tmp_path / "a", 2, "efficiency", "1.000"))
    with pytest.raises(InputError, match=r"row 3, column 'n11': 0.0 is out of range; allowed n11 > 0 on an "
                                         r"efficiency contour"):
        load_chart(_chart_with(tmp_path / "b", 2, "n11", "0"))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped chart: no warning
        load_chart(CHART)


def test_a_series_with_a_hole_is_refused_and_a_regular_one_passes():
    from simulate.identification.series_checks import check_time

    t = np.arange(0.0, 20.0, 0.02)
    rows = np.arange(2, t.size + 2)
    check_time("s.csv", t, rows, sample_time_s=0.2)
    holed = np.where(t > 10.0, t + 100.0, t)
    with pytest.raises(InputError, match=r"jumps by 100.02 s from row 502 to row 503 .* a hole in the record"):
        check_time("s.csv", holed, rows, sample_time_s=0.2)


def test_a_series_in_minutes_or_from_another_plant_is_refused():
    from types import SimpleNamespace

    from simulate.config import load_plant
    from simulate.identification.series_checks import check_against_plant, check_duration_against_plant

    plant = load_plant(PLANT)
    check_duration_against_plant("s.csv", np.arange(0.0, 20.0, 0.02), plant)  # 20 s: fine
    with pytest.raises(InputError, match=r"spans 0.333 s, less than half.*inertia_time_s = 9 s.*is time in "
                                         r"minutes \(then it spans 19.98 s\)"):
        check_duration_against_plant("s.csv", np.arange(0.0, 20.0, 0.02) / 60.0, plant)
    point = SimpleNamespace(speed_rpm=200.0, head_m=176.0, flow_m3_s=110.0, torque_nm=8.6e6)
    check_against_plant("s.csv", point, plant)
    with pytest.raises(InputError, match=r"starts at 500 r/min, 2.5 x the plant's rated 200 r/min; a unit under "
                                         r"test runs at 0.7 to 1.4 x rated"):
        check_against_plant("s.csv", SimpleNamespace(**{**vars(point), "speed_rpm": 500.0}), plant)
    # another plant's series: head 2 x the rated 176 m (inside the 0.2-5 x rated), 352 / 180 = 1.95556 x the static
    with pytest.raises(InputError, match=r"column 'head_m' starts at 352 m, 1\.95556 x the plant's "
                                         r"penstock\.static_head_m = 180 m; a unit's net head lies at 0\.5 to 1\.2 x "
                                         r"the static head: is this the plant the data come from"):
        check_against_plant("s.csv", SimpleNamespace(**{**vars(point), "head_m": 352.0}), plant)


@pytest.mark.parametrize("column, factor, word", [("flow_m3_s", 1000.0, "flow in l/s"),
                                                  ("power_kw", 1000.0, "power in W"),
                                                  ("blade_angle_deg", np.pi / 180, "radians"),
                                                  ("head_m", 9.81, "head in kPa (divide by 9.81"),
                                                  ("head_m", 9810.0, "head in Pa (divide by 9810")])
def test_model_test_tables_in_other_units_warn(tmp_path, column, factor, word):
    from hillchart.fccm.table import load_test_table

    table = tmp_path / "t"
    assert main(["synth", str(table), "--turbine", "bulb", "--quiet"]) == 0
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_test_table(table)  # as written: no warning
    lines = (table / "table.csv").read_text().splitlines()
    j = lines[0].split(",").index(column)
    scaled = [lines[0]] + [",".join(repr(float(c) * factor) if i == j else c for i, c in enumerate(line.split(",")))
                           for line in lines[1:]]
    (table / "table.csv").write_text("\n".join(scaled) + "\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_test_table(table)
    # one column in another unit: one warning, naming that column (a flow in l/s once also blamed the power)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert column in str(caught[0].message) and word in str(caught[0].message)


def test_a_table_with_flow_and_power_both_in_other_units_warns_of_both(tmp_path):
    from hillchart.fccm.table import unit_warnings

    flow = np.array([1.0, 1.2, 1.4])
    head = np.array([15.0, 16.0, 17.0])
    q11 = flow / (0.4 ** 2 * np.sqrt(head))
    power_kw = 0.85 * 9.81 * flow * head  # efficiency 0.85
    assert unit_warnings({"q11_m3_s": q11, "flow_m3_s": flow, "power_kw": power_kw, "head_m": head}, "t") == []
    # the flow in l/s alone: the power is right against the flow in m^3/s
    alone = unit_warnings({"q11_m3_s": 1e3 * q11, "flow_m3_s": 1e3 * flow, "power_kw": power_kw, "head_m": head},
                          "t")
    assert len(alone) == 1 and "flow in l/s" in alone[0]
    # flow in l/s and power in W: both
    both = unit_warnings({"q11_m3_s": 1e3 * q11, "flow_m3_s": 1e3 * flow, "power_kw": 1e3 * power_kw,
                          "head_m": head}, "t")
    assert len(both) == 2 and "flow in l/s" in both[0] and "power in W" in both[1], both
    assert "efficiency P / (rho g Q H) = 850 with the flow divided by 1000" in both[1], both


def test_a_low_head_rigs_head_in_kpa_warns_from_the_efficiency_column():
    """A 4 m rig's head in kPa (39) is below the 100 m any double-regulated turbine stays under: the efficiency
    column, 9.81 x above P / (rho g Q H), tells it."""
    from hillchart.fccm.table import unit_warnings

    flow, head, eff = np.array([0.3, 0.35, 0.4]), np.array([3.8, 4.0, 4.2]), np.array([0.84, 0.86, 0.85])
    power_kw = eff * 9.81 * flow * head
    columns = {"flow_m3_s": flow, "head_m": head, "efficiency": eff, "power_kw": power_kw}
    assert unit_warnings(columns, "t") == []  # in metres: no warning
    (line,) = unit_warnings({**columns, "head_m": 9.81 * head}, "t")
    # median P / (rho g Q H) = 0.85 / 9.81 = 0.086646: exact to the 4 digits shown
    assert "median efficiency P / (rho g Q H) = 0.08665, 9.81 x below the efficiency column's 0.85" in line, line
    assert "is the head in kPa (divide by 9.81" in line


def test_an_efficiency_outlier_in_a_model_test_table_warns_naming_the_row(tmp_path):
    """One efficiency far from its neighbours' (0.4 below, a typo such as 0.45 for 0.85) is named with its row;
    the table as written and a point 0.03 off (the spread the chart's curvature gives, see EFFICIENCY_OUTLIER)
    are not."""
    import warnings

    from hillchart.fccm.table import load_test_table

    table = tmp_path / "t"
    assert main(["synth", str(table), "--turbine", "bulb", "--quiet"]) == 0
    lines = (table / "table.csv").read_text().splitlines()
    j = lines[0].split(",").index("efficiency")

    def with_efficiency_of_row_41(delta):
        cells = lines[40].split(",")
        cells[j] = f"{float(cells[j]) + delta:.5f}"
        (table / "table.csv").write_text("\n".join(lines[:40] + [",".join(cells)] + lines[41:]) + "\n")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            load_test_table(table)
        return [str(w.message) for w in caught], float(cells[j])

    assert with_efficiency_of_row_41(0.0)[0] == [] and with_efficiency_of_row_41(-0.03)[0] == []
    caught, value = with_efficiency_of_row_41(-0.4)
    assert len(caught) == 1, caught  # the outlier only: its neighbours, fitted with it left out, are not named
    assert f"table.csv: row 41: efficiency {value:.4g} is -0." in caught[0], caught
    departure = float(caught[0].split(" is ")[1].split()[0])
    # -0.4 as written, shifted by the row's own departure from its neighbours' plane (at most 0.033 on this table)
    assert abs(departure + 0.4) < 0.035, caught
    assert "correct the row (a typo?) or remove it" in caught[0]


# ------------------------------------------------------------------------------ messages that help


def _guarantee(tmp_path: Path, load_case_extra: str) -> Path:
    text = (REPO / "data_synthetic" / "plant_hla339_guarantee.toml").read_text()
    text = text.replace('"francis/nets.json"', json.dumps(str(CHART / "nets.json")))
    text = text.replace('name = "rated load"\nscenario.initial_power_mw = 225.0',
                        f'name = "rated load"\n{load_case_extra}')
    path = tmp_path / "g.toml"
    path.write_text(text)
    return path


def test_a_draft_tube_that_does_not_fit_the_step_names_the_draft_tube_not_one_reach(tmp_path, capsys):
    """A Francis plant with [draft_tube] of 30 m (L/a 0.03 s against dt 0.019 s) was told "penstock.reaches = 1" (the
    placeholder of the draft tube's mirrored section) though the plant has 8; the message names the draft tube's
    segment and the plant's real penstock.reaches. Beside it, a 38 m draft tube (2 reaches within 0.4 %) runs."""
    draft = ('\n[draft_tube]\nmodel = "moc"\nrunner_elevation_m = -4.0\n\n[[draft_tube.segments]]\n'
             'length_m = {length}\ndiameter_m = 5.5\nwave_speed_m_s = 1000.0\ndarcy_friction = 0.014\n')
    base = PLANT.read_text().replace('"francis/nets.json"', json.dumps(str(CHART / "nets.json")))
    plant = tmp_path / "plant.toml"
    plant.write_text(base + draft.format(length=30.0))
    argv = ["run", str(plant), "--set", "scenario.t_end_s=2.5", "--no-plot", "--quiet", "--out"]
    assert main(argv + [str(tmp_path / "r")]) == 2
    assert _one_line_error(capsys.readouterr().err, "run") == (
        "hillsim run: error: [draft_tube]: draft_tube.segments: segment 0 (L/a = 0.03 s) would need its wave speed "
        "changed by 21.3 % to fit 2 reaches of dt = 0.0190678 s; at most 5 % is allowed: the step is the plant's "
        "(penstock.reaches = 8); change penstock.reaches or the draft tube's length_m or wave_speed_m_s")
    plant.write_text(base + draft.format(length=38.0))
    assert main(argv + [str(tmp_path / "ok")]) == 0, capsys.readouterr().err


def test_a_load_case_out_of_range_names_the_load_case_and_key(tmp_path, capsys):
    plant = _guarantee(tmp_path, "scenario.initial_power_mw = 225.0\ngovernor.closing_time_s = -1")
    assert main(["report", str(plant), "--out", str(tmp_path / "rep"), "--quiet"]) == 2
    line = _one_line_error(capsys.readouterr().err, "report")
    assert "load_cases[0] ('rated load', setting governor.closing_time_s" in line and "got -1.0" in line


@pytest.mark.parametrize("command", ["report", "optimize-closure"])
def test_an_unreachable_load_case_power_names_the_load_case_and_the_largest_power(tmp_path, capsys, command):
    plant = _guarantee(tmp_path, "scenario.initial_power_mw = 300.0")
    assert main([command, str(plant), "--out", str(tmp_path / "o"), "--quiet", "--max-speed-rise", "0.5"][
                :None if command == "optimize-closure" else 5]) == 2
    line = _one_line_error(capsys.readouterr().err, command)
    # 249.1 MW: the power the unit gives at full stroke and rated head (the steady-state solve)
    assert "load case 'rated load' (setting scenario.initial_power_mw)" in line and "249.1" in line
    assert list((tmp_path).glob("o*")) == []


@pytest.mark.parametrize("overrides, word", [
    ({"governor.closing_time_s": 0.001}, "governor.closing_time_s = 0.001 s is implausibly short"),
    ({"turbine.rated_power_mw": "eta=1"}, "rated efficiency P_r/(rho g Q_r H_r) = 1 "),
    ({}, None),
])
def test_implausible_plant_values_warn_naming_the_value(overrides, word):
    from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
    from simulate.config import load_plant
    from simulate.loop.guards import plausibility_warnings

    if overrides.get("turbine.rated_power_mw") == "eta=1":  # exactly 1: P_r = rho g Q_r H_r
        overrides = {"turbine.rated_power_mw": RHO_WATER_KG_M3 * G_M_S2 * 142.5 * 176.0 / 1e6}
    warnings = plausibility_warnings(load_plant(PLANT, overrides))
    if word is None:
        assert warnings == []  # the shipped plant: closing 12 s, rated efficiency 0.915
    else:
        assert len(warnings) == 1 and word in warnings[0]


def test_the_campaign_page_matches_the_campaign_cases():
    """docs/reliability-campaign.md holds the output of benchmarks/bench_fault_campaign.py: the same number of cases
    as the script defines now, and no traceback, hang, damaged input or unexpected outcome (the page is regenerated
    by the command it shows when the cases change)."""
    campaign = _campaign()
    cases = campaign.all_cases()
    assert len(cases) >= 1000 and {c["command"] for c in cases} == set(campaign.COMMANDS)
    page = (REPO / "docs" / "reliability-campaign.md").read_text(encoding="utf-8")
    total = next(line for line in page.splitlines() if line.startswith("| **all** |"))
    cells = [c.strip().strip("*") for c in total.strip("|").split("|")][1:]
    header = next(line for line in page.splitlines() if line.startswith("| category |"))
    names = [c.strip() for c in header.strip("|").split("|")][1:]
    counts = dict(zip(names, map(int, cells)))
    assert counts["cases"] == len(cases)
    assert counts["traceback"] == counts["hang"] == counts["lost or damaged input"] == counts["left temporaries"] == 0
    assert counts["unexpected outcome"] == 0
    assert counts["limit FAIL (exit 3)"] == sum(c.get("expect") == campaign.LIMIT_FAIL for c in cases)
    assert "python benchmarks/bench_fault_campaign.py" in page


def _campaign():
    return load_script("bench_fault_campaign")  # registered: the campaign's workers find its functions by name


@pytest.mark.slow
def test_the_fault_campaign_sample_ends_cleanly_and_as_each_case_expects():
    """The slow tier runs a sample of benchmarks/bench_fault_campaign.py (the whole campaign, over 1000 cases, takes
    about 2-5 minutes on 2 cores; its table is docs/reliability-campaign.md): every case that states its expected
    outcome (former tracebacks, absurd values that must be refused or warned, good input that must run, messages
    that must name the cause, a guarantee study file given to every command) and every 8th other case, signal cases
    aside (their timing against a run's start and end depends on the machine's load). None may end in a traceback,
    a hang, an undocumented exit, a lost or damaged input, left temporaries or an outcome other than the one it
    expects."""
    campaign = _campaign()
    cases = campaign.sample_cases(campaign.all_cases())
    expected = [c for c in cases if "expect" in c]
    assert len(expected) >= 35 and len(cases) >= 150 and not any("signal" in c for c in cases)
    results, _ = campaign.run_campaign(cases, workers=2)
    assert [r["id"] for r in results] == [c["id"] for c in cases]
    total = sum(campaign.tally(results).values(), Counter())
    bad = [f"{r['command']} {r['label']!r}: {r['outcome']} {r.get('unexpected')} {r['last_line']}"
           for r in campaign.to_look_at(results)]
    assert bad == []
    for column in ("traceback", "hang", "other exit", "campaign setup failure", "lost or damaged input",
                   "left temporaries", "unexpected outcome"):
        assert total[column] == 0, column
    # the expectations are met as stated: refusals, warnings, runs and the report's FAIL all occur
    outcomes = Counter(r["outcome"] for r, c in zip(results, cases) if "expect" in c)
    assert outcomes["clean error"] >= 20 and outcomes["warning"] >= 4 and outcomes["ran"] >= 4
    assert outcomes["limit FAIL (exit 3)"] == 1


def test_a_process_pool_sweep_prints_no_worker_traceback(tmp_path):
    """The pool terminates its workers at the end with SIGTERM: workers that kept the CLI's handlers printed a
    ``hillsim.cli.Terminated`` traceback each, even on a successful sweep."""
    import subprocess
    import sys

    from simulate.studies.batch import SERIAL_BELOW, default_workers

    if default_workers() < 2:
        pytest.skip("one core: the sweep runs serially, without a pool")
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-m", "hillsim.cli", "sweep", str(PLANT), "--vary",
                           f"governor.kp=1:3:{SERIAL_BELOW}", "--out", str(tmp_path / "sw"), "--workers", "2",
                           "--no-plot", "--quiet", "--set", "scenario.t_end_s=2.5"],
                          capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "(processes, 2 workers)" in proc.stdout
    assert "Traceback" not in proc.stderr and "Terminated" not in proc.stderr
