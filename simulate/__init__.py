"""simulate: a hydropower plant (reservoir, penstock, turbine, governor, rotor) driven by hill-chart
characteristics, and the linear models and identification that are compared with them.

``simulate`` imports :mod:`hillchart`; never the reverse.
"""
