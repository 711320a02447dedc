"""The ``replication`` command line.

Only this module prints or sets an exit status: library errors (:class:`ReplicationError`)
become a one-line message on stderr and exit status 1; usage errors exit with status 2
(argparse); an interrupt exits with 130.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from replication import __version__
from replication.errors import DuplicatePointsWarning, InputError, ReplicationError

__all__ = ["main", "build_parser"]

EPILOG_ADT = """\
examples:
  replication adt cloud.csv -o surface.vtk
      triangulate your own cloud (csv/txt/xyz with 3 columns, or .npy)
  replication adt --random 200 --seed 1 --step 1 -o surface.vtp --save-cloud cloud.csv
      a random 200-point cloud on a 1 mm lattice in the case-study box, kept in cloud.csv
  replication adt sphere.xyz --split z=0 -o closed.vtk
      a closed surface: two halves above and below z = 0, stitched along the plane
  replication adt cloud.csv --json
      report the depth axis, merges and triangle count as JSON, writing nothing

The depth axis is the axis along which the surface is a height field: by default the axis of
least spread (paper eq. 7), ties broken z first, then y (eq. 8). Points that share a position
in the projection plane become one vertex by --duplicates (default: mean depth, with a
warning); --duplicates raise refuses such clouds instead.
"""


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _add_adt_parser(sub: argparse._SubParsersAction) -> None:
    from replication.io import CLOUD_SUFFIXES, SURFACE_FORMATS
    from replication.surfaces import BACKENDS, DEPTH_RULES, DUPLICATE_POLICIES

    p = sub.add_parser(
        "adt",
        help="build an ADT surface from a point cloud (paper section 3.2)",
        description=(
            "Build an adapted-Delaunay-triangulation (ADT) surface: choose a depth axis from the "
            "spread of the coordinates, project the points onto the other two axes, "
            "triangulate in 2-D and lift the triangles back to 3-D. Every input point is a "
            "vertex of the surface (after merging points that share a projected position)."
        ),
        epilog=EPILOG_ADT,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "input",
        nargs="?",
        metavar="INPUT",
        help=f"point-cloud file ({', '.join(CLOUD_SUFFIXES)}); omit when using --random",
    )
    p.add_argument(
        "-o", "--output", metavar="OUT", help="surface file to write (.vtk or .vtp); omit to write nothing"
    )
    p.add_argument(
        "--format",
        choices=SURFACE_FORMATS,
        help="vtk: compact legacy ASCII; vtp: binary VTK XML (default: from the OUT suffix)",
    )
    p.add_argument(
        "--depth",
        choices=DEPTH_RULES,
        default="min",
        help="depth axis: the axis of min or max spread, or an imposed axis (default: min)",
    )
    p.add_argument(
        "--duplicates",
        choices=DUPLICATE_POLICIES,
        default="mean",
        help="points sharing a projected position: merge with the mean/min/max/first depth, "
        "or raise an error (default: mean)",
    )
    p.add_argument(
        "--split",
        metavar="AXIS=OFFSET",
        help="closed surface: split the cloud by the plane AXIS=OFFSET (e.g. z=0) and stitch the two halves",
    )
    p.add_argument(
        "--backend", choices=BACKENDS, default="auto", help="2-D Delaunay backend (default: auto = sweephull)"
    )
    g = p.add_argument_group("random cloud (instead of INPUT)")
    g.add_argument("--random", type=_positive_int, metavar="N", help="generate N random points")
    g.add_argument("--seed", type=int, default=None, metavar="S", help="random seed (default: fresh entropy)")
    g.add_argument(
        "--box",
        type=float,
        nargs=6,
        metavar=("XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"),
        help="domain of the random cloud (default: the case study's 0 36 0 30 0 13, in mm)",
    )
    g.add_argument(
        "--step", type=float, metavar="H", help="draw coordinates on a lattice of step H (the case study: 1)"
    )
    g.add_argument(
        "--save-cloud", metavar="FILE", help="also write the generated points (.csv, .txt, .xyz, .npy)"
    )
    p.add_argument("--json", action="store_true", help="print one JSON object describing what was done")
    p.set_defaults(func=_cmd_adt)


def _load_or_generate(args: argparse.Namespace) -> tuple[np.ndarray, str, dict[str, Any]]:
    from replication.io import load_cloud
    from replication.surfaces import CASE_STUDY_BOX, Box, random_cloud

    if args.random is None:
        if args.input is None:
            raise InputError("give a point-cloud file INPUT, or --random N for a generated cloud")
        for flag in ("seed", "box", "step", "save_cloud"):
            if getattr(args, flag) is not None:
                raise InputError(f"--{flag.replace('_', '-')} applies only with --random")
        return load_cloud(args.input), str(args.input), {}
    if args.input is not None:
        raise InputError(f"give either INPUT ({args.input}) or --random, not both")
    box = CASE_STUDY_BOX if args.box is None else Box.from_bounds(args.box)
    seed = args.seed if args.seed is not None else int(np.random.SeedSequence().entropy % 2**32)
    cloud = random_cloud(args.random, box, step=args.step, rng=seed)
    meta: dict[str, Any] = {
        "seed": seed,
        "box": list(map(float, (box.xmin, box.xmax, box.ymin, box.ymax, box.zmin, box.zmax))),
        "step": args.step,
    }
    if args.save_cloud:
        from replication.io import save_cloud

        meta["cloud_file"] = args.save_cloud
        meta["cloud_bytes"] = save_cloud(cloud, args.save_cloud)
    return cloud, f"{args.random} random points (seed {seed})", meta


def _cmd_adt(args: argparse.Namespace) -> int:
    from replication.io import surface_format, write_surface
    from replication.surfaces import AXES, adt, closed_adt, parse_split

    fmt = surface_format(args.output, args.format) if args.output else args.format
    if args.output:
        from replication.io.atomic import check_output_path

        check_output_path(args.output)  # fail before any work
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DuplicatePointsWarning)
        cloud, source, meta = _load_or_generate(args)
        if args.split:
            closed = closed_adt(
                cloud, parse_split(args.split), duplicates=args.duplicates, backend=args.backend
            )
            mesh: Any = closed
            halves = (closed.upper, closed.lower)
            info: dict[str, Any] = {
                "split": str(closed.split),
                "closed": closed.is_closed,
                "points_on_plane": closed.n_on_plane,
                "shared_vertices": closed.n_shared,
                "depth_axis": AXES[closed.split.axis],
                "points_merged": sum(h.n_merged for h in halves),
            }
        else:
            if (
                args.depth not in ("min", "max") and args.depth not in AXES
            ):  # pragma: no cover - argparse guards
                raise InputError(f"bad depth rule {args.depth!r}")
            surface = adt(cloud, depth=args.depth, duplicates=args.duplicates, backend=args.backend)
            mesh = surface
            halves = (surface,)
            info = {
                "depth_axis": surface.depth_axis_name,
                "depth_rule": surface.depth_rule,
                "projection_axes": list(surface.projection_axes_names),
                "spreads": dict(zip(AXES, surface.spreads)),
                "points_merged": surface.n_merged,
            }
    build_s = time.perf_counter() - start
    written = write_surface(mesh, args.output, fmt) if args.output else None
    report: dict[str, Any] = {
        "input": source,
        "points": int(cloud.shape[0]),
        "vertices": int(mesh.points.shape[0]),
        "triangles": int(mesh.triangles.shape[0]),
        **info,
        "duplicate_policy": args.duplicates,
        "backend": sorted({h.backend for h in halves}),
        "output": args.output,
        "format": fmt if args.output else None,
        "bytes": written,
        "build_seconds": build_s,
        **meta,
    }
    for w in caught:  # merges are reported below and in the JSON; other warnings go to stderr
        if not issubclass(w.category, DuplicatePointsWarning):
            print(f"warning: {w.message}", file=sys.stderr)
    if args.json:
        print(json.dumps(report))
        return 0
    print(
        f"ADT surface from {source}: {report['points']} points -> "
        f"{report['vertices']} vertices, {report['triangles']} triangles"
    )
    if args.split:
        state = "closed (watertight)" if info["closed"] else "NOT watertight: the halves' boundaries differ"
        print(f"split plane {info['split']}: {info['points_on_plane']} points on the plane, {state}")
    else:
        spreads = ", ".join(f"{a}={v:.4g}" for a, v in info["spreads"].items())
        plane = ", ".join(info["projection_axes"])
        rule = info["depth_rule"]
        print(f"depth axis {info['depth_axis']} (rule {rule}; std {spreads}); triangulated in ({plane})")
    if report["points_merged"]:
        merged = report["points_merged"]
        print(f"merged {merged} point(s) sharing a projected position (policy {args.duplicates})")
    if args.output:
        kind = "legacy VTK, ASCII" if fmt == "vtk" else "VTK XML, binary"
        print(f"wrote {args.output} ({written:,} bytes, {kind})")
    else:
        print("no output file written (use -o OUT)")
    if "cloud_file" in meta:
        print(f"wrote the cloud to {meta['cloud_file']} ({meta['cloud_bytes']:,} bytes)")
    return 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    print("replication reproduce: regenerating the paper's results")
    print("stages still to come (not yet available in this version):")
    for name, what in (
        ("table1", "Table 1 and Fig. 6: file size, computation time and paired statistics, ADT vs NURBS"),
        ("casestudy", "Figs. 8 and 9: the water-jet genetic algorithm"),
    ):
        print(f"  - {name}: {what} [not yet available]")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="replication",
        description=(
            "Reproduce 'adapted Delaunay triangulation' (ADT) surfaces from random point clouds, "
            "their comparison with NURBS, and the paper's water-jet case study."
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_adt_parser(sub)
    p = sub.add_parser(
        "reproduce",
        help="regenerate the paper's tables and figures into reports/",
        description="Run every available stage of the replication and regenerate the reports.",
    )
    p.add_argument("--quick", action="store_true", help="a reduced run for smoke testing")
    p.set_defaults(func=_cmd_reproduce)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``replication`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except ReplicationError as exc:
        print(f"replication {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"replication {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
