"""Physical constants used everywhere in hillsim (one definition each)."""

#: Density of water, kg/m^3.
RHO_WATER_KG_M3 = 1000.0
#: Gravitational acceleration, m/s^2 (the value the papers use).
G_M_S2 = 9.81
#: rad/s per r/min.
RPM_TO_RAD_S = 2.0 * 3.141592653589793 / 60.0
