"""BP nets for the unit characteristics Q11(N11, a) and M11(N11, a): fit, text export, fast evaluation.

Li et al. (2017), sections 2.2-2.6, eqs. (10)-(12): one 2-H-1 net per characteristic (H = 5 in the paper),
log-sigmoid hidden layer, linear output, inputs and output mapped to [-1, 1] by their min/max (MATLAB
``mapminmax``)::

    xn = 2 (x - x_min) / (x_max - x_min) - 1                  # mapminmax of the inputs (N11 r/min, a chart unit)
    yn = sum_i W2_i f(W1_i1 xn_n11 + W1_i2 xn_a + b1_i) + b2  # eq. (11), f(z) = 1 / (1 + exp(-z)) eq. (10)
    y  = (yn + 1) (y_max - y_min) / 2 + y_min                 # reverse mapminmax of the output

Q11 is in m^3/s and M11 in N*m whatever the chart's units; N11 in r/min; the opening in the chart's unit.

Pieces
------
:class:`HillNet`
    scikit-learn style estimator for one net, trained by Levenberg-Marquardt (:mod:`hillchart.nets.lm`, a compiled
    loop) with a seeded, origin-stratified 80/20 split and a multi-start "loop control" (section 2.3).
:class:`NetWeights`
    The exported weights of one net (the ``NET`` block of ``nets.json``), validated on construction.
:class:`HillNets`
    The flow and torque nets together; implements the :class:`hillchart.characteristics.Characteristics`
    protocol and ``numba_kernel()`` for the simulator, ``to_json()``/``save()``; :func:`load_nets` reads it back.
:func:`train_nets`
    Both nets from the extended-samples table of :mod:`hillchart.extension.extend`: derived boundary samples weighted
    as soft constraints, boundary weight / hidden size / weight decay chosen by cross-validation on the measured
    samples, optionally an ensemble whose mean is distilled into the point nets.

There is exactly one implementation of eq. (11) and its analytic gradient at evaluation time, the numba function
``_net_value_grad`` of :mod:`hillchart.nets.weights`; the vectorized methods loop over it in compiled code.

Modules: :mod:`~hillchart.nets.weights` (one net's weights and evaluation), :mod:`~hillchart.nets.estimator`
(:class:`HillNet`), :mod:`~hillchart.nets.hill_nets` (:class:`HillNets`, nets.json), :mod:`~hillchart.nets.training`
(:func:`train_nets`), :mod:`~hillchart.nets.accuracy` (against an exact turbine), :mod:`~hillchart.nets.lm`
(Levenberg-Marquardt), :mod:`~hillchart.nets.chartplot` (figures).

``nets.json``
-------------
::

    {"format": "hillsim.nets", "version": 1,
     "units": {"n11": "r/min", "opening": "<chart unit>", "q11": "m^3/s", "m11": "N*m"},
     "flow": NET (output "q11"), "torque": NET (output "m11"), "training": {...},
     "ensemble": [{"flow": NET, "torque": NET}, ...],    # optional: the members of the uncertainty band
     "digitized_region": [[n11, opening], ...]}         # optional: the hull of the digitized chart points
    NET = {"inputs": ["n11", "opening"], "output": "q11" | "m11",
           "x_min": [n11_min, opening_min], "x_max": [n11_max, opening_max], "y_min": float, "y_max": float,
           "W1": [[w_n11, w_opening], ... H rows], "b1": [... H], "W2": [... H], "b2": float}

Floats are written with Python's shortest round-trip ``repr``, so ``load_nets(save(nets))`` is bit-exact.
"""
