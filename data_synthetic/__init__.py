"""Shipped synthetic data: the synthetic Francis chart (``francis/``) and the example plant.

Regenerate the chart with ``hillsim synth data_synthetic/francis``.
"""

from pathlib import Path

#: Folder of the shipped synthetic chart.
FRANCIS_DIR = Path(__file__).resolve().parent / "francis"
#: Folder of the shipped synthetic bulb nets (three inputs: n11, guide-vane angle, blade angle); regenerate with
#: ``python -c "from hillchart.fccm.double_regulated import write_bulb_nets; write_bulb_nets('data_synthetic/bulb')"``.
BULB_DIR = Path(__file__).resolve().parent / "bulb"
#: Folder of the synthetic pump-turbine (hillchart.synthetic.pump_turbine): its complete-characteristics table
#: (table.csv, table.toml) and its Suter-curve nets (nets.json); regenerate with
#: ``python -m hillchart.four_quadrant.nets data_synthetic/pump_turbine``.
PUMP_TURBINE_DIR = Path(__file__).resolve().parent / "pump_turbine"
#: The double-regulated example plant: a low-head run-of-river plant with the synthetic bulb and a draft tube.
PLANT_BULB = Path(__file__).resolve().parent / "plant_bulb.toml"
#: The shipped example plant.
PLANT_HLA339 = Path(__file__).resolve().parent / "plant_hla339.toml"
#: The example plant with [limits] and [[load_cases]] for the design studies (hillsim optimize-closure, report).
PLANT_HLA339_GUARANTEE = Path(__file__).resolve().parent / "plant_hla339_guarantee.toml"
#: The example plant with paper 001's sub-transient generator, voltage control and island load (eq. (14) load step).
PLANT_HLA339_GRID = Path(__file__).resolve().parent / "plant_hla339_grid.toml"
#: Two units of the example turbine on one penstock that branches at a manifold ([[units]]).
PLANT_TWO_UNITS = Path(__file__).resolve().parent / "plant_two_units.toml"
