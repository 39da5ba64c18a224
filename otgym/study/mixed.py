"""Mixed-effects models of the study's trials, and order effects (statsmodels
``MixedLM``: a linear mixed model fitted by (restricted) maximum likelihood, Lindstrom &
Bates 1988; statsmodels' documentation, "Linear Mixed Effects Models").

Per trial, each measure is modelled as a fixed effect of the mode plus a random
intercept per participant (the participant effect):

    value[p, t] = b0 + b_mode[mode(p, t)] + u[p] + e[p, t],   u ~ N(0, s_u^2), e ~ N(0, s^2)

Measures: ``success`` (the trial's proportion of obstacles avoided; trials that met no
obstacle have none and are left out), ``time`` (completion time of the trials that
reached the goal), and, from the questionnaires (one value per participant and mode),
``raw_tlx`` and ``ueq_overall``. Estimates are REML; their Wald z tests are against
the first mode in ``stats.MODE_ORDER`` (the reference level).

Order effects, where the trials carry the block ``position`` (1..n: ``otgym study
run``): likelihood-ratio tests between models fitted by maximum likelihood (REML
likelihoods of different fixed effects are not comparable): mode + position against
mode alone (does the block's place matter: practice, fatigue), and mode x position
against mode + position (does a mode's effect depend on where it comes). A model that
cannot be fitted (too few participants or trials, a singular design) gives a note and
no numbers; nothing is invented."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

from otgym.study.stats import ordered_modes

TRIAL_MEASURES = ("success", "time")
SCORE_MEASURES = ("raw_tlx", "ueq_overall")


def trial_values(trials: pd.DataFrame, measure: str) -> pd.DataFrame:
    """Columns participant, mode, (position,) value: one row per trial that has the measure."""
    frame = trials.copy()
    if measure == "success":
        encountered = frame["obstacles_encountered"].astype(float)
        frame["value"] = frame["obstacles_avoided"].astype(float) / encountered.where(encountered > 0)
    elif measure == "time":
        frame["value"] = frame["completion_time_s"].astype(float).where(frame["reached_goal"].astype(bool))
    else:
        raise ValueError(f"measure must be one of {TRIAL_MEASURES}, got {measure!r}")
    keep = ["participant", "mode", "value"] + (["position"] if "position" in frame.columns else [])
    return frame[keep].dropna(subset=["value"]).reset_index(drop=True)


def _design(frame: pd.DataFrame) -> pd.DataFrame:
    modes = ordered_modes(frame["mode"])
    frame = frame.copy()
    frame["mode"] = pd.Categorical(frame["mode"], categories=modes)
    frame["participant"] = frame["participant"].astype(str)
    if "position" in frame.columns:
        frame["position"] = pd.Categorical(frame["position"].astype(int))
    return frame


FIT_METHODS = ("lbfgs", "powell", "nm")
"""Optimisers tried in turn. When the participant variance lies on its boundary (0),
L-BFGS can stop at a degenerate point (an infinite log-likelihood with the intercept at
0) or fail inverting a singular Hessian (seen with statsmodels 0.15); a fit counts only
converged with a finite log-likelihood, and the first such one is kept."""


def _fit(frame: pd.DataFrame, formula: str, reml: bool):
    import statsmodels.formula.api as smf

    model = smf.mixedlm(formula, frame, groups=frame["participant"])
    failures = []
    for method in FIT_METHODS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # convergence and boundary warnings: judged from the result
            try:
                fitted = model.fit(reml=reml, method=method)
            except (ValueError, np.linalg.LinAlgError) as error:  # e.g. a singular Hessian at the boundary
                failures.append(f"{method}: {str(error).splitlines()[0]}")
                continue
        if fitted.converged and math.isfinite(fitted.llf):
            return fitted
        failures.append(f"{method}: {'infinite log-likelihood' if fitted.converged else 'not converged'}")
    raise ValueError(f"no finite, converged fit ({'; '.join(failures)})")


def _float(value) -> float:
    value = float(value)
    return value if math.isfinite(value) else math.nan


def _too_small(frame: pd.DataFrame) -> str | None:
    if frame["participant"].nunique() < 2:
        return f"{frame['participant'].nunique()} participant(s): a participant effect needs at least 2"
    if frame["mode"].nunique() < 2:
        return "fewer than 2 modes"
    if frame["value"].nunique() < 2:
        return "every value is the same"
    return None


def mode_model(frame: pd.DataFrame) -> dict:
    """``value ~ mode + (1 | participant)`` by REML on ``frame`` (participant, mode,
    value). Returns formula, n, participants, converged, the participant variance, the
    residual variance and per coefficient estimate, se, z, p and the 95 % interval; or
    a ``note`` saying why no model was fitted."""
    result = {"formula": "value ~ mode + (1 | participant)", "n": len(frame), "participants": 0}
    if frame.empty:
        return {**result, "note": "no trials with this measure"}
    frame = _design(frame)
    result["participants"] = int(frame["participant"].nunique())
    problem = _too_small(frame)
    if problem:
        return {**result, "note": problem}
    try:
        fitted = _fit(frame, "value ~ C(mode)", reml=True)
    except (ValueError, np.linalg.LinAlgError) as error:
        return {**result, "note": f"not fitted: {str(error).splitlines()[0]}"}
    interval = fitted.conf_int()
    coefficients = []
    for name in fitted.fe_params.index:
        coefficients.append(
            {
                "term": name.replace("C(mode)[T.", "mode[").replace("]", "]"),
                "estimate": _float(fitted.fe_params[name]),
                "se": _float(fitted.bse_fe[name]),
                "z": _float(fitted.tvalues[name]),
                "p": _float(fitted.pvalues[name]),
                "ci_low": _float(interval.loc[name, 0]),
                "ci_high": _float(interval.loc[name, 1]),
            }
        )
    return {
        **result,
        "reference": str(frame["mode"].cat.categories[0]),
        "converged": bool(fitted.converged),
        "participant_variance": _float(fitted.cov_re.iloc[0, 0]),
        "residual_variance": _float(fitted.scale),
        "coefficients": coefficients,
    }


def _likelihood_ratio(frame: pd.DataFrame, small: str, large: str) -> dict:
    from scipy import stats

    fits = [_fit(frame, formula, reml=False) for formula in (small, large)]
    statistic = max(2.0 * (fits[1].llf - fits[0].llf), 0.0)
    dof = len(fits[1].fe_params) - len(fits[0].fe_params)
    return {
        "lr": _float(statistic),
        "dof": int(dof),
        "p": _float(stats.chi2.sf(statistic, dof)) if dof > 0 else math.nan,
        "converged": bool(fits[0].converged and fits[1].converged),
    }


def order_effects(frame: pd.DataFrame) -> dict:
    """The two likelihood-ratio tests of the module's docstring on ``frame``
    (participant, mode, position, value); or a ``note``."""
    if "position" not in frame.columns:
        return {"note": "the trials carry no block position (not an otgym study run folder)"}
    if frame.empty:
        return {"note": "no trials with this measure"}
    frame = _design(frame)
    problem = _too_small(frame)
    if problem is None and frame["position"].nunique() < 2:
        problem = "fewer than 2 block positions"
    if problem:
        return {"note": problem}
    result = {}
    for name, small, large in (
        ("position", "value ~ C(mode)", "value ~ C(mode) + C(position)"),
        ("mode_x_position", "value ~ C(mode) + C(position)", "value ~ C(mode) * C(position)"),
    ):
        try:
            result[name] = _likelihood_ratio(frame, small, large)
        except (ValueError, np.linalg.LinAlgError) as error:
            result[name] = {"note": f"not fitted: {str(error).splitlines()[0]}"}
    return result


def cell_means(frame: pd.DataFrame) -> pd.DataFrame:
    """Mean and count of ``value`` per mode and position (the order-effects figure's points)."""
    return (
        frame.groupby(["mode", "position"], observed=True)["value"]
        .agg(["mean", "count"])
        .reset_index()
        .sort_values(["mode", "position"])
    )


def study_models(trials: pd.DataFrame, scores: pd.DataFrame | None) -> dict:
    """``mode_model`` and ``order_effects`` for each trial measure, and ``mode_model`` for
    each questionnaire score (``scores``: ``questionnaires.score``'s table; one value
    per participant and mode, so no order model)."""
    models = {}
    for measure in TRIAL_MEASURES:
        frame = trial_values(trials, measure)
        models[measure] = {"mixed": mode_model(frame), "order": order_effects(frame)}
    if scores is not None:
        for measure in SCORE_MEASURES:
            frame = scores[["participant", "mode", measure]].rename(columns={measure: "value"}).dropna()
            models[measure] = {"mixed": mode_model(frame)}
    return models
