"""The file formats of ``station export``: each tool's own keys, units and layout.

Every writer takes the per-axis :class:`analysis.figures.tool_units.AxisNoise` and returns the
file's text; the conversions are :mod:`analysis.figures.tool_units`' and ``docs/units.md`` lists
them. Every number carries its unit in a comment or a key.

=====================  ==========================  ========================================
format                 file                        read by
=====================  ==========================  ========================================
``kalibr``             ``imu.yaml``                Kalibr (``--imu``), and tools taking it
``openvins``           ``kalibr_imu_chain.yaml``   OpenVINS (OpenCV ``FileStorage``)
``matlab``             ``gyro_params.m`` / ``.json`` MATLAB's ``gyroparams`` (``imuSensor``)
``gnss-ins-sim``       ``gyro_err.py``             gnss-ins-sim's ``imu_model.IMU(accuracy=)``
``allan-variance-ros`` ``imu.yaml``                as allan_variance_ros' analysis.py writes it
``json``               ``noise.json``              anything: every figure in both unit families
=====================  ==========================  ========================================

Kalibr, OpenVINS and allan_variance_ros take one value per sensor: the largest over the
axes (allan_variance_ros' own choice), each axis listed in a comment. A record with
accelerometers (``ExportContext.accel``) gets the accelerometer keys too, in SI
(:mod:`analysis.figures.tool_units_accel`); a gyro-only record's files leave them out and the
header says so (a value we did not measure would be invented).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from analysis.figures.tool_units import AxisNoise, rate_rad_s
from analysis.figures.tool_units_accel import AccelNoise
from station.errors import UsageError

_ACCEL_NOTE = (
    "gyroscope only: this record has no accelerometer axes (a gyro, or an IMU recorded "
    "without them); add accelerometer_noise_density and accelerometer_random_walk before use"
)


@dataclass(frozen=True)
class ExportContext:
    """What a file's header names: the record, the unit, the method and the topic."""

    source: str
    unit: str | None = None
    method: str = "logwls"
    rostopic: str = "/imu0"
    earth_rate_removed: bool = False
    #: The record's accelerometer axes (empty: a gyro-only record).
    accel: tuple[AccelNoise, ...] = ()

    def origin(self) -> str:
        """``<file>[, unit <id>], <method> analysis``."""
        unit = f", unit {self.unit}" if self.unit else ""
        return f"{self.source}{unit}, {self.method} analysis (station export)"


def _yaml(key: str, value: object, comment: str = "", indent: str = "") -> str:
    """One ``key: value  # comment`` line, the value written by PyYAML."""
    import yaml  # PyYAML: only when a YAML file is written

    line = yaml.safe_dump({key: value}, default_flow_style=True, width=1000).strip()[1:-1]
    return f"{indent}{line}" + (f"  # {comment}" if comment else "")


def _rate(axes: Sequence[AxisNoise]) -> float:
    """The record's sample rate, Hz, to 10 digits (a rate measured from time stamps)."""
    return float(f"{axes[0].sample_rate_hz:.10g}")


def _largest(axes: Sequence[AxisNoise]) -> tuple[AxisNoise, AxisNoise]:
    """(the axis of the largest noise density, the axis of the largest random walk)."""
    return (max(axes, key=lambda a: a.arw_deg_rt_h), max(axes, key=lambda a: a.rrw_deg_h_1_5))


def _axis_comments(axes: Sequence[AxisNoise]) -> list[str]:
    out = []
    for a in axes:
        out.append(
            f"#   {a.name}: noise density {a.noise_density_rad_s_rt_hz:.6g} rad/s/sqrt(Hz) "
            f"(ARW {a.arw_deg_rt_h:.4g} deg/sqrt(h), {(a.sources or {}).get('arw', '')}); "
            f"random walk {a.random_walk_rad_s2_rt_hz:.6g} rad/s^2/sqrt(Hz) "
            f"(K {a.rrw_deg_h_1_5:.4g} deg/h^1.5, {(a.sources or {}).get('rrw', '')})"
        )
    return out


def fewer_axes_note(tool: str, axes: Sequence[AxisNoise]) -> str:
    """The sentence saying that ``tool`` applies its one value to all three gyroscope axes
    while fewer were measured ('' with three or more)."""
    if len(axes) >= 3:
        return ""
    names = ", ".join(a.name for a in axes)
    return (f"{tool} applies one value to all three gyroscope axes; only {len(axes)} of three "
            f"measured ({names}): the others are not characterized by this file")


def _fewer_axes_comment(tool: str, axes: Sequence[AxisNoise], mark: str = "#") -> list[str]:
    note = fewer_axes_note(tool, axes)
    return [f"{mark} {note}"] if note else []


def _bound_text(axis: AxisNoise) -> str:
    """', an upper bound' where the axis' random walk is a bound, not a fit."""
    return (", an UPPER BOUND: the record does not resolve it"
            if "upper bound" in (axis.sources or {}).get("rrw", "") else "")


def _gyro_lines(axes: Sequence[AxisNoise], indent: str = "") -> list[str]:
    nd_axis, rw_axis = _largest(axes)
    return [
        _yaml(
            "gyroscope_noise_density",
            nd_axis.noise_density_rad_s_rt_hz,
            f"rad/s/sqrt(Hz), continuous time (axis {nd_axis.name})",
            indent,
        ),
        _yaml(
            "gyroscope_random_walk",
            rw_axis.random_walk_rad_s2_rt_hz,
            f"rad/s^2/sqrt(Hz), continuous time (axis {rw_axis.name}{_bound_text(rw_axis)})",
            indent,
        ),
    ]


def _accel_comments(accel: Sequence[AccelNoise]) -> list[str]:
    sources = [a.sources or {} for a in accel]
    return [
        f"#   {a.name}: noise density {a.noise_density_m_s2_rt_hz:.6g} m/s^2/sqrt(Hz) "
        f"(VRW {a.vrw_m_s_rt_h:.4g} m/s/sqrt(h), {s.get('vrw', '')}); random walk "
        f"{a.random_walk_m_s3_rt_hz:.6g} m/s^3/sqrt(Hz) (K {a.accel_random_walk_m_s_h1_5:.4g} "
        f"m/s/h^1.5, {s.get('accel_random_walk', '')})"
        for a, s in zip(accel, sources, strict=True)
    ]


def _bound_said(axis: AccelNoise, figure: str) -> str:
    """``"; UPPER BOUND ..."`` where ``axis``' ``figure`` is a bound the record sets, else ""."""
    return ("; UPPER BOUND, not a measurement: the record does not resolve it"
            if figure in axis.upper_bounds else "")


def _accel_lines(ctx: ExportContext, indent: str = "") -> list[str]:
    """The accelerometer keys of Kalibr's noise model (the largest over the axes; a value
    that is only an upper bound the record sets says so on its line), or the comment that
    says the record has none."""
    if not ctx.accel:
        return [f"{indent}# {_ACCEL_NOTE}"]
    nd = max(ctx.accel, key=lambda a: a.noise_density_m_s2_rt_hz)
    rw = max(ctx.accel, key=lambda a: a.random_walk_m_s3_rt_hz)
    return [
        _yaml("accelerometer_noise_density", nd.noise_density_m_s2_rt_hz,
              f"m/s^2/sqrt(Hz), continuous time (axis {nd.name}){_bound_said(nd, 'vrw')}",
              indent),
        _yaml("accelerometer_random_walk", rw.random_walk_m_s3_rt_hz,
              f"m/s^3/sqrt(Hz), continuous time (axis {rw.name})"
              f"{_bound_said(rw, 'accel_random_walk')}", indent),
    ]


def _header_note(ctx: ExportContext) -> list[str]:
    return ([f"# {_ACCEL_NOTE}"] if not ctx.accel else
            ["# accelerometers: the largest value over the axes is written; per axis:",
             *_accel_comments(ctx.accel)])


def kalibr(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """Kalibr's ``imu.yaml``: ``gyroscope_noise_density`` (rad/s/sqrt(Hz)),
    ``gyroscope_random_walk`` (rad/s^2/sqrt(Hz)), ``rostopic``, ``update_rate`` (Hz)."""
    rate = _rate(axes)
    return "\n".join(
        [
            f"# Kalibr IMU noise parameters of {ctx.origin()}",
            *_header_note(ctx),
            "# gyroscopes: the largest value over the axes is written; per axis:",
            *_axis_comments(axes),
            *_fewer_axes_comment("Kalibr", axes),
            "",
            *_gyro_lines(axes),
            *(_accel_lines(ctx) if ctx.accel else []),
            "",
            _yaml("rostopic", ctx.rostopic, "the IMU topic: check it"),
            _yaml("update_rate", rate, "Hz, the record's sample rate (for the discrete values)"),
            "",
        ]
    )


def openvins(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """OpenVINS' ``kalibr_imu_chain.yaml``: an ``imu0`` block with Kalibr's keys, the
    ``time_offset`` and the ``model``; the OpenCV header ``%YAML:1.0`` its reader needs."""
    rate = _rate(axes)
    return "\n".join(
        [
            "%YAML:1.0 # OpenCV FileStorage header: OpenVINS reads this file with cv::FileStorage",
            f"# OpenVINS IMU noise parameters of {ctx.origin()}",
            *_header_note(ctx),
            "# intrinsics (Tw, R_IMUtoGYRO, Tg) are not written: the station does not "
            "calibrate them",
            "# gyroscopes: the largest value over the axes is written; per axis:",
            *_axis_comments(axes),
            *_fewer_axes_comment("OpenVINS", axes),
            "",
            "imu0:",
            *(_accel_lines(ctx, "  ") if ctx.accel else []),
            *_gyro_lines(axes, "  "),
            _yaml("rostopic", ctx.rostopic, "the IMU topic: check it", "  "),
            _yaml("time_offset", 0.0, "s", "  "),
            _yaml("update_rate", rate, "Hz, the record's sample rate", "  "),
            _yaml("model", "kalibr", "", "  "),
            "",
        ]
    )


def allan_variance_ros(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """allan_variance_ros' ``imu.yaml`` (its analysis.py output): the gyroscope section,
    the largest value over the axes in rad units, ``rostopic`` and ``update_rate``."""
    rate = _rate(axes)
    return "\n".join(
        [
            f"# allan_variance_ros imu.yaml of {ctx.origin()}",
            *_header_note(ctx),
            "# gyroscopes, per axis:",
            *_axis_comments(axes),
            *_fewer_axes_comment("allan_variance_ros", axes),
            "",
            *(["#Accelerometer", *_accel_lines(ctx), ""] if ctx.accel else []),
            "#Gyroscope",
            *_gyro_lines(axes),
            "",
            _yaml("rostopic", ctx.rostopic, "Make sure this is correct"),
            _yaml("update_rate", rate, "Hz, Make sure this is correct"),
            "",
        ]
    )


def _need_bias_instability(missing: Sequence[str], what: str = "axis") -> None:
    """Refuse MATLAB's parameters when an axis has no bias instability."""
    if missing:
        raise UsageError(
            f"no bias instability for {what} {', '.join(missing)}: MATLAB's "
            f"BiasInstability needs one (record longer)"
        )


def _matlab_values(axes: Sequence[AxisNoise]) -> dict[str, list[float]]:
    """gyroparams' fields in its units (rad/s/sqrt(Hz), rad/s, (rad/s) sqrt(Hz), rad/s)."""
    _need_bias_instability([a.name for a in axes if a.bias_instability_deg_h is None])
    return {
        "NoiseDensity": [a.noise_density_rad_s_rt_hz for a in axes],
        "BiasInstability": [rate_rad_s(a.bias_instability_deg_h or 0.0) for a in axes],
        "RandomWalk": [a.random_walk_rad_s2_rt_hz for a in axes],
        "ConstantBias": [rate_rad_s(a.bias_deg_h) for a in axes],
    }


_MATLAB_UNITS = {
    "NoiseDensity": "(rad/s)/sqrt(Hz)",
    "BiasInstability": "rad/s (sigma_min / 0.664)",
    "RandomWalk": "(rad/s)*sqrt(Hz)",
    "ConstantBias": "rad/s",
}


def _accel_matlab_values(accel: Sequence[AccelNoise]) -> dict[str, list[float]]:
    """accelparams' fields in its units (m/s^2/sqrt(Hz), m/s^2, (m/s^2) sqrt(Hz), m/s^2)."""
    _need_bias_instability([a.name for a in accel if a.bias_instability_m_s2 is None],
                           "accelerometer axis")
    return {
        "NoiseDensity": [a.noise_density_m_s2_rt_hz for a in accel],
        "BiasInstability": [a.bias_instability_m_s2 or 0.0 for a in accel],
        "RandomWalk": [a.random_walk_m_s3_rt_hz for a in accel],
        "ConstantBias": [a.accel_bias_m_s2 for a in accel],
    }


_ACCEL_MATLAB_UNITS = {
    "NoiseDensity": "(m/s^2)/sqrt(Hz)",
    "BiasInstability": "m/s^2 (sigma_min / 0.664)",
    "RandomWalk": "(m/s^2)*sqrt(Hz)",
    "ConstantBias": "m/s^2 (gravity removed)",
}


#: The accelerometer figure each of accelparams' fields is written from.
_ACCEL_MATLAB_FIGURE = {"NoiseDensity": "vrw", "BiasInstability": "bias_instability",
                        "RandomWalk": "accel_random_walk"}


def _accel_bounds(accel: Sequence[AccelNoise]) -> dict[str, list[str]]:
    """accelparams' fields (by name) whose value on the listed axes is an upper bound the
    record sets, not a measurement ({} when none)."""
    out = {field: [a.name for a in accel if figure in a.upper_bounds]
           for field, figure in _ACCEL_MATLAB_FIGURE.items()}
    return {k: v for k, v in out.items() if v}


def _accel_bound_comments(accel: Sequence[AccelNoise], mark: str) -> list[str]:
    """One comment line (``mark`` its comment sign) per accelparams field written as an
    upper bound."""
    return [f"{mark} UPPER BOUND, not a measurement (the record does not resolve it): {field} "
            f"of {', '.join(names)}" for field, names in _accel_bounds(accel).items()]


def _matlab_call(name: str, function: str, values: dict[str, list[float]]) -> list[str]:
    lines = [f"{name} = {function}( ..."]
    fields = list(values)
    for i, k in enumerate(fields):
        v = values[k]
        text = repr(v[0]) if len(v) == 1 else "[" + " ".join(repr(x) for x in v) + "]"
        lines.append(f"    '{k}', {text}{', ...' if i < len(fields) - 1 else ');'}")
    return lines


def matlab(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """A MATLAB script that builds ``params = gyroparams(...)`` with ``NoiseDensity``,
    ``BiasInstability``, ``RandomWalk`` and ``ConstantBias``, each a scalar (one axis) or
    a 1x3 row vector (x, y, z), in gyroparams' units; with accelerometers also
    ``aparams = accelparams(...)`` with the same fields in SI."""
    values = _matlab_values(axes)
    earth = "Earth rate removed" if ctx.earth_rate_removed else "Earth rate NOT removed"
    lines = [
        f"% MATLAB gyroparams of {ctx.origin()}",
        f"% axes: {', '.join(a.name for a in axes)}; units as gyroparams expects them:",
    ]
    lines += [f"%   {k}: {u}" for k, u in _MATLAB_UNITS.items()]
    lines += [f"% ConstantBias is the record's mean rate ({earth})"]
    lines += _fewer_axes_comment("gyroparams (a scalar)", axes, "%")
    lines += [f"% {a.name}: RandomWalk is an upper bound, the record does not resolve it"
              for a in axes if _bound_text(a)]
    lines += _matlab_call("params", "gyroparams", values)
    if ctx.accel:
        lines += [f"% accelparams of the accelerometer axes "
                  f"{', '.join(a.name for a in ctx.accel)}; units:"]
        lines += [f"%   {k}: {u}" for k, u in _ACCEL_MATLAB_UNITS.items()]
        lines += _accel_bound_comments(ctx.accel, "%")
        lines += _matlab_call("aparams", "accelparams", _accel_matlab_values(ctx.accel))
    return "\n".join(lines) + "\n"


def matlab_json(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """gyroparams' fields as JSON for MATLAB's ``jsondecode`` (each a list over the axes),
    with ``units``, ``axes`` and ``source``."""
    body = {
        **_matlab_values(axes),
        "units": _MATLAB_UNITS,
        "axes": [a.name for a in axes],
        "source": ctx.origin(),
        "earth_rate_removed": ctx.earth_rate_removed,
    }
    if ctx.accel:
        body["accelparams"] = {**_accel_matlab_values(ctx.accel), "units": _ACCEL_MATLAB_UNITS,
                               "axes": [a.name for a in ctx.accel],
                               "upper_bounds": _accel_bounds(ctx.accel)}
    return json.dumps(body, indent=2) + "\n"


def gnss_ins_sim(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """A Python module defining ``gyro_err``, gnss-ins-sim's gyro keys: ``gyro_b`` (deg/h),
    ``gyro_arw`` (deg/sqrt(h)), ``gyro_b_stability`` (deg/h) and, where a Gauss-Markov
    term exists, ``gyro_b_corr`` (s; the Gauss-Markov sigma then is ``gyro_b_stability``);
    with three accelerometer axes ``imu_err``, those and ``accel_b`` (m/s^2, gravity
    removed), ``accel_vrw`` (m/s/sqrt(h)), ``accel_b_stability`` (m/s^2, B)."""

    def arr(xs: Sequence[float]) -> str:
        return (
            "np.array(["
            + ", ".join("np.inf" if math.isinf(x) else repr(float(x)) for x in xs)
            + "])"
        )

    gm = [a.main_gauss_markov for a in axes]
    stability, corr, how = [], [], []
    for a, g in zip(axes, gm, strict=True):
        if g is not None:
            stability.append(g.sigma_deg_h)
            corr.append(g.tau_s)
            how.append(f"{a.name}: Gauss-Markov sigma {g.sigma_deg_h:.4g} deg/h, T {g.tau_s:.4g} s")
        else:
            if a.bias_instability_deg_h is None:
                raise UsageError(
                    f"no bias instability for axis {a.name}: gnss-ins-sim's "
                    f"gyro_b_stability needs one (record longer)"
                )
            stability.append(a.bias_instability_deg_h)
            corr.append(float("inf"))
            how.append(
                f"{a.name}: bias instability B = sigma_min / 0.664 = "
                f"{a.bias_instability_deg_h:.4g} deg/h (no Gauss-Markov term)"
            )
    earth = "Earth rate removed" if ctx.earth_rate_removed else "Earth rate NOT removed"
    lines = [
        f"# gnss-ins-sim {'IMU' if len(ctx.accel) == 3 else 'gyro'} error parameters of "
        f"{ctx.origin()}",
        *(["# gyroscope only: merge with your accelerometer's before use, e.g.",
           "#   imu = imu_model.IMU(accuracy={**gyro_err, 'accel_b': ..., 'accel_vrw': ...,",
           "#                                 'accel_b_stability': ...}, axis=6)"]
          if len(ctx.accel) != 3 else
          ["# gyroscopes and accelerometers: imu_model.IMU(accuracy=imu_err, axis=6)"]),
        f"# axes: {', '.join(a.name for a in axes)}",
        *(f"#   {h}" for h in how),
        "import numpy as np",
        "",
        "gyro_err = {",
        f"    'gyro_b': {arr([a.bias_deg_h for a in axes])},"
        f"  # deg/h, the record's mean rate ({earth})",
        f"    'gyro_arw': {arr([a.arw_deg_rt_h for a in axes])},  # deg/sqrt(h)",
        f"    'gyro_b_stability': {arr(stability)},  # deg/h",
    ]
    if any(g is not None for g in gm):
        lines.append(
            f"    'gyro_b_corr': {arr(corr)},  # s (inf: no Gauss-Markov term on that axis)"
        )
    lines += ["}", ""]
    if len(ctx.accel) == 3:
        values = _accel_matlab_values(ctx.accel)  # the same SI figures (B checked there)
        lines += [
            *_accel_bound_comments(ctx.accel, "#"),
            "imu_err = {",
            "    **gyro_err,",
            f"    'accel_b': {arr(values['ConstantBias'])},  # m/s^2, the mean, gravity removed",
            f"    'accel_vrw': {arr([a.vrw_m_s_rt_h for a in ctx.accel])},  # m/s/sqrt(h)",
            f"    'accel_b_stability': {arr(values['BiasInstability'])},"
            "  # m/s^2, B = sigma_min / 0.664",
            "}",
            "",
        ]
    return "\n".join(lines)


def json_format(axes: Sequence[AxisNoise], ctx: ExportContext) -> str:
    """Every figure of every gyro axis in both unit families (:meth:`AxisNoise.as_json`),
    and of every accelerometer axis in SI (``accel_axes``, :meth:`AccelNoise.as_json`)."""
    body = {
        "source": ctx.source,
        "unit": ctx.unit,
        "method": ctx.method,
        "earth_rate_removed": ctx.earth_rate_removed,
        "axes": [a.as_json() for a in axes],
        "accel_axes": [a.as_json() for a in ctx.accel],
    }
    return json.dumps(body, indent=2) + "\n"


def _any_axes(n: int, names: Sequence[str]) -> None:
    if n < 1:
        raise UsageError("the record has no axis to export")


def _one_or_three(tool: str) -> Callable[[int, Sequence[str]], None]:
    def check(n: int, names: Sequence[str]) -> None:
        if n not in (1, 3) or (tool == "gnss-ins-sim" and n != 3):
            want = (
                "three axes (x, y, z)" if tool == "gnss-ins-sim" else "one axis or three (x, y, z)"
            )
            raise UsageError(
                f"{tool} takes {want}; the record has {n} ({', '.join(names)}): "
                f"pick one with --axis, or use --format json"
            )

    return check


@dataclass(frozen=True)
class ExportFormat:
    """A format: its writer, default file name and the axis counts it can hold."""

    write: Callable[[Sequence[AxisNoise], ExportContext], str]
    default_name: str
    check_axes: Callable[[int, Sequence[str]], None] = _any_axes
    description: str = ""
    #: The file is loaded by name as code (MATLAB script, Python module): its default name
    #: must be an identifier.
    identifier_name: bool = False


FORMATS: dict[str, ExportFormat] = {
    "kalibr": ExportFormat(kalibr, "imu.yaml", description="Kalibr imu.yaml"),
    "openvins": ExportFormat(
        openvins, "kalibr_imu_chain.yaml", description="OpenVINS kalibr_imu_chain.yaml"
    ),
    "matlab": ExportFormat(
        matlab,
        "gyro_params.m",
        _one_or_three("MATLAB's gyroparams"),
        "MATLAB gyroparams (.m script, or .json for jsondecode)",
        True,
    ),
    "gnss-ins-sim": ExportFormat(
        gnss_ins_sim,
        "gyro_err.py",
        _one_or_three("gnss-ins-sim"),
        "gnss-ins-sim IMU error dictionary (Python)",
        True,
    ),
    "allan-variance-ros": ExportFormat(
        allan_variance_ros, "allan_imu.yaml", description="allan_variance_ros imu.yaml"
    ),
    "json": ExportFormat(json_format, "noise.json", description="every figure, both unit families"),
}


def check_export_axes(fmt: str, names: Sequence[str], has_accel: bool) -> None:
    """Refuse gyro axes ``names`` that format ``fmt`` cannot hold; a record of
    accelerometer axes only (no name, ``has_accel``) goes to ``json`` alone.

    Raises
    ------
    UsageError
        One line naming what the format needs.
    """
    if not names and has_accel:
        if fmt != "json":
            raise UsageError(f"the record has accelerometer axes only; {fmt} needs gyroscope "
                             f"figures too: use --format json")
        return
    FORMATS[fmt].check_axes(len(names), names)


def render(fmt: str, axes: Sequence[AxisNoise], ctx: ExportContext, *, suffix: str = "") -> str:
    """The text of ``fmt`` for ``axes`` (``suffix`` ``.json`` turns ``matlab`` into its JSON form).

    Raises
    ------
    UsageError
        An unknown format, or axes the format cannot hold.
    """
    if fmt not in FORMATS:
        raise UsageError(f"unknown format {fmt!r}: one of {', '.join(FORMATS)}")
    spec = FORMATS[fmt]
    check_export_axes(fmt, [a.name for a in axes], bool(ctx.accel))
    if not axes:  # an accelerometer-only record: json alone takes it
        return json_format(axes, ctx)
    if fmt == "matlab" and suffix.lower() == ".json":
        return matlab_json(axes, ctx)
    return spec.write(axes, ctx)
