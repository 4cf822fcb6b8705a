"""Plant components, one module each, grouped by role (hydraulic, turbine, control, shaft, electrical)."""
