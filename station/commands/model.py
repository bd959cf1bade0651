"""``station model``: noise models, their theoretical Allan deviation, and FOG models from indicators.

* ``station model curve MODEL --taus log --json`` prints the model's theoretical Allan
  deviation in deg/s, ``{"tau_s": [...], "adev": [...], "terms": {"<term>": [...]}}``,
  on the tau grid of a record of ``--duration`` at ``--rate`` (``log``, ``octave``,
  ``all``) or at explicit taus (``--taus 0.1,1,10``);
* ``station model show MODEL`` prints a model (file or preset) as TOML;
* ``station model fog --arw A --bias-stability B [--average-s 100] [--correlation-s T]``
  prints (or writes with ``--out``) the white-noise-plus-Markov FOG model of
  ``docs/fog-model.md`` as TOML.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from analysis.allan import resolve_m
from analysis.fog import fog_from_indicators
from analysis.simulate import n_samples_of
from devices.model_files import load_noise_model, save_noise_model
from station.commands.simulate import parse_duration
from station.errors import UsageError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``model`` sub-command and its actions."""
    p = sub.add_parser("model", help="noise models: theoretical Allan curve, show, FOG from indicators",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")

    curve = actions.add_parser("curve", help="theoretical Allan deviation of a model (deg/s)")
    curve.add_argument("model", metavar="MODEL", help="model TOML file or preset name")
    curve.add_argument("--taus", default="log", metavar="GRID",
                       help="log, octave, all, or comma-separated taus in s (default log)")
    curve.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                       help="sample rate of the record the grid is for (default 10)")
    curve.add_argument("--duration", type=parse_duration, default=4 * 3600.0, metavar="DURATION",
                       help="record length the grid (and transient terms) are for (default 4h)")
    curve.add_argument("--json", action="store_true", help="print JSON instead of a table")
    curve.set_defaults(handler=run)

    show = actions.add_parser("show", help="print a model as TOML")
    show.add_argument("model", metavar="MODEL", help="model TOML file or preset name")
    show.set_defaults(handler=run)

    fog = actions.add_parser("fog", help="FOG model from ARW and bias stability, as TOML")
    fog.add_argument("--arw", type=float, required=True, metavar="DEG_RT_H",
                     help="angle random walk in deg/sqrt(h)")
    fog.add_argument("--bias-stability", type=float, required=True, metavar="DEG_H",
                     help="bias stability in deg/h (1 sigma of --average-s averages)")
    fog.add_argument("--average-s", type=float, default=100.0, metavar="S",
                     help="averaging time of the bias stability in s (default 100)")
    fog.add_argument("--correlation-s", type=float, metavar="S",
                     help="correlation time of the Markov process in s (default: --average-s)")
    fog.add_argument("--name", default="", help="model name (default fog-two-indicators)")
    fog.add_argument("--out", type=Path, metavar="FILE.toml", help="write here instead of printing")
    fog.set_defaults(handler=run)


def curve_taus(grid: str, sample_rate_hz: float, duration_s: float) -> np.ndarray:
    """Averaging times (s) of a named grid for a record, or of a comma-separated list.

    Raises
    ------
    UsageError
        If the list holds something that is not a number.
    """
    if grid in ("log", "octave", "all"):
        n = n_samples_of(duration_s, sample_rate_hz)
        return resolve_m(grid, n, sample_rate_hz) / sample_rate_hz
    try:
        taus = np.array([float(x) for x in grid.split(",") if x.strip()])
    except ValueError as exc:
        raise UsageError(f"--taus must be log, octave, all or numbers like 0.1,1,10; got {grid!r}") from exc
    if taus.size == 0:
        raise UsageError("--taus names no averaging time")
    return taus


def run(args: argparse.Namespace) -> int:
    """Run the chosen ``model`` action."""
    if args.action == "fog":
        params = fog_from_indicators(args.arw, args.bias_stability, average_s=args.average_s,
                                     correlation_s=args.correlation_s)
        model = params.noise_model(args.name)
        comment = (f"white noise + first-order Markov FOG (docs/fog-model.md): Markov sigma "
                   f"{params.markov_sigma_deg_h:.6g} deg/h, T {params.correlation_s:g} s")
        if args.out:
            save_noise_model(model, args.out, comment=comment)
        else:
            print(f"# {comment}\n{model.to_toml()}", end="")
        return 0
    model = load_noise_model(args.model)
    if args.action == "show":
        print(model.to_toml(), end="")
        return 0
    taus = curve_taus(args.taus, args.rate, args.duration)
    adev = model.adev(taus, duration_s=args.duration)
    terms = {name: np.sqrt(avar) for name, avar in model.term_avars(taus, duration_s=args.duration).items()}
    if args.json:
        print(json.dumps({"tau_s": taus.tolist(), "adev": adev.tolist(),
                          "terms": {k: v.tolist() for k, v in terms.items()}}))
        return 0
    names = list(terms)
    print(f"# theoretical Allan deviation of {model.name or args.model} in deg/s")
    print("  ".join(f"{h:>12}" for h in ["tau_s", "adev", *names]))
    for i, tau in enumerate(taus):
        row = [tau, adev[i], *(terms[n][i] for n in names)]
        print("  ".join(f"{v:12.5g}" for v in row))
    return 0
