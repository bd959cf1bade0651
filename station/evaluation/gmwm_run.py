"""The GMWM noise model of every graded axis, for the spec sheet's GMWM page.

Grading stays on the Allan variance (the profile's figures, its fit method); this adds,
beside it, each axis' Haar wavelet variance and its GMWM fit
(:func:`analysis.gmwm.selection.gmwm_analysis`) on the very samples the figures came
from: warm-up discarded, spikes removed as the rule said, no Haar window across a gap.
Whether a sheet carries it is the report service's choice (:mod:`station.services.report`).
"""

from __future__ import annotations

from dataclasses import replace

from analysis.errors import AnalysisError
from station.evaluation.grading import AxisGrade, RunGrade, UnitGrade
from station.evaluation.long_records import angle_buffer


def axis_with_gmwm(axis: AxisGrade, model: str, *, robust: bool = False) -> AxisGrade:
    """``axis`` whose analysis carries the GMWM of its analysed rate.

    Raises
    ------
    AnalysisError
        A record too short for the model, a fit that fails.
    """
    from analysis.gmwm.selection import gmwm_analysis  # scipy's optimiser: only when asked

    a = axis.analysis
    if a.rate_deg_s is None:
        raise AnalysisError(f"axis {axis.axis}: the analysed rate was not kept")
    gm = gmwm_analysis(a.rate_deg_s, a.sample_rate_hz, model=model, robust=robust,
                       gaps=a.gaps.count > 0, angle_out=angle_buffer(a.rate_deg_s))
    return replace(axis, analysis=replace(a, gmwm=gm))


def unit_with_gmwm(unit: UnitGrade, model: str, *, robust: bool = False) -> UnitGrade:
    """``unit`` with the GMWM of each axis; an axis the GMWM cannot fit (a record too short
    for the model) keeps its Allan figures alone and the unit a note saying why."""
    axes, notes = [], []
    for axis in unit.axes:
        try:
            axes.append(axis_with_gmwm(axis, model, robust=robust))
        except AnalysisError as exc:
            axes.append(axis)
            notes.append(f"{axis.axis}: GMWM ({model}) not fitted: {exc}")
    return replace(unit, axes=tuple(axes), notes=unit.notes + tuple(notes))


def run_with_gmwm(graded: RunGrade, model: str, *, robust: bool = False) -> RunGrade:
    """``graded`` with the GMWM (``model``: a model string or ``"auto"``) of every axis of
    every unit; the grades are unchanged."""
    return replace(graded, units=tuple(unit_with_gmwm(u, model, robust=robust)
                                       for u in graded.units))


def run_with_profile_gmwm(graded: RunGrade) -> RunGrade:
    """``graded`` with the GMWM its profile asks for (``[test] gmwm_model``), unchanged when
    the profile asks for none: how a view that grades a run itself (the TUI's spec
    screen, ``station fleet report``) shows the GMWM a report of it would carry."""
    model = graded.profile.gmwm_model
    return graded if model is None else run_with_gmwm(graded, model)
