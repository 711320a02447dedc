"""Off-screen 3-D renders of the reports (replication.report.render3d)."""

from __future__ import annotations

import numpy as np
import pytest

from replication.report.render3d import render_views
from replication.surfaces import adt, random_cloud


def _views(tmp_path, tag):
    surfaces = [adt(random_cloud(n, rng=n)) for n in (9, 60, 200)]
    return {
        tmp_path / f"{tag}{k}.png": [("ADT", (s.points, s.triangles))]
        + ([("NURBS", (s.points, s.triangles))] if k else [])
        for k, s in enumerate(surfaces)
    }


def test_views_rendered_together_match_views_rendered_alone(tmp_path):
    """One plotter serves every view; each picture is the one a plotter of its own makes (a
    screenshot after the first shows the last frame rendered, so each view must render)."""
    together = _views(tmp_path, "together")
    renderer = render_views(together)
    if not renderer.startswith("pyvista"):
        pytest.skip(f"no off-screen VTK here: {renderer}")
    alone = _views(tmp_path, "alone")
    for path, meshes in alone.items():
        render_views({path: meshes})
    for (a, _), (b, _) in zip(together.items(), alone.items()):
        assert a.read_bytes() == b.read_bytes(), a.name
    sizes = {len(p.read_bytes()) for p in together}
    assert len(sizes) == len(together)  # three different pictures, not one repeated


def test_renders_are_deterministic(tmp_path):
    views = _views(tmp_path, "v")
    render_views(views)
    first = [p.read_bytes() for p in views]
    render_views(views)
    assert [p.read_bytes() for p in views] == first
    assert all(np.frombuffer(b[:8], np.uint8).tolist() == [137, 80, 78, 71, 13, 10, 26, 10] for b in first)


def test_ctrl_c_while_pyvista_is_imported_waits_for_the_import(monkeypatch):
    # a KeyboardInterrupt inside VTK's module initialisation crashed the interpreter (segfault)
    import os
    import signal

    from replication.report import render3d

    imported = []

    def import_module(name):
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of the import
        imported.append(name)  # the import still completes
        return "pyvista"

    monkeypatch.setattr(render3d.importlib, "import_module", import_module)
    with pytest.raises(KeyboardInterrupt):
        render3d._load_pyvista()
    # pyvista.plotting (most of VTK, loaded lazily by the first pv.Plotter) is imported while
    # Ctrl-C waits too: outside, a Ctrl-C there segfaulted or was swallowed
    assert imported == ["pyvista", "pyvista.plotting", *render3d._PLOTTER_MODULES]


def test_after_loading_pyvista_the_first_plotter_imports_no_vtk_module():
    """pv.Plotter() imported three VTK modules itself: a SIGTERM there crashed (SIGSEGV) or was
    taken for "pyvista cannot render" (4 of 80 at that moment)."""
    import subprocess
    import sys

    code = (
        "import sys\nfrom replication.report.render3d import _load_pyvista\npv = _load_pyvista()\n"
        "before = set(sys.modules)\npv.Plotter(off_screen=True).close()\n"
        "print(sorted(m for m in set(sys.modules) - before if m.startswith('vtkmodules')))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
