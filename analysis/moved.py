"""The deprecation warning of a module that moved into a package of analysis/."""

from __future__ import annotations

import warnings


def warn_moved(old: str, new: str) -> None:
    """Warn that module ``old`` moved to ``new``, pointing at the code that imported it.

    Parameters
    ----------
    old, new : str
        Dotted module paths, e.g. ``"analysis.fit_log"`` and ``"analysis.fit.log"``.

    Warns
    -----
    DeprecationWarning
        Always; attributed to the first frame outside the import machinery.
    """
    # 1: here, 2: the moved module, 3: the code importing it (warnings.warn does not count the
    # import machinery's frames)
    warnings.warn(f"{old} moved to {new}: import it from {new} (the old path goes in a later "
                  "release)", DeprecationWarning, stacklevel=3)
