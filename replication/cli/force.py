"""``replication force``: the water-jet force on a surface (paper section 6)."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from replication.cli import jet_misses
from replication.cli.common import (
    about_the_input,
    emit_json,
    finite_float,
    finite_positive,
    int_between,
    positive_within,
    relay_warnings,
)

EPILOG_FORCE = """\
examples:
  replication force bucket.csv
      the paper's half jet (18 mm, 4.34 m/s, centred at x = 18, y = 0 mm) on the ADT surface
      (depth axis z) of a point cloud in millimetres
  replication force my_mesh.vtp --json
      any height field z(x, y) meshed in triangles, triangle strips or flat polygons (.vtk or
      .vtp; a warped quad is refused: how it is cut decides the surface), one JSON object
  replication force bucket.csv --solver sph --particle-radius 0.75 --duration 20
      an SPH simulation with SPlisHSPlasH instead of the thin-sheet model (pip install ".[sph]")

bucket.csv stands for any cloud; the case study's Pelton bucket (101 points) is written by
  python -c "import replication as rp; from replication.casestudy.shapes import pelton_bucket_cloud; rp.save_cloud(pelton_bucket_cloud(), 'bucket.csv')"
and a mesh such as my_mesh.vtp by `replication adt bucket.csv --depth z -o my_mesh.vtp`.

The jet travels along -z onto the surface. The default model (--solver sheet) is an inviscid
thin-sheet momentum balance (no SPH): each streamlet of the jet strikes a facet, loses its normal momentum and
spreads over the surface at the jet speed; the sheet follows concave creases, separates at
convex ones and may strike the surface again; the force is mass flow x (velocity in -
velocity out). The axial force is the component along the jet (positive when the jet pushes
the surface along -z). With the default half jet the surface must lie in y >= 0: y = 0 is
the symmetry (splitter) plane, as in the paper's half-domain simulation; --full-jet sends the
whole jet (off the centre line too) onto a surface spanning both sides of y = 0. A jet that
partly misses the surface is reported with the share of its mass flow that misses. Lengths
are in mm.

With --solver sph the half jet is simulated as the whole jet on the surface joined to its
mirror image in y = 0 (the engine has no symmetry plane), and the forces are halved: the y
force of the half surface alone is not simulated, and --json gives force_N's y as null (the
simulation's own mean_force and force series keep the mirrored pair's halved y, about 0).
"""  # noqa: E501 - a command to copy whole


def _load(path: str) -> tuple[Any, Any, str, int]:
    """(points, triangles, description, merged points) of a cloud or surface file."""
    from replication.errors import CloudFileError, DegenerateInputError
    from replication.io import CLOUD_SUFFIXES, SURFACE_FORMATS, load_cloud, read_surface
    from replication.surfaces import adt
    from replication.surfaces.adt import DEPTH_HINT, LINE_HINT

    suffix = Path(path).suffix.lower()
    if suffix.lstrip(".") in SURFACE_FORMATS:
        points, triangles = read_surface(path)
        return points, triangles, f"{points.shape[0]} vertices, {triangles.shape[0]} triangles", 0
    if suffix not in CLOUD_SUFFIXES:
        known = ", ".join((*CLOUD_SUFFIXES, *(f".{f}" for f in SURFACE_FORMATS)))
        raise CloudFileError(f"cannot read {path!r}: use a point cloud or surface file ({known})")
    cloud = load_cloud(path)
    try:
        surface = adt(cloud, depth="z")
    except DegenerateInputError as exc:  # the depth is the jet's axis z here: no --depth to try
        jet = "; the jet model needs a surface z(x, y) over an area of x-y"
        why = str(exc).replace(DEPTH_HINT, jet).replace(LINE_HINT, jet)
        raise DegenerateInputError(why) from exc
    what = f"{cloud.shape[0]} points -> ADT surface of {surface.n_triangles} triangles"
    return surface.points, surface.triangles, what, surface.n_merged


def _cmd_force(args: argparse.Namespace) -> int:
    from replication.casestudy import JetConfig, jet_force
    from replication.casestudy.units import to_metres
    from replication.cli.sph import check_force_options, force_sph
    from replication.errors import JetResolutionWarning, UsageError

    check_force_options(args)
    if not str(args.input):  # as an empty -o is: a misused command line
        raise UsageError("INPUT is empty: give the name of a point-cloud or surface file")
    if args.no_domain and args.domain is not None:
        raise UsageError("give either --domain or --no-domain, not both")
    # the values themselves are checked by their options, in the millimetres given (JetConfig's
    # messages quote metres); what is left is how they go together
    if not args.full_jet and args.center[1] != 0:
        raise UsageError(
            f"the half jet is centred on its symmetry plane y = 0, got --center {args.center[0]:g} "
            f"{args.center[1]:g}; add --full-jet for an off-centre jet"
        )
    # millimetres -> metres by the model's one conversion (replication.casestudy.units)
    domain = None if args.no_domain else tuple(to_metres(args.domain or (36.0, 30.0, 13.0)).tolist())
    config = JetConfig(
        diameter=float(to_metres(args.diameter)),
        velocity=args.velocity,
        density=args.density,
        center=tuple(to_metres(args.center).tolist()),
        full_jet=args.full_jet,
        domain=domain,
    )
    with relay_warnings(), about_the_input(args):
        points, triangles, what, merged = _load(args.input)
    shared = shared_report(args, config, points, triangles, merged)
    if args.solver == "sph":
        return force_sph(args, config, points, triangles, what, shared)
    # load the compiled kernels first (once per process), so the time is one evaluation's
    jet_force([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], JetConfig(domain=None), resolution=1)
    with relay_warnings() as caught:  # the streamlets may be too coarse for the surface: the library says so
        start = time.perf_counter()
        with about_the_input(args), _traced(args.resolution, config) as progress:
            result = jet_force(points, triangles, config, resolution=args.resolution, progress=progress)
        seconds = time.perf_counter() - start
    if result.n_streamlets_hit == 0 and not any(issubclass(w.category, JetResolutionWarning) for w in caught):
        print(
            f"warning: the jet misses the surface: none of its {result.n_streamlets} streamlets strikes it, "
            "so the force is 0 N (check --center and where the surface lies)",
            file=sys.stderr,
        )
    partly_missed = jet_misses.partly_missed(result, config, points, triangles)
    if partly_missed:
        print(partly_missed, file=sys.stderr)
    report: dict[str, Any] = {
        **shared,
        **result.as_dict(),
        "over_rho_q_v": result.axial_force / config.momentum_flux,
        "evaluation_seconds": seconds,
    }
    if args.json:
        emit_json(report)
        return 0
    jet = "full jet" if config.full_jet else "half jet (y >= 0, symmetry plane y = 0)"
    fx, fy, fz = (float(v) + 0.0 for v in result.force)  # + 0.0: no "-0"
    print(f"water-jet force on {args.input} ({what})")
    print(
        f"{jet}: {args.diameter:g} mm at {config.velocity:g} m/s along -z, "
        f"centred at ({args.center[0]:g}, {args.center[1]:g}) mm"
    )
    print(
        f"axial force {result.axial_force:.4g} N = {result.axial_force / config.momentum_flux:.3f} rho Q V; "
        f"force ({fx:.4g}, {fy:.4g}, {fz:.4g}) N"
    )
    print(
        f"mass flow {result.mass_flow_total:.4g} kg/s, {result.mass_flow_hit:.4g} kg/s on the surface; "
        f"{result.n_streamlets} streamlets, {result.n_parcels} parcels, {1e3 * seconds:.1f} ms"
    )
    if merged:
        print(f"merged {merged} point(s) sharing an (x, y) position (mean height)")
    return 0


#: From this resolution on (seconds of work: the work grows as its cube) progress is shown.
PROGRESS_FROM = 128


@contextlib.contextmanager
def _traced(resolution: int, config: Any) -> Iterator[Callable[[int], None] | None]:
    """A progress display of the streamlets traced at a fine resolution; None below it."""
    if resolution < PROGRESS_FROM:
        yield None
        return
    from replication.casestudy.jet import jet_streamlets
    from replication.cli.progress import progress

    total = int(jet_streamlets(config, resolution)[0].shape[0])
    with progress(total, f"jet streamlets traced (resolution {resolution})") as bar:
        yield lambda done: bar.update(done - bar.done)


def shared_report(
    args: argparse.Namespace, config: Any, points: Any, triangles: Any, merged: int
) -> dict[str, Any]:
    """The keys that ``force --json`` prints for both solvers, the input and jet alike.

    Each solver adds ``force_N``, ``axial_force_N`` and ``over_rho_q_v`` (the axial force over
    the jet's momentum flux rho Q V), then its own details.
    """
    from replication.casestudy.units import to_millimetres

    return {
        "input": args.input,
        "solver": args.solver,
        "vertices": int(points.shape[0]),
        "triangles": int(triangles.shape[0]),
        "points_merged": merged,
        "jet": {
            "center_mm": list(args.center),
            "diameter_mm": args.diameter,
            "velocity_m_s": config.velocity,
            "density_kg_m3": config.density,
            "full_jet": config.full_jet,
            "domain_mm": (
                None
                if config.domain is None
                else [round(v, 9) for v in to_millimetres(config.domain).tolist()]
            ),
        },
        "momentum_flux_N": config.momentum_flux,
        # the SPH result's own keys (settings.particle_radius, window, peak_time, time, ...) carry
        # no suffix: the JSON said millimetres beside metres without a word
        "units": UNITS,
    }


#: What ``force --json`` says of its units.
UNITS = "SI (m, s, kg, N) unless a key's suffix names the unit (_mm, _m_s, _kg_m3, _N)"


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``force`` subcommand."""
    from replication.casestudy import DEFAULT_RESOLUTION, MAX_RESOLUTION
    from replication.casestudy.jetconfig import DIAMETER_RANGE

    p = sub.add_parser(
        "force",
        help="force of the case study's water jet on a surface (paper section 6)",
        description=(
            "Force of a water jet on a faceted height-field surface z(x, y): by default a fast inviscid "
            "thin-sheet momentum balance (milliseconds), or with --solver sph an SPH simulation, the "
            "paper's method (seconds to minutes)."
        ),
        epilog=EPILOG_FORCE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "input",
        metavar="INPUT",
        help="point cloud (.csv, .txt, .xyz, .npy; triangulated by ADT with depth z) or surface (.vtk, .vtp)",
    )
    # the model's range, in millimetres as they are printed (1000 * 1e60 is 9.999999999999999e62)
    low, high = (float(f"{1000.0 * limit:.15g}") for limit in DIAMETER_RANGE)
    p.add_argument(
        "--center",
        type=finite_float,
        nargs=2,
        default=(18.0, 0.0),
        metavar=("X", "Y"),
        help="jet axis position in mm (default: 18 0)",
    )
    p.add_argument(
        "--diameter",
        type=positive_within(low, high, "diameter", "mm", "the range the force model computes in"),
        default=18.0,
        metavar="D",
        help="jet diameter in mm (default 18)",
    )
    p.add_argument(
        "--velocity", type=finite_positive, default=4.34, metavar="V", help="jet speed in m/s (default 4.34)"
    )
    p.add_argument(
        "--density", type=finite_positive, default=1000.0, help="water density in kg/m^3 (default 1000)"
    )
    p.add_argument(
        "--full-jet", action="store_true", help="the whole jet on a surface spanning both sides of y = 0"
    )
    p.add_argument(
        "--resolution",
        type=int_between(1, MAX_RESOLUTION, f"an integer from 1 to {MAX_RESOLUTION}"),
        default=DEFAULT_RESOLUTION,
        metavar="N",
        help=(
            f"streamlet rings across the jet radius, 4N spreading directions (default {DEFAULT_RESOLUTION}, "
            f"at most {MAX_RESOLUTION}: the work grows as N^3; from {PROGRESS_FROM} on, progress is shown)"
        ),
    )
    p.add_argument(
        "--domain",
        type=finite_positive,
        nargs=3,
        metavar=("LX", "LY", "LZ"),
        help="domain the surface must lie in, mm: x 0..LX, y 0..LY (-LY..LY with --full-jet), "
        "z 0..LZ (default: the paper's 36 30 13)",
    )
    p.add_argument("--no-domain", action="store_true", help="accept a surface anywhere")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    from replication.cli.sph import add_force_options

    add_force_options(p)
    p.set_defaults(func=_cmd_force)
