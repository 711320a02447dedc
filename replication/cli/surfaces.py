"""``replication adt``, ``replication nurbs`` and ``replication compare`` (its handler: :mod:`.compare`)."""

from __future__ import annotations

import argparse
import time
from typing import Any

from replication.cli import progress
from replication.cli.common import (
    about_the_input,
    add_cloud_source,
    add_frame_options,
    emit_json,
    file_name,
    finite_positive,
    frame_kwargs,
    load_or_generate,
    pair,
    positive_int,
    relay_warnings,
    samples,
    significance,
    warm_up,
)
from replication.cli.compare import EPILOG_COMPARE, cmd_compare
from replication.cli.files import (
    check_format_suffix,
    check_outputs,
    save_generated_cloud,
    suffix_warning,
    write_all_or_none,
)
from replication.cli.progress import stage
from replication.cli.resources import check_tessellation

SURFACE_KINDS = {"vtk": "legacy VTK, ASCII", "vtp": "VTK XML, binary"}
NURBS_KINDS = {"smesh": "compact smesh, ASCII", "json": "geomdl JSON"}

EPILOG_ADT = """\
examples:
  replication adt cloud.csv -o surface.vtk
      triangulate your own cloud (csv/txt/xyz with 3 columns x y z, or as a header names them;
      or .npy)
  replication adt --random 200 --seed 1 --step 1 -o surface.vtp --save-cloud cloud.csv
      a random 200-point cloud on a 1 mm lattice in the case-study box, kept in cloud.csv
  replication adt sphere.xyz --split z=0 -o closed.vtk
      a closed surface: two halves above and below z = 0, joined along their rims
      (an oblique plane: --split 1,1,0=0.5, the plane with normal (1, 1, 0) at distance 0.5)
  replication adt cloud.csv --json
      report the depth axis, merges and triangle count as JSON, writing nothing

sphere.xyz stands for any cloud around a plane; 500 points on a 10 mm sphere are written by
  python -c "import numpy as np, replication as rp; p = np.random.default_rng(1).normal(size=(500, 3)); rp.save_cloud(10 * p / np.linalg.norm(p, axis=1, keepdims=True), 'sphere.xyz')"

The depth axis is the axis along which the surface is a height field: by default the axis of
least spread (paper eq. 7), ties broken z first, then y (eq. 8). Points that share a position
in the projection plane become one vertex by --duplicates (default: mean depth, with a
warning); --duplicates raise refuses such clouds instead.
"""  # noqa: E501 - a command to copy whole

EPILOG_NURBS = """\
examples:
  replication nurbs cloud.csv -o surface.smesh
  replication nurbs --random 45 --seed 3 --step 1 -o surface.json --json

The paper's baseline (section 3.1): the cloud is interpolated linearly onto a rectangular
grid over its bounding box (nodes outside the convex hull take the nearest point's depth),
the grid nodes become control points with weight 1, and the knot vectors are clamped with
uniform interior knots. The net has m_u x m_v = n control points when n factors with a side
ratio near the cloud's aspect ratio, otherwise about n (fallback). .smesh is the compact
complete ASCII format geomdl reads back (geomdl.exchange.import_smesh); .json is geomdl's
JSON exchange format.
"""


def _check_format_has_output(args: argparse.Namespace) -> None:
    """``--format`` without ``-o`` was accepted and did nothing, as --seed without --random is refused."""
    from replication.errors import UsageError

    if args.format is not None and args.output is None:
        raise UsageError(f"--format {args.format} applies only with -o OUT (a file to write)")


def _write_outputs(args: argparse.Namespace, write: Any, cloud: Any, meta: Any, *, large: bool) -> Any:
    """Write ``-o`` (``write``) and ``--save-cloud`` all or none, saying so for a large cloud."""
    names = [str(p) for p in (args.output, args.save_cloud) if p]
    with stage("writing " + " and ".join(names), shown=large and bool(names)):
        return write_all_or_none(
            (args.output, write), (args.save_cloud, lambda: save_generated_cloud(cloud, args, meta))
        )


def _cmd_adt(args: argparse.Namespace) -> int:
    from replication.errors import InputError, UsageError
    from replication.io import surface_format, write_surface
    from replication.surfaces import AXES, adt, closed_adt, parse_split

    if args.split and args.depth != "min":  # before any work: the cloud is not even read
        raise UsageError(
            f"--depth {args.depth} does not apply with --split: each half is a height field over "
            "the split plane, whose normal is the depth axis"
        )
    split = None
    if args.split:  # a malformed plane is a misused option (exit 2), found before any work
        try:
            split = parse_split(args.split)
        except InputError as exc:
            raise UsageError(f"--split: {exc}") from exc
    _check_format_has_output(args)
    check_format_suffix(args.output, args.format, SURFACE_KINDS)  # a misused option: before the library's
    fmt = surface_format(args.output, args.format) if args.output else args.format
    check_outputs(args)
    suffix_warning(args.output, args.format, SURFACE_KINDS)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        large = len(cloud) >= progress.LARGE_CLOUD
        startup_s = warm_up("adt", args)
        start = time.perf_counter()
        if split is not None:
            building = f"building the closed ADT surface of {len(cloud):,} points"
            with about_the_input(args), stage(building, shown=large):
                closed = closed_adt(cloud, split, duplicates=args.duplicates, backend=args.backend)
            mesh: Any = closed
            halves = (closed.upper, closed.lower)
            info: dict[str, Any] = {
                "split": str(closed.split),
                "closed": closed.is_closed,
                "not_closed_reason": closed.not_closed_reason or None,
                "points_on_plane": closed.n_on_plane,
                "shared_vertices": closed.n_shared,
                "closing_triangles": closed.n_strip,
                "depth_axis": closed.split.depth_name,
                "points_merged": sum(h.n_merged for h in halves),
            }
        else:
            with (
                about_the_input(args),
                stage(f"building the ADT surface of {len(cloud):,} points", shown=large),
            ):
                surface = adt(cloud, **frame_kwargs(args))
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
    written, _ = _write_outputs(args, lambda: write_surface(mesh, args.output, fmt), cloud, meta, large=large)
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
        "startup_seconds": startup_s,
        **meta,
    }
    if args.json:
        emit_json(report)
        return 0
    print(
        f"ADT surface from {source}: {report['points']} points -> "
        f"{report['vertices']} vertices, {report['triangles']} triangle{'s' * (report['triangles'] != 1)}"
    )
    if args.split:
        state = (
            f"closed (watertight), the halves' rims joined by {info['closing_triangles']} triangles"
            if info["closed"]
            else f"NOT watertight: {info['not_closed_reason']}"
        )
        print(f"split plane {info['split']}: {info['points_on_plane']} points on the plane, {state}")
    else:
        spreads = ", ".join(f"{a}={v:.4g}" for a, v in info["spreads"].items())
        plane = ", ".join(info["projection_axes"])
        rule = info["depth_rule"]
        print(f"depth axis {info['depth_axis']} (rule {rule}; std {spreads}); triangulated in ({plane})")
    _print_merges_and_outputs(report, args)
    return 0


def _print_merges_and_outputs(report: dict[str, Any], args: argparse.Namespace) -> None:
    if report["points_merged"]:
        merged = report["points_merged"]
        print(f"merged {merged} point(s) sharing a projected position (policy {args.duplicates})")
    if args.output:
        kind = SURFACE_KINDS[report["format"]]
        print(f"wrote {args.output} ({report['bytes']:,} bytes, {kind})")
    else:
        print("no output file written (use -o OUT)")
    if "cloud_file" in report:
        print(f"wrote the cloud to {report['cloud_file']} ({report['cloud_bytes']:,} bytes)")


def _cmd_nurbs(args: argparse.Namespace) -> int:
    from replication.io.nurbs import nurbs_format, write_nurbs
    from replication.surfaces.nurbs import fit_nurbs

    _check_format_has_output(args)
    check_format_suffix(args.output, args.format, NURBS_KINDS)  # a misused option: before the library's
    fmt = nurbs_format(args.output, args.format) if args.output else args.format
    check_outputs(args)
    suffix_warning(args.output, args.format, NURBS_KINDS)
    check_tessellation(args.tessellation, args.evaluator)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        large = len(cloud) >= progress.LARGE_CLOUD
        startup_s = warm_up("nurbs", args)
        start = time.perf_counter()
        # geomdl, the reference, takes most of the time at a million points: say what is faster
        hint = "; --evaluator fast takes a fraction of the time" if args.evaluator == "geomdl" else ""
        fitting = f"fitting the NURBS surface to {len(cloud):,} points ({args.evaluator} tessellation{hint})"
        with about_the_input(args), stage(fitting, shown=large):
            nurbs = fit_nurbs(
                cloud,
                degree=args.degree,
                net=args.net,
                tessellation=args.tessellation,
                evaluator=args.evaluator,
                **frame_kwargs(args),
            )
        build_s = time.perf_counter() - start
    written, _ = _write_outputs(
        args, lambda: write_nurbs(nurbs.patch, args.output, fmt), cloud, meta, large=large
    )
    m_u, m_v = nurbs.patch.net_shape
    report: dict[str, Any] = {
        "input": source,
        "points": int(cloud.shape[0]),
        "points_merged": nurbs.n_merged,
        "depth_axis": nurbs.depth_axis_name,
        "degree": [nurbs.patch.degree_u, nurbs.patch.degree_v],
        "net": [m_u, m_v],
        "net_rule": nurbs.net.rule,
        "control_points": m_u * m_v,
        "grid_nodes_filled": nurbs.n_filled,
        "knots_u": nurbs.patch.knots_u.tolist(),
        "knots_v": nurbs.patch.knots_v.tolist(),
        "tessellation": list(args.tessellation),
        "evaluator": args.evaluator,
        "output": args.output,
        "format": fmt if args.output else None,
        "bytes": written,
        "build_seconds": build_s,
        "startup_seconds": startup_s,
        **meta,
    }
    if args.json:
        emit_json(report)
        return 0
    plane = "-".join(a for a in "xyz" if a != nurbs.depth_axis_name)
    print(
        f"NURBS surface from {source}: degree {args.degree}, {m_u} x {m_v} control net "
        f"({nurbs.net.rule} rule), a height field over the {plane} plane"
    )
    print(
        f"{nurbs.n_filled} of {m_u * m_v} grid nodes lie outside the cloud's convex hull "
        "and took the nearest point's depth"
    )
    if nurbs.n_merged:
        print(f"merged {nurbs.n_merged} point(s) sharing a projected position (policy {args.duplicates})")
    if args.output:
        print(f"wrote {args.output} ({written:,} bytes, {NURBS_KINDS[fmt]})")
    else:
        print("no output file written (use -o OUT)")
    if "cloud_file" in meta:
        print(f"wrote the cloud to {meta['cloud_file']} ({meta['cloud_bytes']:,} bytes)")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the adt, nurbs and compare subcommands."""
    from replication.io import SURFACE_FORMATS
    from replication.io.nurbs import NURBS_FORMATS

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
    add_cloud_source(p)
    p.add_argument(
        "-o",
        "--output",
        type=file_name,
        metavar="OUT",
        help="surface file to write (.vtk or .vtp); omit to write nothing",
    )
    p.add_argument(
        "--format",
        choices=SURFACE_FORMATS,
        help="vtk: compact legacy ASCII; vtp: binary VTK XML (default: from the OUT suffix)",
    )
    add_frame_options(p)
    p.add_argument(
        "--split",
        metavar="AXIS=OFFSET",
        help="closed surface: split the cloud by the plane AXIS=OFFSET (e.g. z=0, or 1,1,0=0.5 for a "
        "normal) and join the two halves' rims",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object describing what was done")
    p.set_defaults(func=_cmd_adt)

    for name, func, helptext, epilog in (
        ("nurbs", _cmd_nurbs, "fit the paper's NURBS baseline to a point cloud (section 3.1)", EPILOG_NURBS),
        ("compare", cmd_compare, "paired statistics of ADT vs NURBS depths (section 4)", EPILOG_COMPARE),
    ):
        p = sub.add_parser(
            name,
            help=helptext,
            description=helptext[0].upper() + helptext[1:] + ".",
            epilog=epilog,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        add_cloud_source(p)
        if name == "nurbs":
            p.add_argument(
                "-o", "--output", type=file_name, metavar="OUT", help="NURBS file to write (.smesh or .json)"
            )
            p.add_argument("--format", choices=NURBS_FORMATS, help="default: from the OUT suffix")
            p.add_argument(
                "--tessellation",
                type=samples,
                default=(50, 50),
                metavar="SUxSV",
                help="parameter samples evaluated as part of the build (default 50x50)",
            )
            p.add_argument(
                "--evaluator",
                choices=("geomdl", "fast"),
                default="geomdl",
                help="evaluate the tessellation with geomdl (the reference, default) or scipy (fast)",
            )
        else:
            p.add_argument(
                "--samples",
                type=samples,
                metavar="SUxSV",
                help="NURBS samples for pairing (a) (default: the control-net size)",
            )
            p.add_argument(
                "--margin",
                type=finite_positive,
                default=0.05,
                help="equivalence margin as a fraction of the depth range (default 0.05)",
            )
            p.add_argument(
                "--alpha", type=significance, default=0.05, help="significance level below 0.5 (default 0.05)"
            )
        p.add_argument(
            "--degree", type=positive_int, default=2, help="NURBS degree in both directions (default 2)"
        )
        p.add_argument("--net", type=pair, metavar="MUxMV", help="impose the control net, e.g. 9x5")
        add_frame_options(p)
        p.add_argument("--json", action="store_true", help="print one JSON object")
        p.set_defaults(func=func)
