"""Full characteristic curve map (FCCM) of a double-regulated turbine: test tables, a multi-output BP net and the
analyses of paper 003 (Wu et al., "Advanced modelling of full characteristic curve of tubular turbine based on
back-propagation neural network").

Pieces
------
:func:`~hillchart.fccm.table.load_test_table`
    A test-table folder (``table.csv`` + ``table.toml``) -> :class:`TestTable`, with n11 and Q11 derived from
    eqs. (1)-(2) of paper 003 when the table has head, flow and speed instead.
:class:`FCCMNet`
    scikit-learn style estimator: one logsig hidden layer, linear outputs, several outputs at once, trained by the
    Levenberg-Marquardt code of :mod:`hillchart.nets.lm`; hidden size from eq. (3) with C chosen by validation; the
    paper's seeded 30/35/35 train/validation/test split, validation stop, multi-start.
:class:`FCCMWeights`
    The exported net (``fccm_nets.json``); evaluation is plain numpy (no torch).
Analyses
    :func:`efficiency_maps` (Fig. 4), :func:`grey_images` and :func:`image_similarity` (eqs. (4)-(5), Figs. 5-6),
    :func:`grey_relational_analysis` (Table 1), :func:`truth_comparison` (net vs linear interpolation against an
    exact grid), the figures (:func:`plot_efficiency_maps`, :func:`plot_control_maps` (Fig. 7),
    :func:`plot_operating_characteristic` (Fig. 8)), and the three-input hill chart of a double-regulated turbine
    (:func:`train_double_regulated_nets`, :func:`on_cam_relation`).

Modules: :mod:`~hillchart.fccm.table` (test tables), :mod:`~hillchart.fccm.net` (the net and its weights),
:mod:`~hillchart.fccm.maps` (maps, similarity, grey relational analysis), :mod:`~hillchart.fccm.plots`,
:mod:`~hillchart.fccm.analysis` (what ``hillsim fccm`` runs), :mod:`~hillchart.fccm.double_regulated` (three-input
hill chart, on-cam relation). matplotlib and scipy are imported only where a function needs them.
"""
