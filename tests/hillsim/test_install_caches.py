"""Compiled code is cached in the user's cache folder, never beside the installed package; a cache-only folder that
an earlier installation left in site-packages is ignored with one line (the README's two commands in one venv)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: A stand-in for an editable install's finder: the project's packages from the checkout, found after the path
#: finder (as setuptools' editable finder is), so that a folder on sys.path can shadow them.
EDITABLE = textwrap.dedent(f"""
    import importlib.util, sys
    from pathlib import Path
    ROOT = Path({str(ROOT)!r})
    class Editable:
        @classmethod
        def find_spec(cls, name, path=None, target=None):
            if name not in ("hillsim", "hillchart", "simulate", "data_synthetic"):
                return None
            init = ROOT / name / "__init__.py"
            return importlib.util.spec_from_file_location(name, init, submodule_search_locations=[str(init.parent)])
    sys.path[:] = [p for p in sys.path if p not in ("", ".", str(ROOT))]
    sys.meta_path.append(Editable)
""")


def _run(code: str, tmp_path: Path, **env) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    environ.update(env)
    return subprocess.run([sys.executable, "-c", EDITABLE + textwrap.dedent(code)], cwd=tmp_path, env=environ,
                          capture_output=True, text=True, timeout=300)


def _leftover_site(tmp_path: Path) -> Path:
    """site-packages after ``pip install .``, a run, and ``pip install -e .``: cache files and no __init__.py."""
    site = tmp_path / "site"
    for package in ("simulate/components/turbine", "hillchart/nets"):
        cache = site / package / "__pycache__"
        cache.mkdir(parents=True)
        (cache / "boundary.turbine_signals-189.py311.nbi").write_bytes(b"stale")
    return site


def test_numba_caches_in_the_user_cache_folder(tmp_path):
    run = _run("""
        import simulate.components.schedules, numba, os
        print(os.environ["NUMBA_CACHE_DIR"])
        print(numba.config.CACHE_DIR)
    """, tmp_path, HILLSIM_CACHE_DIR=str(tmp_path / "cache"))
    assert run.returncode == 0, run.stderr
    env_dir, config_dir = run.stdout.split()
    # one folder per installation, under the hillsim cache: version and a hash of the installed location
    assert env_dir == config_dir and Path(env_dir).parent == tmp_path / "cache" / "numba"
    assert Path(env_dir).name.startswith("0.1.0-")
    # a NUMBA_CACHE_DIR the user set is kept
    run = _run("import hillchart, os; print(os.environ['NUMBA_CACHE_DIR'])", tmp_path, NUMBA_CACHE_DIR="/mine")
    assert run.stdout.split() == ["/mine"]


@pytest.mark.slow
def test_a_compiled_function_writes_its_cache_outside_the_package(tmp_path):
    # a real compile through the engine's own path: a short simulation of the shipped plant
    sim = _run("""
        from simulate.config import load_plant
        from simulate.loop.engine import run_simulation
        from data_synthetic import PLANT_HLA339
        run_simulation(load_plant(PLANT_HLA339, {"scenario.t_end_s": 2.5}))
    """, tmp_path, HILLSIM_CACHE_DIR=str(tmp_path / "cache"))
    assert sim.returncode == 0, sim.stderr
    written = list((tmp_path / "cache").rglob("*.nbi"))
    assert len(written) > 10  # the components' and the loop's indexes
    assert not any(str(p).startswith(str(ROOT)) for p in written)


def test_a_leftover_cache_folder_is_ignored_with_one_line(tmp_path):
    site = _leftover_site(tmp_path)
    code = f"""
        import sys
        sys.path.insert(0, {str(site)!r})
        import hillsim.cli
        from simulate.components.registry import PENSTOCKS
        import simulate, hillchart
        assert simulate.__file__ and hillchart.__file__
        print("ok", PENSTOCKS is not None)
    """
    run = _run(code, tmp_path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["ok", "True"]
    lines = run.stderr.strip().splitlines()
    # one line per shadowing folder, naming it and what to do
    assert len(lines) == 2 and all("earlier installation" in line and "safe to delete" in line for line in lines)
    assert str(site / "simulate") in run.stderr and str(site / "hillchart") in run.stderr
    # nothing was deleted: the files are the user's to remove
    assert len(list(site.rglob("*.nbi"))) == 2


def test_without_the_guard_the_leftover_folder_hides_the_package(tmp_path):
    """The failing case: importing the simulator before hillsim takes the leftover folder for the package."""
    site = _leftover_site(tmp_path)
    run = _run(f"""
        import sys
        sys.path.insert(0, {str(site)!r})
        from simulate.components.registry import PENSTOCKS
    """, tmp_path)
    assert run.returncode != 0 and "No module named 'simulate.components.registry'" in run.stderr


def _tree(root: Path, kernel: str, plain: str) -> Path:
    for package in ("hillchart", "simulate"):
        (root / package).mkdir(parents=True, exist_ok=True)
    (root / "simulate" / "kernels.py").write_text(kernel, encoding="utf-8")
    (root / "hillchart" / "plain.py").write_text(plain, encoding="utf-8")
    return root


def test_the_cache_folder_follows_the_compiled_modules_contents(tmp_path):
    """numba checks a cached function against its own file only, not against the functions of other files it
    compiles in: the folder's key changes with the content of any module that uses numba, and with nothing else."""
    from hillchart.cache import kernel_stamp

    root = _tree(tmp_path, "import numba\nA = 1\n", "B = 1\n")
    before = kernel_stamp(root)
    _tree(root, "import numba\nA = 1\n", "B = 2\n")  # a module without compiled code: the same folder
    assert kernel_stamp(root) == before
    _tree(root, "import numba\nA = 2\n", "B = 2\n")  # a compiled module edited: another folder
    assert kernel_stamp(root) != before and len(kernel_stamp(root)) == 8


def test_folders_of_earlier_contents_are_removed_a_day_after_their_last_write(tmp_path):
    from hillchart.cache import STALE_AFTER_S, remove_stale

    numba_dir = tmp_path / "numba"
    names = ("0.1.0-aaaa1111-cafe0001", "0.1.0-aaaa1111-cafe0002", "0.1.0-aaaa1111-cafe0003", "0.1.0-bbbb2222-cafe0002",
             "0.1.0-aaaa1111")
    current, old, young, elsewhere, legacy = (numba_dir / name for name in names)
    for folder in (current, old, young, elsewhere, legacy):
        folder.mkdir(parents=True)
    now = 1e9
    for folder, age in ((current, 2.0), (old, 1.5), (young, 0.5), (elsewhere, 2.0), (legacy, 3.0)):
        os.utime(folder, (now - age * STALE_AFTER_S, now - age * STALE_AFTER_S))
    assert sorted(remove_stale(current, now=now)) == [legacy, old]  # an earlier content, and the key without one
    # the current folder however old, one written within the day (a running process's), another location's: kept
    assert sorted(p.name for p in numba_dir.iterdir()) == sorted(p.name for p in (current, young, elsewhere))
