"""The turbine boundary: characteristics at the penstock's end and the pressure loop."""
