"""Off-screen renders of surfaces (pyvista with EGL; matplotlib 3-D as the fallback).

pyvista renders off-screen with the PyPI vtk wheel through EGL (software Mesa) when
``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` is set before the first render window is
made; this module sets it unless the user chose otherwise. If rendering fails, the same
views are drawn with matplotlib's 3-D axes and :func:`render_views` says so.
"""

from __future__ import annotations

import contextlib
import importlib
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from replication.io.atomic import atomic_path
from replication.report.figures import new_figure, save_figure

__all__ = ["render_views"]

Mesh = tuple[np.ndarray, np.ndarray]
COLORS = {"ADT": "#d9a441", "NURBS": "#5b8fd9"}


def _load_pyvista() -> Any:
    """``import pyvista`` (and VTK's compiled modules), with Ctrl-C held until it is done.

    A KeyboardInterrupt raised in the middle of VTK's module initialisation left it half
    built, and the interpreter then crashed (a segmentation fault, 3 of 40 Ctrl-Cs at that
    moment) instead of reporting the interrupt. ``pyvista.plotting``, which pyvista loads
    lazily on the first ``pv.Plotter`` and which pulls in most of VTK, is loaded here too: a
    Ctrl-C during that later import crashed the same way or was swallowed (2-3 of 60). So are
    the VTK modules the first ``pv.Plotter`` still loads on its own (:data:`_PLOTTER_MODULES`):
    interrupted there, VTK crashed or raised an ``ImportError`` that :func:`render_views` took
    for "cannot render" (4 of 80 SIGTERMs at that moment).
    """
    from replication.io.vtkload import vtk_imports

    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    with vtk_imports():
        pv = importlib.import_module("pyvista")
        importlib.import_module("pyvista.plotting")
        for name in _PLOTTER_MODULES:
            with contextlib.suppress(ImportError):  # (a VTK build without one: pv.Plotter says so)
                importlib.import_module(name)
        return pv


#: The VTK modules ``pyvista.Plotter()`` imports on first use (measured with pyvista 0.49, VTK 9.7).
_PLOTTER_MODULES = (
    "vtkmodules.vtkViewsCore",
    "vtkmodules.vtkViewsContext2D",
    "vtkmodules.vtkInteractionWidgets",
)


def _pyvista_views(views: dict[Path, Sequence[tuple[str, Mesh]]], size: tuple[int, int]) -> None:
    pv = _load_pyvista()

    from replication.surfaces.adt import triangle_polydata

    # one plotter (one off-screen context) for every view: a new context per view cost about
    # as much as the render itself
    plotter = pv.Plotter(off_screen=True, window_size=size)
    try:
        plotter.set_background("white")
        for path, meshes in views.items():
            plotter.clear_actors()
            for label, (points, triangles) in meshes:
                opacity = 0.75 if len(meshes) > 1 and label == "NURBS" else 1.0
                plotter.add_mesh(
                    triangle_polydata(points, triangles),
                    color=COLORS[label],
                    show_edges=label == "ADT",
                    edge_color="#6b4d12",
                    opacity=opacity,
                    smooth_shading=label == "NURBS",
                )
            plotter.view_vector((1.0, -1.4, 1.1), viewup=(0, 0, 1))
            plotter.camera.zoom(1.25)
            plotter.render()  # a screenshot renders by itself only the first time
            with atomic_path(path) as tmp:
                plotter.screenshot(str(tmp))
    finally:
        plotter.close()


def _matplotlib_views(views: dict[Path, Sequence[tuple[str, Mesh]]], size: tuple[int, int]) -> None:
    for path, meshes in views.items():
        fig = new_figure((size[0] / 100, size[1] / 100))
        ax = fig.add_subplot(projection="3d")
        for label, (points, triangles) in meshes:
            ax.plot_trisurf(
                points[:, 0], points[:, 1], points[:, 2], triangles=triangles, color=COLORS[label],
                alpha=0.75 if len(meshes) > 1 else 1.0, edgecolor="#6b4d12" if label == "ADT" else "none",
                linewidth=0.3,
            )  # fmt: skip
        ax.view_init(elev=35, azim=-55)
        ax.set_axis_off()
        save_figure(fig, path.with_suffix(""), formats=("png",))


def render_views(views: dict[Path, Sequence[tuple[str, Mesh]]], *, size: tuple[int, int] = (420, 320)) -> str:
    """Render each view (a list of labelled meshes) to its PNG path; return the renderer used.

    Returns ``"pyvista (VTK, off-screen EGL)"`` or, when VTK cannot render off-screen,
    ``"matplotlib 3-D (fallback: <reason>)"``.
    """
    try:
        _pyvista_views(views, size)
        return "pyvista (VTK, off-screen EGL)"
    except Exception as exc:  # any VTK/EGL failure: fall back, and say why
        _matplotlib_views(views, size)
        return f"matplotlib 3-D (fallback: pyvista could not render off-screen: {type(exc).__name__}: {exc})"
