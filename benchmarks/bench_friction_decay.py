"""Unsteady friction on the shipped plants: how much halving the step moves the heads, and how fast the oscillation
after a closure decays, with the quasi-steady loss (``penstock.friction_model = "steady"``) and with Brunone's
unsteady friction (``"brunone"``, :mod:`simulate.components.hydraulic.brunone`).

    PYTHONPATH=$PWD python benchmarks/bench_friction_decay.py [--figures DIR]

Step convergence: every shipped plant of one unit whose penstock is MOC, its load rejection as shipped with
``penstock.reaches`` N and 2 N (the step dt and dt / 2, the grid's Courant number 1 either way); the largest and the
smallest head at the turbine of each run and their change, in per cent of the head at N.

Decay: the demo's load rejection (``data_synthetic/plant_hla339.toml``, MOC penstock, governor closing the vanes in
about 8.7 s); once the flow at the turbine is below 1e-3 of its initial value the head rings at the penstock's
periods (4 L / a = 1.7 s for its two segments). The ringing amplitude is the standard deviation of the head at the
turbine over each 10 s after that instant (:func:`window_amplitudes`); its decay is the ratio of the last window's to
the first's and the rate ln(first / last) / (time between the windows' centres), 1/s.

``--figures DIR`` draws ``friction_decay.png``: the head at the turbine over the whole run with both models, and the
last 12 s enlarged.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from simulate.config import load_plant
from simulate.loop.engine import run_simulation

DATA = resources.files("data_synthetic")
DEMO_PLANT = "plant_hla339.toml"
#: The shipped plants of one unit on a MOC penstock (plant_two_units.toml: tests/simulate/loop/test_units_friction.py).
SHIPPED_MOC = ("plant_hla339.toml", "plant_hla339_guarantee.toml", "plant_hla339_grid.toml",
               "plant_hla339_surge_tank.toml", "plant_bulb.toml", "plant_pump_turbine.toml")
FRICTIONS = ("steady", "brunone", "convolution")
#: Length of the windows of the ringing amplitude, s.
WINDOW_S = 10.0
#: The closure is over when the turbine's flow is below this fraction of its initial value.
CLOSED_FRACTION = 1e-3
#: Acceptance: halving the step moves the largest and the smallest head by less than this, per cent.
CONVERGED_PCT = 0.1


def run(plant_name: str, friction: str, reaches: int | None = None, **overrides):
    """The shipped plant ``plant_name`` with ``penstock.friction_model = friction`` (and ``penstock.reaches``)."""
    keys = {"penstock.friction_model": friction, **overrides}
    if reaches is not None:
        keys["penstock.reaches"] = reaches
    return run_simulation(load_plant(DATA / plant_name, keys))


@dataclass(frozen=True)
class Convergence:
    """Largest and smallest head at the turbine (m) at ``reaches`` and at twice as many, and their changes (%)."""

    plant: str
    friction: str
    reaches: int
    dt_s: float
    max_head_m: tuple[float, float]
    min_head_m: tuple[float, float]

    @property
    def max_change_pct(self) -> float:
        return 100.0 * (self.max_head_m[1] / self.max_head_m[0] - 1.0)

    @property
    def min_change_pct(self) -> float:
        return 100.0 * (self.min_head_m[1] / self.min_head_m[0] - 1.0)

    @property
    def converged(self) -> bool:
        return max(abs(self.max_change_pct), abs(self.min_change_pct)) < CONVERGED_PCT


def step_convergence(plant_name: str, friction: str, reaches: int | None = None) -> Convergence:
    """The plant's run at its ``penstock.reaches`` (or ``reaches``) N and at 2 N."""
    n = reaches if reaches is not None else load_plant(DATA / plant_name).penstock.reaches
    coarse, fine = run(plant_name, friction, n), run(plant_name, friction, 2 * n)
    return Convergence(plant_name, friction, n, float(coarse.meta["dt_s"]),
                       (float(coarse.head_m.max()), float(fine.head_m.max())),
                       (float(coarse.head_m.min()), float(fine.head_m.min())))


def closure_end_s(result) -> float:
    """First instant at which the turbine's flow is below :data:`CLOSED_FRACTION` of its initial value, s."""
    closed = np.flatnonzero(np.abs(result.flow_m3_s) < CLOSED_FRACTION * abs(result.flow_m3_s[0]))
    if closed.size == 0:
        raise ValueError("the turbine's flow never falls below 1e-3 of its initial value: no closure to measure "
                         "the ringing after")
    return float(result.time_s[closed[0]])


def window_amplitudes(result) -> tuple[np.ndarray, np.ndarray]:
    """Centres (s) and ringing amplitudes (m: the standard deviation of the head at the turbine) of the whole
    :data:`WINDOW_S` windows after the closure."""
    t, head = result.time_s, result.head_m
    edges = np.arange(closure_end_s(result), t[-1] + 1e-9, WINDOW_S)
    if edges.size < 3:
        raise ValueError(f"the run leaves {edges.size - 1} whole window(s) of {WINDOW_S} s after the closure; "
                         f"at least 2 are needed")
    amplitudes = np.array([np.std(head[(t >= a) & (t < b)]) for a, b in zip(edges[:-1], edges[1:])])
    return 0.5 * (edges[:-1] + edges[1:]), amplitudes


@dataclass(frozen=True)
class Decay:
    """The ringing after the closure: the windows' centres (s) and amplitudes (m), the last over the first, and the
    mean decay rate (1/s)."""

    friction: str
    reaches: int
    centres_s: np.ndarray
    amplitudes_m: np.ndarray

    @property
    def ratio(self) -> float:
        return float(self.amplitudes_m[-1] / self.amplitudes_m[0])

    @property
    def rate_per_s(self) -> float:
        return -math.log(self.ratio) / float(self.centres_s[-1] - self.centres_s[0])


def demo_decay(friction: str, reaches: int | None = None) -> tuple[Decay, object]:
    """The ringing after the demo's load rejection, and the run."""
    result = run(DEMO_PLANT, friction, reaches)
    centres, amplitudes = window_amplitudes(result)
    n = reaches if reaches is not None else load_plant(DATA / DEMO_PLANT).penstock.reaches
    return Decay(friction, n, centres, amplitudes), result


def convergence_table(plants=SHIPPED_MOC) -> str:
    rows = ["| plant | friction | N | dt (s) | max head N / 2N (m) | change | min head N / 2N (m) | change |",
            "|---|---|---|---|---|---|---|---|"]
    for plant in plants:
        for friction in FRICTIONS:
            c = step_convergence(plant, friction)
            rows.append(f"| {plant} | {friction} | {c.reaches} | {c.dt_s:.5f} | {c.max_head_m[0]:.3f} / "
                        f"{c.max_head_m[1]:.3f} | {c.max_change_pct:+.4f} % | {c.min_head_m[0]:.3f} / "
                        f"{c.min_head_m[1]:.3f} | {c.min_change_pct:+.4f} % |")
    return "\n".join(rows) + "\n"


def decay_table(decays: list[Decay]) -> str:
    rows = ["| friction | N | ringing amplitude per 10 s window (m) | last / first | decay rate (1/s) |",
            "|---|---|---|---|---|"]
    for d in decays:
        rows.append(f"| {d.friction} | {d.reaches} | {', '.join(f'{a:.3f}' for a in d.amplitudes_m)} | "
                    f"{d.ratio:.4f} | {d.rate_per_s:.5f} |")
    return "\n".join(rows) + "\n"


def draw(runs: dict, decays: dict, path: Path) -> Path:
    """``friction_decay.png``: the head at the turbine over the run, and its last 12 s, with every model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (whole, tail) = plt.subplots(2, 1, figsize=(9.0, 6.5))
    styles = {"steady": {"color": "0.55", "lw": 1.0}, "brunone": {"color": "tab:blue", "lw": 1.0},
              "convolution": {"color": "tab:red", "lw": 1.0}}
    for friction, result in runs.items():
        d = decays[friction]
        label = (f"{friction}: ringing {d.amplitudes_m[0]:.2f} -> {d.amplitudes_m[-1]:.2f} m "
                 f"({d.rate_per_s:.5f} 1/s)")
        whole.plot(result.time_s, result.head_m, label=label, **styles[friction])
        late = result.time_s >= result.time_s[-1] - 12.0
        tail.plot(result.time_s[late], result.head_m[late], label=friction, **styles[friction])
    whole.set_title("Demo load rejection: head at the turbine, quasi-steady, Brunone and convolution friction")
    whole.set_ylabel("head (m)")
    whole.legend(loc="upper right", fontsize=8)
    tail.set_xlabel("time (s)")
    tail.set_ylabel("head (m)")
    tail.set_title("the last 12 s")
    tail.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, help="draw friction_decay.png into this folder")
    args = parser.parse_args(argv)
    print("Halving the step (penstock.reaches N -> 2 N), load rejection of each shipped MOC plant:\n")
    print(convergence_table())
    decays, runs = {}, {}
    for friction in FRICTIONS:
        decays[friction], runs[friction] = demo_decay(friction)
    n = decays["steady"].reaches
    halved = [demo_decay(friction, 2 * n)[0] for friction in FRICTIONS]
    print(f"Ringing after the demo's load rejection (closure over at {closure_end_s(runs['steady']):.2f} s):\n")
    print(decay_table([*decays.values(), *halved]))
    if args.figures is not None:
        args.figures.mkdir(parents=True, exist_ok=True)
        print(f"wrote {draw(runs, decays, args.figures / 'friction_decay.png')}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
