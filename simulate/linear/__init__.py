"""Linear models of the turbine-penstock-rotor system and the nets' linear reference."""
