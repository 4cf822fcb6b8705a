"""hillsim from Python: the pipeline of ``hillsim demo`` in a few lines (run by tests/hillsim/test_examples.py).

Usage: ``python examples/quickstart.py [OUT_DIR]``
"""

import sys
import warnings
from dataclasses import replace
from pathlib import Path

from data_synthetic import FRANCIS_DIR, PLANT_HLA339
from hillchart.extension.extend import extend_samples
from hillchart.linearize import six_coefficients
from hillchart.nets.hill_nets import load_nets
from hillchart.io.samples import load_chart
from simulate.config import load_plant
from simulate.loop.engine import initial_state, run_simulation

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/quickstart")  # out/ is gitignored
out.mkdir(parents=True, exist_ok=True)

# 1. the digitized chart and its extension (torque from efficiency, runaway / zero-opening / zero-speed samples)
with warnings.catch_warnings():
    warnings.simplefilter("ignore", UserWarning)  # a chart without runaway.csv warns
    chart = load_chart(FRANCIS_DIR)
extended = extend_samples(chart)
extended.to_csv(out / "extended.csv")

# 2. the nets (hillchart.nets.training.train_nets(extended) trains new ones in a few seconds; here: the shipped ones)
nets = load_nets(FRANCIS_DIR / "nets.json")

# 3. the example plant: steady state, then its scenario (100 % load rejection)
plant = load_plant(PLANT_HLA339)
steady = initial_state(plant, nets)
result = run_simulation(plant, characteristics=nets)
result.to_csv(out / "timeseries.csv")
summary = result.summary()

# 4. the six coefficients at the initial operating point
coefficients = six_coefficients(nets, n11=steady.unit_speed_rpm, opening=steady.opening_chart)

print(f"initial opening {steady.stroke:.3f} of stroke, head {steady.head_m:.2f} m")
print(f"max speed rise {summary['max_speed_rise']:.1%}, max head rise {summary['max_head_rise']:.1%}")
print("six coefficients:",
      {k: round(v, 4) for k, v in coefficients.to_dict().items() if k in ("ex", "ey", "eh", "eqx", "eqy", "eqh")})

# the same plant on a rigid penstock, for comparison
rigid = replace(plant, penstock=replace(plant.penstock, model="rigid"))
print(f"rigid water column: max head rise {run_simulation(rigid, characteristics=nets).summary()['max_head_rise']:.1%}")
