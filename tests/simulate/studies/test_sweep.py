"""hillsim sweep / simulate.studies.sweep: --vary parsing, cases.csv, results.csv, Dask equals local, garbage
refused."""

import csv
import io
import json
import sys

import pytest

from data_synthetic import PLANT_HLA339
from hillchart.errors import InputError
from hillsim.cli import main
from hillsim.commands.sweep import Progress
from simulate.config import load_plant
from simulate.studies.sweep import DASK_MISSING, build_variants, cartesian, parse_vary, run_batch_dask, run_sweep

PLANT = str(PLANT_HLA339)
SHORT = ["--set", "scenario.t_end_s=5"]  # 5 s of the shipped plant: rejection at 2 s, 3 s of transient


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT_HLA339, {"scenario.t_end_s": 5.0})


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_parse_vary_range_and_list():
    key, values = parse_vary("governor.closing_time_s=4:20:9")
    assert key == "governor.closing_time_s" and values == [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0]
    assert parse_vary("x.y=5:1:3")[1] == [5.0, 3.0, 1.0]  # descending ranges are allowed
    assert parse_vary("x.y=7:7:1")[1] == [7.0]
    assert parse_vary(" x.y = 1e2, 160 ")[1] == [100.0, 160.0]
    assert len(cartesian([("a.b", [1.0, 2.0, 3.0]), ("c.d", [1.0, 2.0])])) == 6


@pytest.mark.parametrize("text,message", [
    ("governor.kp", "--vary expects KEY=START:STOP:COUNT or KEY=v1,v2"),
    ("=1,2", "the key before '=' is empty"),
    ("governor.kp=", "no values after '='"),
    ("governor.kp=1:2", "three fields"),
    ("governor.kp=1:2:3:4", "three fields"),
    ("governor.kp=a:2:3", "START: 'a' is not a number"),
    ("governor.kp=1:inf:3", "STOP: 'inf' must be finite"),
    ("governor.kp=1:2:0", "COUNT must be an integer >= 1, got '0'"),
    ("governor.kp=1:2:-3", "COUNT must be an integer >= 1, got '-3'"),
    ("governor.kp=1:2:2.5", "COUNT must be an integer >= 1, got '2.5'"),
    ("governor.kp=1:2:1", "COUNT 1 needs START == STOP"),
    ("governor.kp=2:2:3", "START == STOP gives 3 equal values"),
    ("governor.kp=1,x,3", "value 2: 'x' is not a number"),
    ("governor.kp=1,,3", "value 2: '' is not a number"),
    ("governor.kp=1,2,1", "value 1.0 is repeated"),
    ("governor.kp=1:2:2000000", "COUNT must be <= 1000000"),
])
def test_bad_vary_texts(text, message):
    with pytest.raises(InputError) as info:
        parse_vary(text)
    assert message in str(info.value)


@pytest.mark.parametrize("varies,message", [
    (["governor.kp=1,2", "governor.kp=3,4"], "--vary governor.kp is given more than once"),
    (["governor.kpp=1,2"], "unknown key 'governor.kpp'"),
    (["solver.pressure_loop=1,2"], "varied solver.pressure_loop = '1': solver.pressure_loop must be one of"),
    (["turbine.characteristics=1,2"], "varied turbine.characteristics = '1': turbine.characteristics = '1': nets file"),
    (["scenario.closing_time_s=1,2"], "is not used by scenario.kind = 'load-rejection'"),
    (["governor.kp=1:2:1000", "governor.ki=1:2:1000", "governor.kd=1:2:1001"], "more than 1000000"),
    ([], "a sweep needs at least one --vary"),
])
def test_bad_vary_combinations(plant, varies, message):
    with pytest.raises(InputError) as info:
        build_variants(plant, varies)
    assert message in str(info.value)


@pytest.mark.parametrize("text,message", [
    ("", "is empty"),
    ("governor.kp\n", "has a header but no case rows"),
    ("governor.kp,governor.kp\n1,2\n", "column 'governor.kp' appears more than once"),
    ("governor.kp,\n1,2\n", "column 2 of the header is empty"),
    ("governor.kpp\n1\n", "column 1: unknown key 'governor.kpp'"),
    ("penstock.model\n8\n", "varied penstock.model = '8': penstock.model must be one of"),
    ("governor.kp,governor.ki\n1\n", "row 2: 1 cells, the header has 2"),
    ("governor.kp\n1\nfast\n", "row 3 column 'governor.kp': 'fast' is not a number"),
    ("governor.kp\nnan\n", "must be finite"),
    ("scenario.initial_power_mw,scenario.initial_opening\n100,0.5\n", "cannot both be varied"),
])
def test_bad_cases_csv(tmp_path, plant, text, message):
    path = tmp_path / "cases.csv"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        build_variants(plant, [], path)
    assert message in str(info.value)


def test_cases_csv_from_a_spreadsheet_reads_as_the_plain_one(tmp_path, plant):
    plain = tmp_path / "plain.csv"
    plain.write_text("governor.closing_time_s,scenario.initial_power_mw\n10.5,200\n12,225\n")
    semi = tmp_path / "semi.csv"
    semi.write_bytes("\ufeffgovernor.closing_time_s;scenario.initial_power_mw\r\n10,5;200\r\n\r\n12;225\r\n"
                     .encode("utf-8"))
    with pytest.warns(UserWarning, match="semi.csv': semicolon-separated with decimal commas; read as such"):
        read = build_variants(plant, [], semi)
    assert read == build_variants(plant, [], plain) == [
        {"governor.closing_time_s": 10.5, "scenario.initial_power_mw": 200.0},
        {"governor.closing_time_s": 12.0, "scenario.initial_power_mw": 225.0}]
    # rows are the file's lines, blank ones counted
    bad = tmp_path / "bad.csv"
    bad.write_text("governor.kp\n\n1\nfast\n")
    with pytest.raises(InputError, match="row 4 column 'governor.kp': 'fast' is not a number"):
        build_variants(plant, [], bad)
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("governor.kp;governor.ki\n1.000,5;0,4\n")
    with pytest.raises(InputError, match="semicolon-separated, but the cell '1.000,5' holds both a comma and a point"):
        build_variants(plant, [], mixed)


def test_cases_csv_unreadable_and_not_utf8(tmp_path, plant):
    with pytest.raises(InputError, match="cannot read --cases file"):
        build_variants(plant, [], tmp_path / "missing.csv")
    bad = tmp_path / "latin1.csv"
    bad.write_bytes("governor.kp\n1\n\xe9\n".encode("latin-1"))
    with pytest.raises(InputError, match="is not UTF-8 text"):
        build_variants(plant, [], bad)
    clash = tmp_path / "clash.csv"
    clash.write_text("governor.kp\n1\n")
    with pytest.raises(InputError, match="both a --cases column and a --vary"):
        build_variants(plant, ["governor.kp=1,2"], clash)


def test_cases_csv_times_vary_product(tmp_path, plant):
    path = tmp_path / "cases.csv"
    path.write_text("scenario.initial_power_mw,governor.kp\n100,2\n160,3\n")
    variants = build_variants(plant, ["governor.closing_time_s=8,12"], path)
    assert variants == [{"scenario.initial_power_mw": 100.0, "governor.kp": 2.0, "governor.closing_time_s": 8.0},
                        {"scenario.initial_power_mw": 100.0, "governor.kp": 2.0, "governor.closing_time_s": 12.0},
                        {"scenario.initial_power_mw": 160.0, "governor.kp": 3.0, "governor.closing_time_s": 8.0},
                        {"scenario.initial_power_mw": 160.0, "governor.kp": 3.0, "governor.closing_time_s": 12.0}]


def test_sweep_cli_writes_one_row_per_case_with_failures_as_rows(tmp_path, capsys):
    out = tmp_path / "sweep"
    code = main(["sweep", PLANT, "--vary", "governor.closing_time_s=-4,8,16", "--vary",
                 "scenario.initial_power_mw=100,225", "--out", str(out), *SHORT])
    assert code == 0
    printed = capsys.readouterr().out
    assert "sweep: 6 cases on local cores" in printed and "4 ok, 0 failed, 2 errors" in printed
    rows = read_csv(out / "results.csv")
    assert [r["governor.closing_time_s"] for r in rows] == ["-4.0", "-4.0", "8.0", "8.0", "16.0", "16.0"]
    assert [r["status"] for r in rows] == ["error", "error", "ok", "ok", "ok", "ok"]
    assert "governor.closing_time_s must be in (0.0, 1000.0], got -4.0" in rows[0]["error"]
    for column in ("max_speed_rise", "max_head_m", "min_head_m", "min_pressure_head_m", "extrapolated", "status"):
        assert column in rows[0]
    # the row equals the single run of the same plant (same code path: exact)
    from simulate.loop.engine import run_simulation
    single = run_simulation(load_plant(PLANT_HLA339, {"scenario.t_end_s": 5.0, "governor.closing_time_s": 8.0,
                                                      "scenario.initial_power_mw": 225.0})).summary()
    assert float(rows[3]["max_speed_rise"]) == single["max_speed_rise"]
    assert float(rows[3]["max_head_m"]) == single["max_head_m"]
    info = json.loads((out / "sweep.json").read_text())
    assert info["cases"] == 6 and info["ok"] == 4 and info["error"] == 2
    assert (out / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_cli_varies_integer_keys_as_integers(tmp_path, capsys):
    """--vary values are read as floats; a key that takes an integer refused 8.0 in every case ("must be an
    integer"), and the sweep exited 0. Whole values are now ints, a fraction is refused before anything runs."""
    out = tmp_path / "sweep"
    code = main(["sweep", PLANT, "--vary", "penstock.reaches=6,8", "--vary", "solver.max_iterations=20:50:2",
                 "--vary", "solver.substeps=1,2", "--out", str(out), "--no-plot", *SHORT])
    assert code == 0, capsys.readouterr().err
    rows = read_csv(out / "results.csv")
    assert [(r["penstock.reaches"], r["solver.max_iterations"], r["solver.substeps"]) for r in rows][:3] == \
        [("6", "20", "1"), ("6", "20", "2"), ("6", "50", "1")]
    assert [r["status"] for r in rows] == ["ok"] * 8
    assert rows[0]["max_head_m"] != rows[4]["max_head_m"]  # 6 and 8 reaches: two grids, two results
    # a fraction of an integer key: refused naming the key and the value, nothing written
    code = main(["sweep", PLANT, "--vary", "penstock.reaches=4:5:3", "--out", str(tmp_path / "never"), *SHORT])
    assert code == 2 and not (tmp_path / "never").exists()
    assert capsys.readouterr().err.strip() == ("hillsim sweep: error: value of varied key 'penstock.reaches' must "
                                               "be an integer (the key counts), got 4.5")
    assert build_variants(load_plant(PLANT_HLA339), ["penstock.reaches=8"]) == [{"penstock.reaches": 8}]


def test_sweep_cli_where_every_case_failed_exits_2_with_the_results(tmp_path, capsys):
    """Every case failing used to exit 0 with one summary line; now exit 2 and a one-line error, and the rows with
    each case's error are written (as hillsim run keeps the series of a failed run). Beside it, one case that ran
    is a sweep that succeeded (exit 0) with the failed case a row."""
    out = tmp_path / "sweep"
    code = main(["sweep", PLANT, "--vary", "penstock.reaches=3,4", "--out", str(out), "--no-plot", *SHORT])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip().splitlines()[-1].startswith(
        "hillsim sweep: error: every one of the 2 cases failed, none ran to the end (case 0, error: InputError: "
        "penstock.reaches = 3: segment 0 (L/a = 0.285714 s) would need its wave speed changed by 6.3 %")
    assert err.strip().endswith(f"the error of each case is in {out}/results.csv")
    assert [r["status"] for r in read_csv(out / "results.csv")] == ["error", "error"]
    assert json.loads((out / "sweep.json").read_text())["error"] == 2
    code = main(["sweep", PLANT, "--vary", "penstock.reaches=4,8", "--out", str(tmp_path / "ok"), "--no-plot",
                 *SHORT])
    assert code == 0 and [r["status"] for r in read_csv(tmp_path / "ok" / "results.csv")] == ["error", "ok"]


def test_sweep_cli_over_a_model_choice_groups_the_cases(tmp_path, capsys):
    out = tmp_path / "sweep"
    code = main(["sweep", PLANT, "--vary", "penstock.model=moc,rigid", "--vary", "governor.closing_time_s=8,16",
                 "--out", str(out), *SHORT])
    assert code == 0, capsys.readouterr().err
    rows = read_csv(out / "results.csv")
    assert [r["penstock.model"] for r in rows] == ["moc", "moc", "rigid", "rigid"]
    assert [r["status"] for r in rows] == ["ok"] * 4
    from simulate.loop.engine import run_simulation
    single = run_simulation(load_plant(PLANT_HLA339, {"scenario.t_end_s": 5.0, "penstock.model": "rigid",
                                                      "governor.closing_time_s": 16.0})).summary()
    assert float(rows[3]["max_head_m"]) == single["max_head_m"]  # the rigid group ran the rigid column
    assert float(rows[1]["max_head_m"]) != single["max_head_m"]
    assert (out / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # a categorical axis for the names


@pytest.mark.parametrize("args,message", [
    (["--vary", "penstock.model=moc,lumpy"], "varied penstock.model = 'lumpy': penstock.model must be one of"),
    (["--vary", "governor.kp=1:2:0"], "COUNT must be an integer >= 1"),
    (["--vary", "governor.nonsense=1,2"], "unknown key 'governor.nonsense'"),
    # a misspelt key or one that takes a name, given names: the key is named, not "'moc' is not a number"
    (["--vary", "penstock.modle=moc,rigid"], "unknown key 'penstock.modle'; numeric keys of [penstock]: "
     "penstock.static_head_m, penstock.reaches, penstock.lumped_alpha, penstock.zdomain_feedback, penstock.brunone_k3, "
     "penstock.brunone_viscosity_m2_s, penstock.convolution_viscosity_m2_s, penstock.water_temperature_c, "
     "penstock.atmospheric_pressure_head_m, penstock.cavity_weighting, penstock.gas_void_fraction; keys of [penstock] "
     "that take a name: penstock.model"),
    (["--vary", "generator.model=swing,subtransient"], "varied key 'generator.model' is not numeric (it takes a name "
     "or a table, not a number); of the keys that take a name only penstock.model, scenario.kind, "
     "solver.pressure_loop, turbine.characteristics can be varied"),
    (["--vary", "penstock.model=moc,rigid", "--vary", "governor.kpp=1,x"], "unknown key 'governor.kpp'"),
    (["--vary", "governor.kp=1,b"], "'b' is not a number"),
    (["--vary", "governor.kp=1,2", "--vary", "governor.kp=3"], "given more than once"),
    (["--vary", "governor.kp=1,2", "--scheduler", "slurm"], "--scheduler must be local or dask"),
    (["--vary", "governor.kp=1,2", "--scheduler", "local", "tcp://x:1"], "--scheduler takes local, dask or dask"),
    (["--vary", "governor.kp=1,2", "--workers", "0"], "--workers must be an integer >= 1"),
    (["--vary", "governor.kp=1,2", "--chunk-size", "0"], "--chunk-size must be an integer >= 1"),
    (["--cases", "/nonexistent/cases.csv"], "cannot read --cases file"),
])
def test_sweep_cli_garbage_exits_2_and_writes_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    code = main(["sweep", PLANT, "--out", str(out), *args])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("hillsim sweep: error: ") and message in err
    assert not out.exists()


def test_progress_bar_only_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True
    tty, pipe = Tty(), io.StringIO()
    for stream in (tty, pipe):
        bar = Progress(stream, width=10)
        bar(5, 10)
        bar(10, 10)
    assert tty.getvalue() == "\r[#####.....] 5/10 cases\r[##########] 10/10 cases\n"
    assert pipe.getvalue() == ""


def test_dask_two_worker_local_cluster_gives_identical_results(plant, tmp_path):
    pytest.importorskip("dask.distributed")
    variants = build_variants(plant, ["governor.closing_time_s=6:14:3", "scenario.initial_power_mw=120,225"])
    local = run_sweep(plant, variants, scheduler="local", workers=2)
    dask = run_batch_dask(plant, variants, n_workers=2, processes=False, chunk_size=2)
    assert dask.mechanism == "dask" and dask.workers == 2 and len(dask.cases) == 6
    # identical, not close: the same run_chunk on the same inputs in another worker (results.csv writes repr)
    local.to_csv(tmp_path / "local.csv")
    dask.to_csv(tmp_path / "dask.csv")
    assert (tmp_path / "local.csv").read_text() == (tmp_path / "dask.csv").read_text()
    assert len(set(c.max_head_rise for c in dask.cases)) == 6  # six different cases, not one repeated
    assert all(c.ok for c in dask.cases)


@pytest.mark.slow
def test_sweep_cli_on_dask_equals_the_local_sweep(tmp_path, monkeypatch, capsys):
    pytest.importorskip("dask.distributed")
    import functools

    import simulate.studies.sweep

    # threads of this process instead of worker processes (each would compile the loop: seconds per worker)
    monkeypatch.setattr(simulate.studies.sweep, "run_batch_dask",
                        functools.partial(simulate.studies.sweep.run_batch_dask, processes=False))
    args = ["--vary", "governor.closing_time_s=8:12:3", "--vary", "governor.kp=1.5,2.5", *SHORT, "--no-plot"]
    assert main(["sweep", PLANT, "--out", str(tmp_path / "local"), *args]) == 0
    assert main(["sweep", PLANT, "--out", str(tmp_path / "dask"), "--scheduler", "dask", "--workers", "2",
                 *args]) == 0
    assert "sweep: 6 cases on Dask LocalCluster" in capsys.readouterr().out
    assert (tmp_path / "local" / "results.csv").read_text() == (tmp_path / "dask" / "results.csv").read_text()
    assert json.loads((tmp_path / "dask" / "sweep.json").read_text())["mechanism"] == "dask"


def test_dask_missing_says_how_to_install(plant, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import fails as if not installed
    with pytest.raises(InputError) as info:
        run_batch_dask(plant, [{"governor.kp": 1.0}])
    assert str(info.value) == DASK_MISSING and "pip install 'hillsim[dask]'" in DASK_MISSING
    code = main(["sweep", PLANT, "--vary", "governor.kp=1,2", "--out", "/nonexistent/x", "--scheduler", "dask"])
    assert code == 2 and "pip install 'hillsim[dask]'" in capsys.readouterr().err


def test_dask_bad_scheduler_address(plant):
    pytest.importorskip("dask.distributed")
    with pytest.raises(InputError, match="cannot connect to the Dask scheduler"):
        run_batch_dask(plant, [{"governor.kp": 1.0}], address="tcp://127.0.0.1:9",
                       connect_timeout_s=1.0)
