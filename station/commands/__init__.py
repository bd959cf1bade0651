"""One module per ``station`` sub-command: each has ``register(subparsers)`` and ``run(args)``.

:data:`COMMAND_HELP` lists them (in the order ``station --help`` shows) with their
one-line summaries; :mod:`station.cli` imports a command's module only when it runs.
"""

from __future__ import annotations

#: Sub-command name -> one-line summary, in the order ``station --help`` lists them.
COMMAND_HELP: dict[str, str] = {
    "demo": "the whole job on two simulated IMUs: record, grade, store, spec sheet, Kalibr file",
    "analyze": "Allan deviation, noise-term fit and spec figures of a record",
    "reproduce": "re-run a published Monte Carlo (lv2015: WLS Allan fit)",
    "simulate": "write a simulated gyro run (model file or ARW + bias stability)",
    "model": "noise models: theoretical Allan curve, show, FOG from indicators",
    "davar": "dynamic Allan deviation, warm-up time and stationarity",
    "devices": "list supported device protocols and their simulations; serve a simulated gyro",
    "grade": "grade a run against a product profile",
    "report": "write spec-sheet reports (PDF, HTML, JSON, CSV) of a run",
    "fleet": "grade, analyze or report many runs on a Dask cluster",
    "results": "browse the results database: list, CSV, yield, trends",
    "record": "record gyros into an HDF5 run file",
    "watch": "follow a run file while it is being recorded",
    "serve": "the line's web page: yield, capability, control charts, unit sheets, live runs",
    "recover": "close a run file left open by a killed recorder",
    "reconcile": "model versus measurement: name the missing effects",
    "export": (
        "noise parameters in Kalibr, OpenVINS, MATLAB, gnss-ins-sim, allan_variance_ros "
        "or JSON form"
    ),
    "tui": "terminal user interface: run, watch and grade gyros",
}
