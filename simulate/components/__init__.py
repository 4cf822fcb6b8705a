"""Plant components, one module each, grouped by role (hydraulic, turbine, control, shaft, electrical), with their
registries (:mod:`simulate.components.registry`: TOML name -> builder) and the schedules they follow."""
