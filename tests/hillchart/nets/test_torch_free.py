"""Training, loading and evaluating nets must not import torch: torch is a test dependency only (the autograd check of
the compiled Levenberg-Marquardt Jacobian); importing it costs about 1 s of start-up."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]

SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    from data_synthetic import FRANCIS_DIR
    from hillchart.nets.estimator import HillNet
    from hillchart.nets.hill_nets import load_nets
    from hillchart.nets.weights import NetWeights
    from hillchart.linearize import six_coefficients, coefficient_maps
    from hillchart.nets.chartplot import efficiency_from_characteristics
    nets = load_nets(FRANCIS_DIR / "nets.json")
    n, a = np.meshgrid(np.linspace(50, 90, 5), np.linspace(12, 30, 4))
    assert np.all(np.isfinite(nets.q11(n, a))) and np.all(np.isfinite(nets.m11_grad(n, a)[0]))
    assert np.all(np.isfinite(efficiency_from_characteristics(nets, n, a)))
    c = six_coefficients(nets, n11=67.8, opening=23.46)
    assert np.isfinite(c.ex)
    kernel, params = nets.numba_kernel()
    assert np.isfinite(kernel(params, 67.8, 23.46)[0])
    X = np.column_stack([np.linspace(0, 1, 20), np.linspace(0, 1, 20) ** 2])
    HillNet(restarts=1, max_epochs=2).fit(X, X[:, 0] + X[:, 1])
    print("torch" in sys.modules)
    """
)


def test_training_loading_evaluating_and_linearizing_nets_does_not_import_torch():
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=REPO, capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert out.returncode == 0, out.stderr
    # the script prints whether torch got imported; it must not be
    assert out.stdout.strip().splitlines()[-1] == "False", out.stdout


def test_the_check_can_fail_when_torch_is_imported(tmp_path):
    """The same probe reports True once something imports torch (so the test above can fail). A stand-in module
    named torch on the path keeps this check from paying torch's second of import time."""
    (tmp_path / "torch.py").write_text("")
    probe = SCRIPT.strip().splitlines()[-1]
    assert probe == 'print("torch" in sys.modules)'
    script = "import sys\nimport numpy\nimport torch\n" + probe  # the probe of SCRIPT after an import of torch
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(REPO)])))
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "True"
