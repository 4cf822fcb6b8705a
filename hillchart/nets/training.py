"""Training the nets from an extended chart: model selection by cross-validation on the measured samples, the ensemble
of the band and its distilled point nets."""

from __future__ import annotations

import time

import numpy as np

from hillchart.errors import InputError
from hillchart.nets import lm
from hillchart.nets.estimator import HillNet, _lm_jobs, _split
from hillchart.nets.hill_nets import HillNets
from hillchart.nets.weights import ORIGINS, NetWeights


# ----------------------------------------------------------------------------------------------------------------
# both nets from the extended samples
# ----------------------------------------------------------------------------------------------------------------
def _column(table, name):
    try:
        return np.asarray(table[name])
    except (KeyError, IndexError, TypeError, ValueError):
        pass
    if hasattr(table, name):
        return np.asarray(getattr(table, name))
    raise InputError(f"extended samples: column {name!r} is missing (need target, origin, n11, opening, value)")


#: Candidates of the model selection, each scored by the validation MSE on measured samples.
BOUNDARY_WEIGHTS = (0.03, 0.1, 0.3, 1.0)
#: From 5, the paper's net: a sparse chart's CV cannot tell 3 units from 10 inside its lines, and a 2-3-1 torque net
#: chosen there missed the exact M11 by 128 N*m at 1.4 x its largest N11, where the speed rise is decided
#: (docs/guarantee-benchmark.md, step 11).
HIDDEN_SIZES = (5, 6, 8, 10)
REGULARIZATIONS = (0.0, 1e-5, 1e-4)
#: A candidate is "as good" as the best when its validation MSE is within this factor; among those the selection
#: takes the largest boundary weight, the smallest net, the strongest regularization (Occam, as the 1-SE rule).
#: 1.3, not 1.1: a 5-fold CV MSE over 12-30 measured samples of a sparse chart varies by tens of percent between
#: candidates that fit alike, and at 1.1 it picked nets that follow the noise between the lines (a 4 x 4 chart: an
#: 8-neuron torque net without weight decay, M11 off by 1.9 % RMS of its range between the lines against 0.45 % at
#: 1.3), which decides the max speed rise of a load rejection. 1.5 went further (worst speed error 0.82 against 1.08
#: points) but cost a dense chart its six coefficients (0.056 > 0.05); docs/guarantee-benchmark.md.
SELECTION_TOLERANCE = 1.3
#: The Levenberg-Marquardt stops the selection weighs against the paper's ``trainlm`` stops (HillNet's defaults, goal
#: 1e-5 on the normalized MSE and 6 validation fails): a fit run on to a goal of 1e-7, with 100 epochs of patience.
#: The extension's samples widen each net's output range about twice over the measured samples' and outnumber them,
#: and on a clean chart the paper's stops end the fit before it has found the slopes inside the chart (a noise-free
#: out-of-class chart's ``ex`` 0.052 off at the rated point where the measured samples alone hold it within 0.005);
#: on a sparse or noisy chart the longer fit follows the readings' noise (a 4 x 4 chart validating on 3 points:
#: its max speed rise 0.9 point off against 0.4). So the stops are a candidate of the selection like the others, the
#: paper's kept unless the longer fit's CV MSE is below theirs by more than SELECTION_TOLERANCE
#: (docs/guarantee-benchmark.md, step 14).
LONGER_STOPS = {"goal": 1e-7, "max_fail": 100}
#: The paper's stops (MATLAB ``trainlm``'s, :class:`hillchart.nets.estimator.HillNet`'s defaults), to fix them.
PAPER_STOPS = {"goal": 1e-5, "max_fail": 6}
#: The selection scores each candidate with one initialisation per fold (three, each fold scored by its best, made
#: the out-of-class family's measured region no better: docs/guarantee-benchmark.md); restarts per ensemble member.
SELECTION_FOLDS = 5
ENSEMBLE_RESTARTS = 2
DISTILL_RESTARTS = 3
#: The point net must follow the members' median inside the digitized box within this fraction of the median's RMS
#: miss of the measured samples (or within DISTILL_FLOOR of the measured range: a noise-free chart), else the next
#: larger hidden size is tried.
DISTILL_FRACTION = 0.5
DISTILL_FLOOR = 1e-3
#: Training MSE goal (normalized outputs) of the point net's fit to the members' median.
DISTILL_GOAL = 1e-8
#: Derived (not digitized) origins; the runaway samples are derived when the extension made them from the model.
DERIVED_ORIGINS = ("zero-opening", "zero-speed")


def _derived_mask(extended, origin: np.ndarray) -> np.ndarray:
    derived = getattr(extended, "derived", None)
    if derived is not None:
        derived = np.asarray(derived, bool)
    else:
        try:
            derived = np.asarray(extended["derived"], bool)
        except (KeyError, IndexError, TypeError, ValueError):
            derived = None
    if derived is None:
        derived = np.isin(origin, DERIVED_ORIGINS)
    return derived


def _select(xn, yn, train_index, val_index, derived, validated, *, hidden, boundary_weight, regularization, seed,
            n_threads, lm_params, progress, label, choose_stops: bool = True):
    """Choose boundary weight, the Levenberg-Marquardt stops (with ``choose_stops``: the paper's or
    :data:`LONGER_STOPS`), hidden size and regularization by validation MSE on the measured samples; returns them and
    the LM parameters chosen."""
    table = []
    # K-fold cross-validation over the validated (measured) samples; every other sample always trains. A single
    # 20 % split holds about 17 measured samples: too few to rank candidates whose errors differ by < 10 %.
    checked = np.flatnonzero(validated)
    always = np.setdiff1d(np.arange(xn.shape[0]), checked)
    folds = np.array_split(np.random.default_rng([seed, 31]).permutation(checked), SELECTION_FOLDS)

    def score(weight, h, lam, index, params=None):
        params = params or lm_params
        rng = np.random.default_rng([seed, 7919, index])
        jobs = []  # one start per fold, drawn in the folds' order; the folds run side by side
        for fold in folds:
            train = np.sort(np.concatenate([always, np.setdiff1d(checked, fold)]))
            jobs += _lm_jobs(xn, yn, train, np.sort(fold), np.where(derived, weight, 1.0), h, lam,
                             [lm.nguyen_widrow_init(h, rng)], params)
        errors = [result.val_mse * fold.size for result, fold in zip(lm.run_threads(jobs, n_threads), folds)]
        value = float(np.sum(errors) / checked.size)
        table.append({"boundary_weight": weight, "hidden": h, "regularization": lam, "goal": params["goal"],
                      "max_fail": params["max_fail"], "cv_mse": value})
        return value

    def pick(candidates, prefer_last: bool, evaluate):
        scores = [evaluate(c, i) for i, c in enumerate(candidates)]
        good = [c for c, v in zip(candidates, scores) if v <= SELECTION_TOLERANCE * min(scores) + 1e-15]
        return good[-1] if prefer_last else good[0]

    weight = boundary_weight
    h = hidden if hidden is not None else 5
    lam = regularization if regularization is not None else 0.0
    if weight is None:
        weight = pick(BOUNDARY_WEIGHTS, True, lambda w, i: score(w, h, lam, i)) if derived.any() else 1.0
        if progress:
            progress(f"{label}: boundary weight {weight}")
    if choose_stops:
        lm_params = pick((lm_params, {**lm_params, **LONGER_STOPS}), False,
                         lambda c, i: score(weight, h, lam, 300 + i, c))
        if progress:
            progress(f"{label}: stops goal {lm_params['goal']:g}, {lm_params['max_fail']} validation fails")
    if hidden is None:
        h = pick(HIDDEN_SIZES, False, lambda c, i: score(weight, c, lam, 100 + i))
        if progress:
            progress(f"{label}: hidden size {h}")
    if regularization is None:
        lam = pick(REGULARIZATIONS, True, lambda c, i: score(weight, h, c, 200 + i))
        if progress:
            progress(f"{label}: regularization {lam}")
    return weight, h, lam, table, lm_params


def train_nets(extended, *, opening_unit: str | None = None, hidden: int | None = None, restarts: int = 10,
               seed: int = 0, boundary_weight: float | None = None, regularization: float | None = None,
               ensemble: int = 0, record_time: bool = False, progress=None, **net_params) -> HillNets:
    """Train the flow and torque nets on the extended samples (Li et al. 2017, eq. (12) and section 2.6 steps (5)-(6)).

    The measured (digitized) samples carry the fit; derived boundary samples are soft constraints whose weight, the
    hidden size (5-10), a weight-decay regularization and the Levenberg-Marquardt stops (the paper's or
    :data:`LONGER_STOPS`) are chosen by the validation error on measured samples (see the docs page on the nets).
    Give ``hidden``, ``boundary_weight``, ``regularization`` or ``goal`` / ``max_fail`` to fix them instead.

    Parameters
    ----------
    extended : table
        Extended samples with columns ``target`` ('q11' | 'm11'), ``origin`` ('measured' | 'runaway' |
        'zero-opening' | 'zero-speed'), ``n11`` (r/min), ``opening`` (chart units), ``value`` (m^3/s or N*m);
        anything indexable by column name or with those attributes; an optional boolean ``derived`` marks the
        samples the extension made up (default: the zero-opening and zero-speed origins).
    opening_unit : str, optional
        The chart's opening unit; default ``extended.opening_unit``.
    hidden : int in [1, 50] or None
        Hidden neurons of both nets; None selects among :data:`HIDDEN_SIZES`. The paper's net: 5.
    restarts : int
        Multi-start count of the final fit of each net.
    seed : int
        The flow net uses ``seed``, the torque net ``seed + 1``.
    boundary_weight : float in (0, 1] or None
        Weight of the derived samples' residuals; None selects among :data:`BOUNDARY_WEIGHTS`.
    regularization : float in [0, 1] or None
        Weight decay lambda; None selects among :data:`REGULARIZATIONS`.
    ensemble : int >= 0
        Ensemble members (the uncertainty band), each trained on every derived sample and its own random 80/20
        split of the measured ones (early stopping on its held-out part), with its own initialisations, and toward
        runaway its torque samples at its place in the band of the chart's overspeed evidence; the point net is
        then fitted to their median. 0: none (one net, the paper's).
    record_time : bool
        Put training times (``time_s``) into the training record; off by default so that ``nets.json`` is
        byte-reproducible.
    progress : callable(str), optional
        Called with a short message after each stage (long trainings report progress).
    **net_params
        Further :class:`HillNet` hyperparameters (its Levenberg-Marquardt stops ``goal`` and ``max_fail`` among
        them; the point net of an ensemble fits the members' median to the tighter of ``goal`` and
        :data:`DISTILL_GOAL`).

    Returns
    -------
    HillNets
        With ``training`` holding per-net sample counts, split, errors (normalized MSE and physical max/RMS),
        epochs, stop reasons and the selection; the fitted estimators are kept in ``nets.estimators``.
    """
    if opening_unit is None:
        opening_unit = getattr(extended, "opening_unit", None)
        if opening_unit is None:
            raise InputError("train_nets: opening_unit is required when the table does not carry it")
    for name, value, low, high in (("hidden", hidden, 1, 50), ("ensemble", ensemble, 0, 200),
                                   ("restarts", restarts, 1, 1000), ("seed", seed, 0, 2**63 - 1)):
        if value is None and name == "hidden":
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
            raise InputError(f"train_nets: {name} must be an integer in [{low}, {high}], got {value!r}")
    if boundary_weight is not None and not (isinstance(boundary_weight, (int, float)) and 0 < boundary_weight <= 1):
        raise InputError(f"train_nets: boundary_weight must be in (0, 1], got {boundary_weight!r}")
    if regularization is not None and not (isinstance(regularization, (int, float))
                                           and 0 <= regularization <= 1):
        raise InputError(f"train_nets: regularization must be in [0, 1], got {regularization!r}")
    target = _column(extended, "target").astype(str)
    origin = _column(extended, "origin").astype(str)
    n11 = _column(extended, "n11").astype(float)
    opening = _column(extended, "opening").astype(float)
    value = _column(extended, "value").astype(float)
    bad_targets = sorted(set(target.tolist()) - {"q11", "m11"})
    if bad_targets:
        raise InputError(f"extended samples: target must be 'q11' or 'm11', got {bad_targets}")
    bad_origins = sorted(set(origin.tolist()) - set(ORIGINS))
    if bad_origins:
        raise InputError(f"extended samples: origin must be one of {', '.join(ORIGINS)}, got {bad_origins}")
    derived_all = _derived_mask(extended, origin)
    record = {"seed": seed, "hidden": hidden if hidden is not None else "selected", "restarts": restarts,
              "validation": "measured samples", "ensemble": int(ensemble)}
    weights, estimators, members = {}, {}, {"flow": [], "torque": []}
    for offset, (key, tgt) in enumerate((("flow", "q11"), ("torque", "m11"))):
        sel = target == tgt
        if not np.any(sel):
            raise InputError(f"extended samples: no rows with target {tgt!r}")
        X = np.column_stack([n11[sel], opening[sel]])
        y = value[sel]
        groups = origin[sel]
        derived = derived_all[sel]
        net_seed = seed + offset
        validation_groups = ("measured",) if np.sum(groups == "measured") >= 10 else None
        probe = HillNet(hidden=hidden or 5, restarts=restarts, seed=net_seed, validation_groups=validation_groups,
                        **net_params)
        probe._validate_params()
        x_min, x_max = X.min(axis=0), X.max(axis=0)
        y_min, y_max = float(y.min()), float(y.max())
        if not (np.all(x_max > x_min) and y_max > y_min) or X.shape[0] < 10 or not np.all(np.isfinite(X)) or \
                not np.all(np.isfinite(y)):
            probe.fit(X, y, groups, derived)  # raises the estimator's own, precise error
        xn = 2.0 * (X - x_min) / (x_max - x_min) - 1.0  # mapminmax, section 2.6 of paper 004
        yn = 2.0 * (y - y_min) / (y_max - y_min) - 1.0
        train_index, val_index = _split(groups, probe.validation_fraction, validation_groups,
                                        np.random.default_rng(net_seed))
        start = time.perf_counter()
        validated = np.isin(groups, validation_groups) if validation_groups else np.ones(groups.size, bool)
        weight, h, lam, table, lm_params = _select(
            xn, yn, train_index, val_index, derived, validated, hidden=hidden, boundary_weight=boundary_weight,
            regularization=regularization, seed=net_seed, n_threads=probe.n_threads, lm_params=probe._lm_params(),
            progress=progress, label=key, choose_stops="goal" not in net_params and "max_fail" not in net_params)
        stops = {"goal": lm_params["goal"], "max_fail": lm_params["max_fail"]}
        moves = _overspeed_moves(extended, key, X, groups, derived, ensemble, seed)
        jobs = []
        for i in range(ensemble):
            # member i: its own random 80/20 split of the validated samples (early stopping on its held-out part),
            # every derived sample in training, its own initialisations; toward runaway its torque samples stand at
            # its place in the band of the chart's overspeed evidence. Every member's starts run side by side.
            rng = np.random.default_rng([net_seed, 104729, i])
            tr_i, va_i = _split(groups, probe.validation_fraction, validation_groups, rng)
            yn_i = yn if moves is None else yn + 2.0 * moves[i] / (y_max - y_min)
            jobs += _lm_jobs(xn, yn_i, tr_i, va_i, np.where(derived, weight, 1.0), h, lam,
                             [lm.nguyen_widrow_init(h, rng) for _ in range(ENSEMBLE_RESTARTS)], lm_params)
        results = lm.run_threads(jobs, probe.n_threads)
        for i in range(ensemble):
            res = min(results[i * ENSEMBLE_RESTARTS:(i + 1) * ENSEMBLE_RESTARTS], key=lambda r: r.val_mse)
            w1, b1, w2, b2 = lm.unpack(res.theta, h)
            members[key].append(NetWeights(x_min=x_min, x_max=x_max, y_min=y_min, y_max=y_max, W1=w1, b1=b1,
                                           W2=w2, b2=float(b2)))
        if ensemble:
            # point estimate: one 2-h-1 net fitted to the ensemble median (the central value of nets trained on
            # different splits has a fraction of a single net's variance; "distilling" it keeps the paper's small
            # net). The median, not the mean: on a sparse chart one member in ten can follow a split's gap between
            # the lines far off the others, and the mean follows it (guarantee benchmark: worst max-speed-rise
            # error 1.08 points with the mean, 0.66 with the median). Targets: the median at the samples and on a
            # 21 x 21 grid over the input box.
            grid = np.stack(np.meshgrid(np.linspace(x_min[0], x_max[0], 21), np.linspace(x_min[1], x_max[1], 21)),
                            axis=-1).reshape(-1, 2)
            X_d = np.vstack([X, grid])
            y_d = np.median([m.evaluate(X_d[:, 0], X_d[:, 1])[0] for m in members[key]], axis=0)
            est, distill = _distill(X_d, y_d, X, y, groups == "measured", h, net_seed, net_params,
                                    grow=hidden is None)
            if progress:
                progress(f"{key}: {ensemble} ensemble members, point net 2-{est.hidden}-1 fitted to their median")
        else:
            distill = None
            est = HillNet(hidden=h, restarts=restarts, seed=net_seed, boundary_weight=weight, regularization=lam,
                          validation_groups=validation_groups, **{**net_params, **stops}).fit(X, y, groups, derived)
            if progress:
                progress(f"{key}: final fit 2-{h}-1, validation MSE {est.val_mse_:.3g}")
        est.fit_time_s_ = time.perf_counter() - start  # selection + ensemble + final fit
        estimators[key] = est
        weights[key] = est.weights_
        rec = _training_record(est, X, y, groups, record_time, point_of_ensemble=bool(ensemble))
        err = est.predict(X) - y
        measured = groups == "measured"
        if measured.any():
            rec["measured_rms_error"] = float(np.sqrt(np.mean(err[measured] ** 2)))
            rec["measured_max_abs_error"] = float(np.max(np.abs(err[measured])))
        best_cv = min(c["cv_mse"] for c in table) if table else None
        if distill is not None:
            rec["distillation"] = distill
        rec["selection"] = {"boundary_weight": weight, "hidden": h, "regularization": lam, **stops,
                            "cv_mse_best": best_cv,
                            "rule": f"{SELECTION_FOLDS}-fold CV MSE on measured samples within {SELECTION_TOLERANCE} "
                                    "x the best: largest boundary weight, the paper's stops, smallest net, strongest "
                                    "regularization",
                            "candidates": table}
        record[key] = rec
    ensemble_pairs = list(zip(members["flow"], members["torque"])) if ensemble else None
    silent, member_silent = silent_region_models(extended, ensemble, seed)
    extrapolation = getattr(extended, "extrapolation", None)
    if extrapolation is not None:
        from hillchart.nets.silent_model import median_of

        record["extrapolation"] = {**extrapolation.to_dict(), "median_of": median_of(extrapolation)}
    if getattr(extended, "warnings", ()):  # what the extension could not do (hillchart.extension.extend)
        record["warnings"] = list(extended.warnings)
    if getattr(extended, "lines_without_runaway", ()):
        record["lines_without_runaway"] = list(extended.lines_without_runaway)
    nets = HillNets(flow=weights["flow"], torque=weights["torque"], opening_unit=opening_unit, training=record,
                    ensemble=ensemble_pairs, silent_model=silent, member_silent_models=member_silent or None)
    nets.estimators = estimators
    return nets


def _distill(X_d, y_d, X, y, measured, h, seed, net_params, grow: bool = True):
    """The point net fitted to the members' median ``y_d`` at ``X_d`` (the samples, then a grid over the box).

    The members' hidden size first; with ``grow`` (the size was selected, not given), the larger
    :data:`HIDDEN_SIZES` in turn until the point net follows the median where the chart was digitized (its samples
    and the grid inside their N11 x opening box) within :data:`DISTILL_FRACTION` of the median's own RMS miss of the
    measured samples (or within :data:`DISTILL_FLOOR` of their range); the closest is kept when none does. A size
    that cannot follow the median adds its own error to the chart's: on the out-of-class family a 2-4-1 point net
    read Q11 0.76 % RMS off in the measured region where the members' median was 0.44 % off. Returns the point
    estimator and a record of the sizes tried (RMS in the target's unit).
    """
    inside = np.zeros(X_d.shape[0], bool)
    if measured.any():
        low, high = X[measured].min(axis=0), X[measured].max(axis=0)
        inside = np.all((X_d >= low) & (X_d <= high), axis=1)
    n = X.shape[0]
    miss = float(np.sqrt(np.mean((y_d[:n][measured] - y[measured]) ** 2))) if measured.any() else 0.0
    bound = max(DISTILL_FRACTION * miss, DISTILL_FLOOR * float(np.ptp(y[measured])) if measured.any() else 0.0)
    tried, best = [], None
    for size in [h, *(c for c in HIDDEN_SIZES if c > h and grow)]:
        # the median is smooth and noise-free: fitted to a tighter goal than the members (and never a looser one
        # than the caller's own ``goal``)
        params = {**net_params, "goal": min(DISTILL_GOAL, net_params.get("goal", DISTILL_GOAL))}
        est = HillNet(hidden=size, restarts=DISTILL_RESTARTS, seed=seed, **params).fit(X_d, y_d)
        off = float(np.sqrt(np.mean((est.predict(X_d[inside]) - y_d[inside]) ** 2))) if inside.any() else 0.0
        tried.append({"hidden": size, "rms_from_median": off})
        if best is None or off < best[1]:
            best = (est, off)
        if off <= bound:
            break
    return best[0], {"median_rms_miss_of_measured": miss, "bound": bound, "tried": tried, "hidden": best[0].hidden}


def _overspeed_moves(extended, key: str, X, groups, derived, members: int, seed: int):
    """Per ensemble member, the shift (N*m) of each torque sample toward runaway: its place in the band
    (:func:`hillchart.extension.hypotheses.member_positions`, the same places as below the lowest line) times the
    band's half-width on that side at the sample
    (:meth:`hillchart.extension.hypotheses.Extrapolation.overspeed_widths`).
    Only samples the extension derived from the model move (the overspeed samples, and the runaway points when no
    runaway curve was digitized); measured ones never do. None for the flow net, without members or evidence."""
    from hillchart.extension.hypotheses import member_positions

    extrapolation = getattr(extended, "extrapolation", None)
    if key != "torque" or not members or extrapolation is None:
        return None
    low, high = extrapolation.overspeed_widths(X[:, 0], X[:, 1])
    movable = (groups == "silent-region") | ((groups == "runaway") & derived)
    low, high = np.where(movable, low, 0.0), np.where(movable, high, 0.0)
    if not (low.any() or high.any()):
        return None
    return [u * (low if u < 0 else high) for u in member_positions(members, seed)]


def silent_region_models(extended, members: int = 0, seed: int = 0):
    """The extrapolation the nets hand over to below the lowest digitized opening
    (:class:`hillchart.nets.silent_model.SilentRegionModel`: the extension's weighed hypotheses, tabulated), when
    the extension weighed them (:attr:`hillchart.extension.extend.ExtendedSamples.extrapolation`), and one table per
    ensemble member at its place in the band (:func:`hillchart.extension.hypotheses.member_positions`, seeded by
    ``seed``): the band's width comes from the chart's held-out lines. ``(None, [])`` when there is none (the nets
    alone everywhere)."""
    from hillchart.extension.hypotheses import member_positions
    from hillchart.nets.silent_model import SilentRegionModel

    extrapolation = getattr(extended, "extrapolation", None)
    if extrapolation is None:  # e.g. a table of samples (dict) or the paper's polynomial boundaries
        return None, []
    evidence = extrapolation.evidence
    table = SilentRegionModel.tabulate(extrapolation.values, extrapolation.lowest_opening, extrapolation.n11_top,
                                       band_q11=evidence.band["q11"],
                                       band_m11=tuple(evidence.m11_scale * v for v in evidence.band["m11"]),
                                       distance_cap=evidence.distance_cap)
    return table, [table.at(float(u)) for u in member_positions(members, seed)]


def _training_record(est: HillNet, X, y, groups, record_time: bool, point_of_ensemble: bool = False) -> dict:
    pred = est.predict(X)
    err = pred - y
    tr, va = est.train_index_, est.val_index_
    if point_of_ensemble:  # the point net was fitted to the ensemble median: report its errors at the samples
        tr, va = np.arange(X.shape[0]), np.zeros(0, int)
    counts = {}
    for g in sorted(set(groups.tolist())):
        counts[g] = {"train": int(np.sum(groups[tr] == g)), "validation": int(np.sum(groups[va] == g))}
    rec = {"seed": est.seed, "n_train": int(tr.size), "n_validation": int(va.size), "samples_by_origin": counts,
           "train_mse_normalized": est.train_mse_, "validation_mse_normalized": est.val_mse_,
           "train_rms_error": float(np.sqrt(np.mean(err[tr] ** 2))),
           "train_max_abs_error": float(np.max(np.abs(err[tr]))),
           "validation_rms_error": float(np.sqrt(np.mean(err[va] ** 2))) if va.size else None,
           "validation_max_abs_error": float(np.max(np.abs(err[va]))) if va.size else None,
           "epochs": est.epochs_, "best_epoch": est.best_epoch_, "stop_reason": est.stop_reason_,
           "best_restart": est.best_restart_, "restart_validation_mse": est.restart_val_mse_}
    if record_time:
        rec["time_s"] = round(est.fit_time_s_, 3)
    return rec
