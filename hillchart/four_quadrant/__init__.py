"""Four-quadrant (pump-turbine) characteristics in the Suter form: the transform and its inverse
(:mod:`~hillchart.four_quadrant.suter`), the complete-characteristics tables and the Wylie-Streeter pump curves
(:mod:`~hillchart.four_quadrant.table`), and the nets WH(x, y), WM(x, y) (:mod:`~hillchart.four_quadrant.nets`).

The synthetic pump-turbine these are checked against is :mod:`hillchart.synthetic.pump_turbine`.
"""
