"""``replication adt``, ``replication nurbs`` and ``replication compare``."""

from __future__ import annotations

import argparse
import time
from typing import Any

from replication.cli.common import (
    add_cloud_source,
    add_frame_options,
    emit_json,
    finite_positive,
    frame_kwargs,
    load_or_generate,
    pair,
    probability,
    relay_warnings,
    warm_up,
)
from replication.cli.files import check_outputs, save_generated_cloud, suffix_warning, write_all_or_none

SURFACE_KINDS = {"vtk": "legacy VTK, ASCII", "vtp": "VTK XML, binary"}
NURBS_KINDS = {"smesh": "compact smesh, ASCII", "json": "geomdl JSON"}

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

EPILOG_COMPARE = """\
examples:
  replication compare cloud.csv
  replication compare --random 200 --seed 1 --step 1 --json

Two pairings of depths at the same position: (a) nurbs-samples, at points evaluated on the
NURBS surface (ADT depth by barycentric interpolation; samples outside the ADT footprint are
excluded), and (b) cloud-points, at the cloud's own positions (NURBS depth by Newton
inversion to 1e-9). For each: the paper's paired t-test and Wilcoxon signed-rank test with
its verdict ("similar" when the test fails to reject), and what that logic lacks: the mean
difference with its 95 % confidence interval, Cohen's d_z, RMS and maximum deviation as a
percentage of the depth range, a normality check, and a TOST equivalence test with a
margin of 5 % of the depth range.
"""


def _cmd_adt(args: argparse.Namespace) -> int:
    from replication.errors import InputError
    from replication.io import surface_format, write_surface
    from replication.surfaces import AXES, adt, closed_adt, parse_split

    fmt = surface_format(args.output, args.format) if args.output else args.format
    check_outputs(args)
    suffix_warning(args.output, args.format, SURFACE_KINDS)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        startup_s = warm_up("adt", args)
        start = time.perf_counter()
        if args.split:
            if args.depth != "min":
                raise InputError(
                    f"--depth {args.depth} does not apply with --split: each half is a height field over "
                    "the split plane, whose normal is the depth axis"
                )
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
    written, _ = write_all_or_none(
        (args.output, lambda: write_surface(mesh, args.output, fmt)),
        (args.save_cloud, lambda: save_generated_cloud(cloud, args, meta)),
    )
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


#: Peak memory per tessellation sample in bytes: the growth of the peak resident size from
#: 2 x 2 to 1000 x 1000 samples (``/usr/bin/time``), rounded up; geomdl keeps every point as a
#: Python list of floats (435 measured), the fast evaluator numpy arrays (52 measured).
BYTES_PER_SAMPLE = {"geomdl": 450, "fast": 56}


def _available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux MemAvailable), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import os

        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def check_tessellation(shape: tuple[int, int], evaluator: str) -> None:
    """Refuse, before any work, a tessellation whose samples cannot fit in the available memory."""
    from replication.errors import InputError

    s_u, s_v = shape
    need = s_u * s_v * BYTES_PER_SAMPLE[evaluator]
    available = _available_memory()
    if available is not None and need > available:
        raise InputError(
            f"--tessellation {s_u}x{s_v} needs about {_size(need)} of memory ({s_u * s_v:,} samples x "
            f"{BYTES_PER_SAMPLE[evaluator]} bytes with the {evaluator} evaluator), but {_size(available)} "
            "is available: choose fewer samples"
        )


def _cmd_nurbs(args: argparse.Namespace) -> int:
    from replication.io.nurbs import nurbs_format, write_nurbs
    from replication.surfaces.nurbs import fit_nurbs

    fmt = nurbs_format(args.output, args.format) if args.output else args.format
    check_outputs(args)
    suffix_warning(args.output, args.format, NURBS_KINDS)
    check_tessellation(args.tessellation, args.evaluator)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        startup_s = warm_up("nurbs", args)
        start = time.perf_counter()
        nurbs = fit_nurbs(
            cloud,
            degree=args.degree,
            net=args.net,
            tessellation=args.tessellation,
            evaluator=args.evaluator,
            **frame_kwargs(args),
        )
        build_s = time.perf_counter() - start
    written, _ = write_all_or_none(
        (args.output, lambda: write_nurbs(nurbs.patch, args.output, fmt)),
        (args.save_cloud, lambda: save_generated_cloud(cloud, args, meta)),
    )
    m_u, m_v = nurbs.patch.net_shape
    report: dict[str, Any] = {
        "input": source,
        "points": int(cloud.shape[0]),
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
    if args.output:
        print(f"wrote {args.output} ({written:,} bytes, {NURBS_KINDS[fmt]})")
    else:
        print("no output file written (use -o OUT)")
    if "cloud_file" in meta:
        print(f"wrote the cloud to {meta['cloud_file']} ({meta['cloud_bytes']:,} bytes)")
    return 0


def _format_stats(name: str, pairs: Any, st: Any) -> list[str]:
    head = f"pairing {name}: {pairs.n} pairs of {pairs.n_candidates}"
    excluded = pairs.n_outside_adt + pairs.n_outside_nurbs
    if excluded:
        where = "ADT" if pairs.n_outside_adt else "NURBS"
        head += f" ({excluded} outside the {where} footprint, excluded)"
    if st is None:
        return [head, "  too few pairs for the tests (need 3)"]
    lo, hi = st.ci95
    return [
        head,
        f"  paired t-test      t = {st.t_test.statistic:.4g}, p = {st.t_test.p_value:.4g}"
        f"  -> paper's verdict: {'similar' if st.t_test.similar else 'different'}",
        f"  Wilcoxon test      W = {st.wilcoxon.statistic:.4g}, p = {st.wilcoxon.p_value:.4g}"
        f"  -> paper's verdict: {'similar' if st.wilcoxon.similar else 'different'}",
        f"  mean difference    {st.mean_difference:.4g} (95% CI {lo:.4g} to {hi:.4g}), "
        f"Cohen's d_z {st.cohens_dz:.3g}",
        f"  deviation          RMS {st.rms:.4g} ({st.rms_percent:.1f}% of depth range), "
        f"max {st.max_abs:.4g} ({st.max_abs_percent:.1f}%)",
        f"  normality          {st.normality_test} p = {st.normality_p:.3g} -> use the {st.recommended_test}",
        f"  equivalence (TOST) margin +-{st.margin:.4g} ({100 * st.margin_fraction:g}% of range): "
        f"p = {st.tost_p:.3g} -> {'equivalent' if st.equivalent else 'NOT shown equivalent'}",
    ]


def _cmd_compare(args: argparse.Namespace) -> int:
    from replication.compare import compare

    check_outputs(args)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        result = compare(
            cloud,
            degree=args.degree,
            net=args.net,
            sample_shape=args.samples,
            margin_fraction=args.margin,
            alpha=args.alpha,
            **frame_kwargs(args),
        )
    write_all_or_none((args.save_cloud, lambda: save_generated_cloud(cloud, args, meta)))
    m_u, m_v = result.nurbs.patch.net_shape
    pairings: dict[str, Any] = {}
    for name, p in result.pairings.items():
        st = result.statistics[name]
        pairings[name] = {
            "pairs": p.n,
            "candidates": p.n_candidates,
            "outside_adt": p.n_outside_adt,
            "outside_nurbs": p.n_outside_nurbs,
            "statistics": None if st is None else st.as_dict(),
        }
    report: dict[str, Any] = {
        "input": source,
        "points": int(cloud.shape[0]),
        "depth_axis": result.adt.depth_axis_name,
        "depth_range": result.depth_range,
        "adt": {"vertices": result.adt.n_vertices, "triangles": result.adt.n_triangles},
        "nurbs": {"degree": args.degree, "net": [m_u, m_v], "net_rule": result.nurbs.net.rule},
        "alpha": args.alpha,
        "margin_fraction": args.margin,
        "pairings": pairings,
        **meta,
    }
    if args.json:
        emit_json(report)
        return 0
    print(
        f"ADT vs NURBS for {source}: depth axis {report['depth_axis']}, "
        f"depth range {result.depth_range:.4g}; NURBS degree {args.degree}, {m_u} x {m_v} net"
    )
    for name in result.pairings:
        print("\n".join(_format_stats(name, result.pairings[name], result.statistics[name])))
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
        "-o", "--output", metavar="OUT", help="surface file to write (.vtk or .vtp); omit to write nothing"
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
        help="closed surface: split the cloud by the plane AXIS=OFFSET (e.g. z=0) and stitch the two halves",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object describing what was done")
    p.set_defaults(func=_cmd_adt)

    for name, func, helptext, epilog in (
        ("nurbs", _cmd_nurbs, "fit the paper's NURBS baseline to a point cloud (section 3.1)", EPILOG_NURBS),
        ("compare", _cmd_compare, "paired statistics of ADT vs NURBS depths (section 4)", EPILOG_COMPARE),
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
            p.add_argument("-o", "--output", metavar="OUT", help="NURBS file to write (.smesh or .json)")
            p.add_argument("--format", choices=NURBS_FORMATS, help="default: from the OUT suffix")
            p.add_argument(
                "--tessellation",
                type=pair,
                default=(50, 50),
                metavar="SUxSV",
                help="parameter samples evaluated as part of the build (default 50x50)",
            )
            p.add_argument(
                "--evaluator",
                choices=("geomdl", "fast"),
                default="geomdl",
                help="evaluate the tessellation with geomdl (reference) or scipy (fast)",
            )
        else:
            p.add_argument(
                "--samples",
                type=pair,
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
                "--alpha", type=probability, default=0.05, help="significance level (default 0.05)"
            )
        p.add_argument("--degree", type=int, default=2, help="NURBS degree in both directions (default 2)")
        p.add_argument("--net", type=pair, metavar="MUxMV", help="impose the control net, e.g. 9x5")
        add_frame_options(p)
        p.add_argument("--json", action="store_true", help="print one JSON object")
        p.set_defaults(func=func)
