"""The synthetic bulb turbine's shipped three-input nets (n11, guide-vane angle, blade angle)."""
