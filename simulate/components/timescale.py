"""What a component states about its dynamics: the time scales it needs resolved by the step (read by
:mod:`simulate.loop.timestep`, which chooses the step and the sub-steps from them)."""

from __future__ import annotations

from dataclasses import dataclass

#: A time scale T is resolved by a step dt <= this x T.
RESOLVE_FRACTION = 0.1


@dataclass(frozen=True)
class TimeScale:
    """One time constant a component needs resolved.

    ``label`` names the component and the constant with the key that sets it (as in the messages), ``value_s`` its
    value in s, ``coupled`` whether it is exchanged with the hydraulics once per step (not sub-stepped),
    ``resolve_fraction`` the largest dt / T that resolves it (a first-order discretization needs a finer step than
    an exact exponential).
    """

    label: str
    value_s: float
    coupled: bool = False
    resolve_fraction: float = RESOLVE_FRACTION

    @property
    def resolving_step_s(self) -> float:
        return self.resolve_fraction * self.value_s
