"""Torque from efficiency and the extension of the samples to runaway, zero opening and zero speed."""
