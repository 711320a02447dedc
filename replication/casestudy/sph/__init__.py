"""The case study on a real SPH solver: SPlisHSPlasH (optional extra ``sph``) in a child process.

The paper (section 6) scores every surface with an SPH simulation (DualSPHysics). This
package scores a surface with SPlisHSPlasH's Python bindings (``pip install ".[sph]"``):

* :mod:`.geometry` - the closed solid under a height field, its mirror image, the jet column;
* :mod:`.scene` - the engine's scene and input files;
* :mod:`.driver` - the child process that runs the engine (the only place it is imported);
* :mod:`.process` - starts the child with a timeout, relays progress, classifies failures;
* :mod:`.analysis` - binned series, quasi-steady mean and spread, impact peak;
* :mod:`.result` - :class:`SPHForce`, JSON and CSV;
* :mod:`.score` - :func:`sph_force`, :func:`surface_sph_force`, :func:`content_key`.

The set-up and its choices (free water column instead of the engine's emitter, force from
the fluid's momentum balance, the half jet as the whole jet on the mirrored surface) are
described in :func:`sph_force` and in the SPH report.
"""

from replication.casestudy.sph.result import SPHForce, read_result, write_result, write_series
from replication.casestudy.sph.score import (
    DEFAULT_TIMEOUT,
    INSTALL_HINT,
    content_key,
    engine_available,
    engine_version,
    require_engine,
    sph_force,
    surface_sph_force,
)
from replication.casestudy.sph.settings import METHODS, SPHSettings

__all__ = [
    "DEFAULT_TIMEOUT",
    "INSTALL_HINT",
    "METHODS",
    "SPHForce",
    "SPHSettings",
    "content_key",
    "engine_available",
    "engine_version",
    "read_result",
    "require_engine",
    "sph_force",
    "surface_sph_force",
    "write_result",
    "write_series",
]
