"""The harness of ``benchmarks/bench_fault_campaign.py``: the inputs each case gets (copies of the shipped files,
mutated as the case says: :func:`setup_case`, :func:`apply_mutation`), one case run in its own folder with every input
hashed before and after (:func:`run_case`), how it ended (:func:`classify`, :func:`unexpected`), the campaign in
worker processes (:func:`run_campaign`) and its table (:func:`tally`, :func:`table`). The cases themselves are the
script's (and :mod:`fault_campaign_expected`'s, for the cases that state their expected outcome).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

CHART = REPO / "data_synthetic" / "francis"
PLANT = REPO / "data_synthetic" / "plant_hla339.toml"
GUARANTEE = REPO / "data_synthetic" / "plant_hla339_guarantee.toml"
TWO_UNITS = REPO / "data_synthetic" / "plant_two_units.toml"
BULB_PLANT = REPO / "data_synthetic" / "plant_bulb.toml"
BULB_NETS = REPO / "data_synthetic" / "bulb" / "nets.json"
NETS = CHART / "nets.json"
CASE_TIMEOUT_S = 120
SHORT = ["--set", "scenario.t_end_s=2.5"]  # keeps every run that is accepted short (the event is at 2 s)

COMMANDS = ("synth", "extend", "train", "chart", "linearize", "run", "identify", "sweep", "optimize-closure",
            "report", "demo", "fccm")


# ------------------------------------------------------------------------------------------------ shared inputs


def _shared(cache: Path) -> dict:
    """Inputs made once per campaign: a measured series and a model-test table (as the tool writes them)."""
    from hillsim.cli import main

    series = cache / "series.csv"
    if not series.exists():
        run = cache / "steps"
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            main(["run", str(PLANT), "--out", str(run), "--quiet", "--set", 'scenario.kind="opening-steps"',
                  "--set", "scenario.initial_power_mw=180", "--set", "scenario.t_end_s=20"])
            main(["synth", str(cache / "bulb"), "--turbine", "bulb", "--quiet"])
            # the plant's own opening-steps test as the tool runs it by default (60 s)
            main(["run", str(PLANT), "--out", str(cache / "steps60"), "--quiet", "--set",
                  'scenario.kind="opening-steps"'])
        shutil.copy(run / "timeseries.csv", series)
    return {"series": series, "bulb": cache / "bulb", "series60": cache / "steps60" / "timeseries.csv"}


def plant_text(source: Path) -> str:
    """A plant file that names its nets by absolute path (so it can be copied anywhere)."""
    return (source.read_text(encoding="utf-8").replace('"francis/nets.json"', json.dumps(str(NETS)))
            .replace('"bulb/nets.json"', json.dumps(str(BULB_NETS))))


def setup_case(folder: Path, case: dict, shared: dict) -> None:
    """Copy the inputs ``case["inputs"]`` into ``folder`` and apply ``case["mutate"]``."""
    for name in case.get("inputs", ()):
        if name == "plant":
            (folder / "plant.toml").write_text(plant_text(PLANT), encoding="utf-8")
        elif name == "guarantee":
            (folder / "guarantee.toml").write_text(plant_text(GUARANTEE), encoding="utf-8")
        elif name == "two units":
            (folder / "two.toml").write_text(plant_text(TWO_UNITS), encoding="utf-8")
        elif name == "bulb plant":
            (folder / "bulb.toml").write_text(plant_text(BULB_PLANT), encoding="utf-8")
        elif name == "chart":
            shutil.copytree(CHART, folder / "c")
        elif name == "nets":
            shutil.copy(NETS, folder / "nets.json")
        elif name == "series":
            shutil.copy(shared["series"], folder / "s.csv")
        elif name == "series60":
            shutil.copy(shared["series60"], folder / "s60.csv")
        elif name == "bulb":
            shutil.copytree(shared["bulb"], folder / "t")
        elif name == "earlier":  # a committed earlier run holding a file given as an input
            (folder / "r").mkdir()
            shutil.copy(shared["series"], folder / "r" / "timeseries.csv")
            for extra in ("closure.json", "sweep.json", "summary.json"):
                (folder / "r" / extra).write_text("{}\n")
            (folder / "r" / ".hillsim-outputs.json").write_text(json.dumps(
                {"files": ["timeseries.csv", "closure.json", "sweep.json", "summary.json"]}))
    for op in case.get("mutate", ()):
        apply_mutation(folder, op)


def apply_mutation(folder: Path, op: tuple) -> None:
    kind, rel = op[0], op[1]
    path = folder / rel
    if kind == "write":  # replace the whole file
        data = op[2]
        path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    elif kind == "prepend":
        path.write_bytes((op[2] if isinstance(op[2], bytes) else op[2].encode()) + path.read_bytes())
    elif kind == "append":
        path.write_bytes(path.read_bytes() + (op[2] if isinstance(op[2], bytes) else op[2].encode()))
    elif kind == "truncate":  # keep a fraction of the bytes
        data = path.read_bytes()
        path.write_bytes(data[:int(len(data) * op[2])])
    elif kind == "replace":  # text replacement (first occurrence, or every one with op[4])
        text = path.read_text(encoding="utf-8")
        path.write_text(text.replace(op[2], op[3]) if len(op) > 4 else text.replace(op[2], op[3], 1),
                        encoding="utf-8")
    elif kind == "line":  # replace line number op[2] (0 = header) by op[3]
        lines = path.read_text(encoding="utf-8").splitlines()
        lines[op[2]] = op[3]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "cell":  # set column op[2] of data row op[3] to op[4] in a CSV
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        cells = lines[op[3]].split(",")
        cells[header.index(op[2])] = op[4]
        lines[op[3]] = ",".join(cells)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "shift":  # add op[4] to column op[2] of data row op[3] in a CSV
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        cells = lines[op[3]].split(",")
        j = header.index(op[2])
        cells[j] = f"{float(cells[j]) + op[4]:.5f}"
        lines[op[3]] = ",".join(cells)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    elif kind == "column":  # scale a numeric CSV column by op[3]
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        j = header.index(op[2])
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            cells[j] = repr(float(cells[j]) * op[3])
            out.append(",".join(cells))
        path.write_text("\n".join(out) + "\n", encoding="utf-8")
    elif kind == "noise":  # relative sensor noise op[2] (normal, seed op[3]) on every column but time and iterations
        import numpy as np

        rng = np.random.default_rng(op[3])
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        noisy = [j for j, name in enumerate(header) if name not in ("time_s", "iterations")]
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            for j in noisy:
                cells[j] = repr(float(cells[j]) * (1.0 + op[2] * rng.standard_normal()))
            out.append(",".join(cells))
        path.write_text("\n".join(out) + "\n", encoding="utf-8")
    elif kind == "rows":  # repeat the data rows of a CSV until it holds op[2] of them
        lines = path.read_text(encoding="utf-8").splitlines()
        rows = lines[1:]
        path.write_text("\n".join([lines[0]] + [rows[i % len(rows)] for i in range(op[2])]) + "\n", encoding="utf-8")
    elif kind == "json_scale":  # multiply every number of a (nested) list at a dotted key path by op[3]
        doc = json.loads(path.read_text(encoding="utf-8"))
        target = doc
        keys = op[2].split(".")
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]

        def scaled(value):
            return [scaled(v) for v in value] if isinstance(value, list) else value * op[3]

        target[keys[-1]] = scaled(target[keys[-1]])
        path.write_text(json.dumps(doc), encoding="utf-8")
    elif kind == "remove":
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()
    elif kind == "mkdir":
        path.mkdir(parents=True, exist_ok=True)
    elif kind == "json":  # set a key path (dotted) in a JSON file
        doc = json.loads(path.read_text(encoding="utf-8"))
        target = doc
        keys = op[2].split(".")
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]
        last = keys[-1]
        if op[3] is REMOVE:
            del target[last]
        elif isinstance(target, list):
            target[int(last)] = op[3]
        else:
            target[last] = op[3]
        path.write_text(json.dumps(doc), encoding="utf-8")
    elif kind == "symlink":
        path.symlink_to(op[2] if os.path.isabs(op[2]) else folder / op[2])
    else:  # pragma: no cover
        raise ValueError(kind)


REMOVE = "<remove>"

#: What a case may state it expects (``expect``): the outcomes that count as handled. An absurd value must be refused
#: (``CLEAN_ERROR``) or named in a warning (``WARNING``, with the text in ``expect_in``): running silently is a
#: failure. Good input must run: ``RAN`` (exit 0; a warning beside, such as a run leaving the digitized region, is no
#: refusal) or ``RAN_QUIET`` (exit 0 without any warning). ``LIMIT_FAIL``: ``hillsim report``'s documented exit 3.
#: Beside ``expect``: ``expect_in`` (texts the output must hold), ``expect_count`` (text -> times it appears),
#: ``expect_files`` (path in the case folder -> text it must hold, "" for any, None for "not written") and
#: ``max_s`` (a refusal that must come before the work, in seconds).
CLEAN_ERROR = ("clean error",)
WARNING = ("warning",)
RAN = ("ran", "warning")
RAN_QUIET = ("ran",)
LIMIT_FAIL = ("limit FAIL (exit 3)",)


def new_case(category, command, argv, inputs=(), mutate=(), **extra) -> dict:
    """One case as :func:`run_case` reads it: its table row (``category``), the command and its ``argv`` (``{D}``
    the case folder), the inputs copied in (:func:`setup_case`), their mutations (:func:`apply_mutation`) and the
    rest (``label``, ``expect`` ..., ``signal``, ``pre``)."""
    return {"category": category, "command": command, "argv": list(argv), "inputs": tuple(inputs),
            "mutate": tuple(mutate), **extra}


# ------------------------------------------------------------------------------------------------ running


class CaseTimeout(BaseException):
    pass


def _alarm(signum, frame):
    raise CaseTimeout()


def _hashes(folder: Path) -> dict:
    out = {}
    for p in folder.rglob("*"):
        try:
            if p.is_file() and not p.is_symlink():
                out[p.relative_to(folder).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
        except OSError:
            pass
    return out


def _output_target(argv: list[str], command: str) -> str | None:
    for option in ("--out", "--map"):
        if option in argv and argv.index(option) + 1 < len(argv):
            return argv[argv.index(option) + 1]
    return argv[1] if command == "synth" and len(argv) > 1 else None


def _replaced_by_design(argv: list[str], command: str, folder: Path) -> Path | None:
    """The output target when nothing else on the command line refers to it (or into it): a command replacing its
    own earlier output there is doing its job. An output that is, holds or lies in an input stays checked."""
    target = _output_target(argv, command)
    if not target or not target.strip():
        return None
    real = Path(os.path.realpath(target if os.path.isabs(target) else folder / target))
    index = argv.index(target) if target in argv else -1
    for i, token in enumerate(argv):
        if i == index or not token.startswith(str(folder)):
            continue
        other = Path(os.path.realpath(token))
        if other == real or real in other.parents or other in real.parents:
            return None
    return real if str(real).startswith(str(folder)) else None


def _under(path: Path, top: Path | None) -> bool:
    if top is None:
        return False
    path = Path(os.path.realpath(path))
    return path == top or top in path.parents


def _drain(fifo: Path):
    """A reader for a FIFO given as an output (as a shell's process substitution would be)."""
    import threading

    def read():
        with open(fifo, "rb") as handle:
            while handle.read(65536):
                pass

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if ".hillsim-tmp-" in p.name or ".hillsim-lock" in p.name]


def _restore_signals() -> None:
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for name in ("SIGTERM", "SIGHUP", "SIGXCPU"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)


def run_case(case: dict, root: Path, shared: dict) -> dict:
    from hillsim.cli import main

    folder = Path(tempfile.mkdtemp(dir=root, prefix=f"case{case['id']:05d}-"))
    setup_case(folder, case, shared)
    for op in case.get("pre", ()):
        if op[0] == "fifo":
            os.mkfifo(folder / op[1])
        else:
            (folder / op[1]).symlink_to(op[2].replace("{D}", str(folder)))
    argv = [a.replace("{D}", str(folder)) for a in case["argv"]]
    skip = _replaced_by_design(argv, case["command"], folder)
    before = {k: v for k, v in _hashes(folder).items() if not _under(folder / k, skip)}
    readers = [_drain(folder / op[1]) for op in case.get("pre", ()) if op[0] == "fifo"]
    out, err = io.StringIO(), io.StringIO()
    result = {"id": case["id"], "category": case["category"], "command": case["command"],
              "label": case.get("label", ""), "argv": argv}
    start = time.perf_counter()
    if "signal" in case:
        code, text = _run_signal_case(argv, folder, case["signal"])
        err.write(text)
    else:
        old_cwd = os.getcwd()
        os.chdir(folder)  # relative outputs (``--out ''``) land in the case folder
        signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(CASE_TIMEOUT_S)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = main(argv)
        except CaseTimeout:
            code = "hang"
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except BaseException:  # noqa: BLE001 - an escaped exception is what the campaign counts
            err.write(traceback.format_exc())
            code = "exception"
        finally:
            signal.alarm(0)
            os.chdir(old_cwd)
            _restore_signals()
    result["seconds"] = round(time.perf_counter() - start, 3)
    for reader in readers:
        reader.join(timeout=1.0)
    after = _hashes(folder)
    result["damaged"] = [name for name, digest in before.items() if after.get(name) != digest]
    result["leftovers"] = _leftovers(folder)
    stderr = err.getvalue()
    stdout = out.getvalue()
    result["code"] = code
    result["last_line"] = (stderr.strip().splitlines() or [""])[-1][:300]
    result["outcome"] = classify(code, stdout, stderr, case)
    result["unexpected"] = unexpected(case, result, stdout + stderr, folder)
    shutil.rmtree(folder, ignore_errors=True)
    return result


def unexpected(case: dict, result: dict, text: str, folder: Path) -> list[str]:
    """What a case that states its expected outcome (see :data:`CLEAN_ERROR`) did otherwise; empty when it did
    what it expects, or states nothing."""
    reasons = []
    if "expect" in case and result["outcome"] not in case["expect"]:
        reasons.append(f"expected {' or '.join(case['expect'])}, got {result['outcome']}")
    reasons += [f"the output lacks {needle!r}" for needle in case.get("expect_in", ()) if needle not in text]
    reasons += [f"{needle!r} appears {text.count(needle)} times, expected {count}"
                for needle, count in case.get("expect_count", {}).items() if text.count(needle) != count]
    for rel, needle in case.get("expect_files", {}).items():
        path = folder / rel
        if needle is None:
            if path.exists():
                reasons.append(f"{rel} written")
        elif not path.is_file():
            reasons.append(f"{rel} not written")
        elif needle not in path.read_text(encoding="utf-8", errors="replace"):
            reasons.append(f"{rel} lacks {needle!r}")
    if "max_s" in case and result["seconds"] > case["max_s"]:
        reasons.append(f"took {result['seconds']:.1f} s, expected at most {case['max_s']} s")
    return reasons


def _run_signal_case(argv, folder: Path, plan) -> tuple:
    name, delay, repeat = plan
    sig = getattr(signal, name)
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-m", "hillsim.cli", *argv], cwd=folder, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    for _ in range(repeat):
        if proc.poll() is None:
            proc.send_signal(sig)
            time.sleep(0.05)
    try:
        _, stderr = proc.communicate(timeout=CASE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, stderr = proc.communicate()
        return "hang", stderr
    code = proc.returncode
    return (code if code >= 0 else f"killed by {-code}"), stderr


def classify(code, stdout: str, stderr: str, case: dict) -> str:
    if code == "hang":
        return "hang"
    if code == "exception" or "Traceback (most recent call last)" in stderr:
        return "traceback"
    lines = [line for line in stderr.splitlines() if line.strip()]
    if "signal" in case:
        sig = getattr(signal, case["signal"][0])
        expected = 130 if sig == signal.SIGINT else 128 + int(sig)
        if code == expected:
            return "clean signal end"
        if code == 0:  # the run finished before the signal
            return "ran"
        return "other exit"
    if code == 2:
        last = lines[-1] if lines else ""
        if last.startswith(f"hillsim {case['command']}: error:") or last.startswith("hillsim: error:"):
            return "clean error"
        return "other exit"
    if code == 0:
        return "warning" if "warning" in (stdout + stderr).lower() else "ran"
    if code == 3 and case["command"] == "report" and lines and lines[-1].startswith("hillsim report: FAIL: "):
        return "limit FAIL (exit 3)"  # a guarantee limit failed: the report is written and the exit says so
    return "other exit"


def _worker_init():
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_one(args):
    case, root, shared = args
    try:
        return run_case(case, Path(root), shared)
    except BaseException as exc:  # noqa: BLE001 - a setup failure is reported, not hidden
        return {"id": case["id"], "category": case["category"], "command": case["command"],
                "label": case.get("label", ""), "argv": case["argv"], "code": "setup",
                "outcome": "campaign setup failure", "damaged": [], "leftovers": [], "unexpected": [],
                "seconds": 0.0,
                "last_line": f"{type(exc).__name__}: {exc}"}


OUTCOMES = ("clean error", "warning", "ran", "limit FAIL (exit 3)", "clean signal end", "traceback", "hang",
            "other exit", "campaign setup failure")
COLUMNS = ("cases", "clean error", "warning", "ran", "limit FAIL (exit 3)", "clean signal end", "traceback", "hang",
           "other exit", "lost or damaged input", "left temporaries", "unexpected outcome")


def tally(results: list[dict]) -> dict:
    """Category -> Counter of the table's columns (a case counts once per outcome, and once more for a damaged
    input, left temporaries or an unexpected outcome)."""
    by_cat = defaultdict(Counter)
    for r in results:
        by_cat[r["category"]][r["outcome"]] += 1
        by_cat[r["category"]]["cases"] += 1
        by_cat[r["category"]]["lost or damaged input"] += bool(r["damaged"])
        by_cat[r["category"]]["left temporaries"] += bool(r["leftovers"])
        by_cat[r["category"]]["unexpected outcome"] += bool(r.get("unexpected"))
    return by_cat


def to_look_at(results: list[dict]) -> list[dict]:
    """The cases that did not end as a campaign case must: a traceback, a hang, an undocumented exit, a setup
    failure, a damaged input, left temporaries or an outcome other than the one the case expects."""
    return [r for r in results if r["outcome"] in ("traceback", "hang", "other exit", "campaign setup failure")
            or r["damaged"] or r["leftovers"] or r.get("unexpected")]


def table(results: list[dict]) -> str:
    by_cat = tally(results)
    columns = COLUMNS
    lines = ["| category | " + " | ".join(columns) + " |", "|---|" + "---:|" * len(columns)]
    total = Counter()
    for cat in sorted(by_cat):
        total.update(by_cat[cat])
        lines.append(f"| {cat} | " + " | ".join(str(by_cat[cat][c]) for c in columns) + " |")
    lines.append("| **all** | " + " | ".join(f"**{total[c]}**" for c in columns) + " |")
    commands = Counter(r["command"] for r in results)
    lines.append("")
    lines.append("Cases per command: " + ", ".join(f"{c} {commands[c]}" for c in COMMANDS) + ".")
    return "\n".join(lines)


def run_campaign(cases: list[dict], workers: int = 2) -> tuple[list[dict], float]:
    """Run ``cases`` in ``workers`` processes, each in its own folder below a temporary root (removed after);
    return their results in case order and the wall time in seconds."""
    root = Path(tempfile.mkdtemp(prefix="hillsim-campaign-"))
    start = time.perf_counter()
    try:
        shared = _shared(root / "shared")
        ctx = multiprocessing.get_context("fork")
        with ctx.Pool(processes=max(1, workers), initializer=_worker_init, maxtasksperchild=200) as pool:
            results = list(pool.imap_unordered(_run_one, [(c, str(root), shared) for c in cases], chunksize=1))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    results.sort(key=lambda r: r["id"])
    return results, time.perf_counter() - start
