"""The time loop: component registries, the generated loop, the steady state, the guards before a run."""
