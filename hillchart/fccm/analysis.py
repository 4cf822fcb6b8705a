"""The whole analysis of a test table (what ``hillsim fccm`` runs): net, maps, similarity, grey relational analysis,
figures."""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.fccm.maps import (
    efficiency_maps,
    grey_images,
    grey_relational_analysis,
    grey_relational_order,
    image_similarity,
    truth_acceptance,
    truth_comparison,
)
from hillchart.fccm.net import METRICS_FILE, NETS_FILE, FCCMNet, FCCMWeights, split_errors
from hillchart.fccm.plots import plot_control_maps, plot_efficiency_maps, plot_operating_characteristic
from hillchart.fccm.table import TestTable


# ----------------------------------------------------------------------------------------------------------------
# the whole analysis (what ``hillsim fccm`` runs)
# ----------------------------------------------------------------------------------------------------------------
@dataclass
class FCCMReport:
    """Everything ``hillsim fccm`` writes: the net, ``metrics.json`` and the figures (built in memory)."""

    weights: FCCMWeights
    metrics: dict
    figures: dict  # file name -> callable(path) drawing it

    def write(self, out_dir, *, plots: bool = True) -> dict:
        """Write ``fccm_nets.json``, ``metrics.json`` and (``plots``) the PNGs into ``out_dir``; returns
        name -> path. Figures are drawn into a temporary folder first, so a failure leaves no partial set."""
        out = Path(out_dir)
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        try:
            return self._write_via(out, plots)
        except BaseException:
            if created and out.is_dir() and not any(out.iterdir()):
                out.rmdir()  # a folder this call created stays only with the complete set in it
            raise

    def _write_via(self, out: Path, plots: bool) -> dict:
        with tempfile.TemporaryDirectory(dir=out, prefix=".fccm-") as tmp:
            tmp = Path(tmp)
            names = [NETS_FILE, METRICS_FILE]
            self.weights.save(tmp / NETS_FILE)
            (tmp / METRICS_FILE).write_text(json.dumps(self.metrics, indent=1, allow_nan=False) + "\n",
                                            encoding="utf-8")
            if plots:
                for name, draw in self.figures.items():
                    draw(tmp / name)
                    names.append(name)
            written = {}
            for name in names:
                shutil.move(str(tmp / name), str(out / name))
                written[name] = out / name
        return written


def analyse_fccm(table: TestTable, inputs, outputs, *, net: FCCMNet | None = None, truth: dict | None = None,
                 pixels: int = 160) -> FCCMReport:
    """Train the net on the table and run paper 003's analyses.

    Parameters
    ----------
    table : TestTable
    inputs, outputs : sequence of str
        Column names (e.g. the controls, and efficiency, head, power, flow).
    net : FCCMNet, optional
        Unfitted estimator with the wanted hyperparameters (default ``FCCMNet()``).
    truth : dict of str -> ndarray, optional
        Exact values on a dense grid (:func:`read_truth_csv`) for the net-vs-interpolation comparison.

    Returns
    -------
    FCCMReport
        ``metrics`` holds: ``errors`` (per output RMSE and max error on train / validation / test), the hidden-size
        choice, ``similarity`` and ``grey_relational`` (+ ``grey_relational_order``) when they apply, ``truth`` and
        ``acceptance`` when a truth grid is given, ``skipped`` (analysis -> reason) and ``warnings``.
    """
    inputs, outputs = tuple(inputs), tuple(outputs)
    for kind, names in (("inputs", inputs), ("outputs", outputs)):
        if not names:
            raise InputError(f"{kind}: give at least one column")
        if len(set(names)) != len(names):
            raise InputError(f"{kind} must be distinct, got {list(names)}")
    overlap = sorted(set(inputs) & set(outputs))
    if overlap:
        raise InputError(f"columns {overlap} are both inputs and outputs")
    X, Y = table.matrix(inputs), table.matrix(outputs)
    net = net if net is not None else FCCMNet()
    net.fit(X, Y, input_names=inputs, output_names=outputs)
    weights = net.weights_
    weights.training["table"] = table.info.name
    parts = {"train": net.train_index_, "validation": net.val_index_, "test": net.test_index_}
    metrics = {"table": table.info.name, "inputs": list(inputs), "outputs": list(outputs), "n_points": table.n_rows,
               "hidden": net.hidden_, "c": net.c_, "hidden_selection": net.selection_,
               "errors": split_errors(weights, X, Y, parts), "skipped": {}, "warnings": []}
    figures = {}
    # grey relational analysis on the test points (Table 1)
    controls = table.info.controls
    refs = {o: table.column(o) for o in outputs}
    try:
        degrees = grey_relational_analysis(refs, {c: table.column(c) for c in controls})
        metrics["grey_relational"] = degrees
        metrics["grey_relational_order"] = grey_relational_order(degrees)
    except InputError as exc:
        metrics["skipped"]["grey_relational"] = str(exc)
    # maps and image similarity (Figs. 4-6)
    try:
        maps = efficiency_maps(table, weights, pixels=pixels)
        ga, gb, mask = grey_images(maps.interpolated, maps.net)
        sim = image_similarity(ga, gb, mask)
        metrics["similarity"] = {k: sim[k] for k in ("euclidean", "cosine", "angle_deg", "pixel_rms", "pixels")}
        metrics["similarity"]["grey_range"] = [float(min(maps.interpolated[mask].min(), maps.net[mask].min())),
                                               float(max(maps.interpolated[mask].max(), maps.net[mask].max()))]
        figures["fccm_efficiency_maps.png"] = lambda p, m=maps, a=ga, b=gb, s=sim: plot_efficiency_maps(m, a, b, s, p)
        if mask.sum() < 0.02 * mask.size:
            metrics["warnings"].append(
                f"the efficiency maps overlap on {int(mask.sum())} of {mask.size} pixels only: the test points lie "
                "(nearly) on one curve of the (Q11, n11) plane (e.g. a plant at constant speed on a water system "
                "H(Q)), so the image similarity measures little")
    except InputError as exc:
        metrics["skipped"]["similarity"] = str(exc)
    if len(inputs) == 2:
        figures["fccm_control_maps.png"] = lambda p: plot_control_maps(weights, table, p)
    else:
        metrics["skipped"]["control_maps"] = f"needs 2 inputs, got {len(inputs)}"
    if {"efficiency", "power_kw"} <= set(outputs) and "head_m" in inputs + outputs and len(inputs) == 2:
        figures["fccm_operating_characteristic.png"] = lambda p: plot_operating_characteristic(weights, table, p)
    else:
        metrics["skipped"]["operating_characteristic"] = ("needs 2 inputs, efficiency and power_kw among the outputs "
                                                          "and head_m among inputs or outputs")
    if truth is not None:
        comparison = truth_comparison(weights, table, truth)
        metrics["truth"] = comparison
        metrics["acceptance"] = truth_acceptance(comparison, outputs)
        Xt = np.column_stack([np.asarray(truth[n], dtype=float) for n in inputs])
        outside = int(weights.outside_domain(Xt).sum())
        if outside:
            metrics["warnings"].append(f"{outside} truth points lie outside the input box the net was fitted on "
                                       "(extrapolation)")
    return FCCMReport(weights=weights, metrics=metrics, figures=figures)
