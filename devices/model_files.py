"""Noise model files: the one place that reads and writes model TOML on disk.

A model reference is a path to a ``.toml`` file or the name of a preset in
``<repo>/profiles/models/<name>.toml`` (``SRS2000``, ``VG951``, ``CRG20``,
``zhang2015-fog``, ``mems-typical``; case-insensitive). The text itself is parsed by
:meth:`analysis.models.NoiseModel.from_toml`.
"""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

from analysis.errors import ModelError
from analysis.models.accel_noise import ACCELEROMETER_TABLE, AccelNoiseModel
from analysis.models.terms import NoiseModel


def shipped_profiles_dir() -> Path:
    """The shipped ``profiles`` folder: the checkout's (an editable install, or running
    from the source tree), else the one a wheel installs under
    ``<prefix>/share/gyro-station/profiles`` (pyproject.toml's data-files)."""
    checkout = Path(__file__).resolve().parent.parent / "profiles"
    if checkout.is_dir():
        return checkout
    return Path(sys.prefix) / "share" / "gyro-station" / "profiles"


#: Folder of the preset models.
PRESET_DIR = shipped_profiles_dir() / "models"


def preset_names(preset_dir: Path = PRESET_DIR) -> list[str]:
    """Names of the preset models (file stems in ``preset_dir``), sorted."""
    if not preset_dir.is_dir():
        return []
    return sorted(p.stem for p in preset_dir.glob("*.toml"))


def resolve_model_path(ref: str | Path, preset_dir: Path = PRESET_DIR) -> Path:
    """The file a model reference names: an existing path, else a preset by name.

    Raises
    ------
    ModelError
        If ``ref`` is neither an existing file nor a preset name (the message lists them).
    """
    path = Path(ref)
    if path.is_file():
        return path
    name = str(ref)
    if path.suffix.lower() != ".toml" and "/" not in name and "\\" not in name:
        for stem in preset_names(preset_dir):
            if stem.lower() == name.lower():
                return preset_dir / f"{stem}.toml"
    raise ModelError(
        f"no model file or preset {name!r}; give a path to a .toml file or one of the presets: "
        f"{', '.join(preset_names(preset_dir)) or '(none found)'}"
    )


def load_noise_model(ref: str | Path, preset_dir: Path = PRESET_DIR) -> NoiseModel:
    """Read a noise model from a TOML file or a preset name.

    Parameters
    ----------
    ref : str or Path
        Path to a model TOML file, or a preset name (``"VG951"``).
    preset_dir : Path
        Folder of the presets (the project's ``profiles/models`` by default).

    Returns
    -------
    NoiseModel

    Raises
    ------
    ModelError
        If the reference names no file or preset, or the file is not a valid model
        (the message starts with the file's path).
    """
    path = resolve_model_path(ref, preset_dir)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ModelError(f"{path}: not a UTF-8 text file") from exc
    try:
        return NoiseModel.from_toml(text)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from exc


def load_accel_model(ref: str | Path, preset_dir: Path = PRESET_DIR) -> AccelNoiseModel | None:
    """The ``[accelerometer]`` table of a model file or preset, or None without one.

    Raises
    ------
    ModelError
        No such file or preset, not TOML, or a bad ``[accelerometer]`` table (the message
        starts with the file's path).
    """
    path = resolve_model_path(ref, preset_dir)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"{path}: not a TOML text file: {exc}") from exc
    table = doc.get(ACCELEROMETER_TABLE)
    if table is None:
        return None
    if not isinstance(table, dict):
        raise ModelError(f"{path}: [accelerometer] must be a table of keys")
    try:
        return AccelNoiseModel.from_table(table)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from exc


def save_noise_model(model: NoiseModel, path: str | Path, *, comment: str = "") -> Path:
    """Write a noise model as TOML, with ``comment`` lines as a ``#`` header.

    Returns
    -------
    Path
        The written file.
    """
    path = Path(path)
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    path.write_text(header + model.to_toml(), encoding="utf-8")
    return path
