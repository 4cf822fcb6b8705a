"""The BP nets of the unit characteristics: training (Levenberg-Marquardt), evaluation, figures."""
