"""Fast start: what simulating, linearizing and identifying import, and the disk cache.

Each check runs a fresh interpreter, because ``sys.modules`` of the test process holds whatever other tests imported.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[3]
HEAVY = ("torch", "scipy.signal", "matplotlib")


def _modules_after(code: str, tmp_path, env_extra=None) -> dict:
    script = (code + "\nimport json, sys\nprint(json.dumps({m: m in sys.modules for m in " + repr(HEAVY) + "}))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", **(env_extra or {}))
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_simulating_with_ideal_characteristics_imports_no_torch_scipy_signal_or_matplotlib(tmp_path):
    loaded = _modules_after(
        "from data_synthetic import PLANT_HLA339\n"
        "from simulate.config import load_plant\nfrom simulate.loop.engine import run_simulation\n"
        "r = run_simulation(load_plant(PLANT_HLA339, {'turbine.characteristics': 'ideal', 'scenario.t_end_s': 3.0}))\n"
        "r.summary()\n", tmp_path)
    assert loaded == {"torch": False, "scipy.signal": False, "matplotlib": False}


def test_the_same_check_sees_an_import(tmp_path):
    """The check can fail: plotting imports matplotlib, and a plain import of scipy.signal is seen."""
    loaded = _modules_after("import scipy.signal\nimport matplotlib\n", tmp_path)
    assert loaded["scipy.signal"] and loaded["matplotlib"]


def test_simulating_and_linearizing_with_the_shipped_nets_import_no_torch(tmp_path):
    """hillchart.nets.hill_nets evaluates the nets without importing torch."""
    loaded = _modules_after(
        "from data_synthetic import PLANT_HLA339\n"
        "from simulate.config import load_plant\nfrom simulate.loop.engine import run_simulation\n"
        "from simulate.identification.linear_reference import plant_linearization\n"
        "plant = load_plant(PLANT_HLA339, {'scenario.t_end_s': 3.0})\n"
        "run_simulation(plant).summary()\nplant_linearization(plant)\n", tmp_path)
    assert not loaded["torch"] and not loaded["scipy.signal"], loaded


@pytest.mark.slow
def test_second_run_loads_the_loop_from_the_disk_cache(tmp_path):
    """Everything compiled is cached: in a second process numba compiles nothing (no cache miss anywhere)."""
    code = (
        "from data_synthetic import PLANT_HLA339\n"
        "from simulate.config import load_plant\nfrom simulate.loop.engine import run_simulation\n"
        "import numba.core.dispatcher as d\n"
        "misses = []\n"
        "orig = d.Dispatcher._compile_for_args\n"
        "def spy(self, *a, **k):\n"
        "    before = sum(self._cache_misses.values())\n"
        "    out = orig(self, *a, **k)\n"
        "    if sum(self._cache_misses.values()) > before: misses.append(self.py_func.__qualname__)\n"
        "    return out\n"
        "d.Dispatcher._compile_for_args = spy\n"
        "run_simulation(load_plant(PLANT_HLA339, {'turbine.characteristics': 'ideal', 'scenario.t_end_s': 3.0}))\n"
        "print('MISSES', misses)\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               HILLSIM_CACHE_DIR=str(tmp_path / "loops"))
    outputs = []
    for _ in range(2):
        proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
        outputs.append(proc.stdout.strip().splitlines()[-1])
    assert outputs[0] != "MISSES []"  # the first process compiled (the spy sees misses: the check can fail)
    assert outputs[1] == "MISSES []", outputs[1]


def test_identification_imports_no_torch_scipy_signal_or_matplotlib(tmp_path):
    loaded = _modules_after(
        "import numpy as np\nimport simulate.identification.compare\n"
        "from simulate.identification.estimators import RecursiveLeastSquares, SixCoefficientLeastSquares\n"
        "rng = np.random.default_rng(0)\n"
        "RecursiveLeastSquares().fit(rng.normal(size=(50, 2)), rng.normal(size=50))\n"
        "SixCoefficientLeastSquares().fit(rng.normal(size=(50, 3)), rng.normal(size=(50, 2)))\n", tmp_path)
    assert loaded == {"torch": False, "scipy.signal": False, "matplotlib": False}
