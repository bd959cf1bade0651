"""``station model``: noise models, their theoretical Allan deviation, and FOG models from
indicators.

* ``station model curve MODEL --taus log --json`` prints the model's theoretical Allan
  deviation, ``{"tau_s", "adev_deg_h", "terms_deg_h": {"<term>": [...]}}`` (and, in deg/s,
  the older keys ``adev`` and ``terms``; ``--output-units rad``: ``adev_rad_s``,
  ``terms_rad_s``, and the table in rad/s),
  on the tau grid of a record of ``--duration`` at ``--rate`` (``log``, ``octave``,
  ``all``) or at explicit taus (``--taus 0.1,1,10``);
* ``station model show MODEL`` prints a model (file or preset) as TOML;
* ``station model fog --arw A --bias-stability B [--average-s 100] [--correlation-s T]``
  prints (or writes with ``--out``) the white-noise-plus-Markov FOG model of
  ``docs/fog-model.md`` as TOML.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.units.conversions import S_PER_H
from devices.model_files import load_noise_model
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_fog_indicators,
    add_output_options,
    duration_type,
    output_family,
    print_json,
)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``model`` sub-command and its actions."""
    p = sub.add_parser(
        "model",
        help=COMMAND_HELP["model"],
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")

    curve = actions.add_parser("curve", help="theoretical Allan deviation of a model (deg/h "
                                               "or rad/s)")
    curve.add_argument("model", metavar="MODEL", help="model TOML file or preset name")
    curve.add_argument("--taus", default="log", metavar="GRID",
                       help="log, octave, all, or comma-separated taus in s (default log)")
    curve.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                       help="sample rate of the record the grid is for (default 10)")
    curve.add_argument("--duration", type=duration_type, default=4 * 3600.0, metavar="DURATION",
                       help="record length the grid (and transient terms) are for (default 4h)")
    add_output_options(curve, json_help="print JSON instead of a table")
    curve.set_defaults(handler=run)

    show = actions.add_parser("show", help="print a model as TOML")
    show.add_argument("model", metavar="MODEL", help="model TOML file or preset name")
    show.set_defaults(handler=run)

    fog = actions.add_parser("fog", help="FOG model from ARW and bias stability, as TOML")
    add_fog_indicators(fog, required=True)
    fog.add_argument("--name", default="", help="model name (default fog-two-indicators)")
    fog.add_argument("--out", type=Path, metavar="FILE.toml", help="write here instead of printing")
    fog.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the chosen ``model`` action."""
    from station.services.noise_models import (
        CurveRequest,
        FogRequest,
        fog_model,
        model_curve,
    )

    if args.action == "fog":
        fog = fog_model(FogRequest(args.arw, args.bias_stability, args.average_s,
                                   args.correlation_s, args.name, args.out))
        if not args.out:
            print(f"# {fog.comment}\n{fog.model.to_toml()}", end="")
        return 0
    if args.action == "show":
        print(load_noise_model(args.model).to_toml(), end="")
        return 0
    curve = model_curve(CurveRequest(args.model, args.taus, args.rate, args.duration))
    family = output_family(args)
    if args.json:
        print_json(curve.as_json(), family)
        return 0
    names = list(curve.terms)
    scale = S_PER_H * family.factor("deg/h")  # deg/s -> the unit printed
    print(f"# theoretical Allan deviation of {curve.model.name or args.model} in "
          f"{family.label('deg/h')}")
    print("  ".join(f"{h:>12}" for h in ["tau_s", "adev", *names]))
    for i, tau in enumerate(curve.tau_s):
        row = [tau, curve.adev[i] * scale, *(curve.terms[n][i] * scale for n in names)]
        print("  ".join(f"{v:12.5g}" for v in row))
    return 0
