"""NURBS files: complete, compact, read back by geomdl."""

import numpy as np
import pytest
from geomdl import exchange

from replication.errors import CloudFileError, InputError
from replication.io.nurbs import read_nurbs, smesh_text, write_nurbs
from replication.surfaces import random_cloud
from replication.surfaces.nurbs import NurbsPatch, clamped_uniform_knots, fit_nurbs


@pytest.fixture(scope="module")
def patch():
    return fit_nurbs(random_cloud(45, rng=3), tessellation=None).patch


@pytest.mark.parametrize("suffix", [".smesh", ".json"])
def test_round_trip_is_exact(patch, tmp_path, suffix):
    path = tmp_path / f"n{suffix}"
    size = write_nurbs(patch, path)
    assert size == path.stat().st_size
    back = read_nurbs(path)
    assert (back.degree_u, back.degree_v) == (patch.degree_u, patch.degree_v)
    np.testing.assert_array_equal(back.knots_u, patch.knots_u)
    np.testing.assert_array_equal(back.knots_v, patch.knots_v)
    np.testing.assert_array_equal(back.control_points, patch.control_points)
    np.testing.assert_array_equal(back.weights, patch.weights)


def test_rational_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    k = clamped_uniform_knots(4, 2)
    patch = NurbsPatch(
        2, 2, k, clamped_uniform_knots(5, 2), rng.normal(size=(4, 5, 3)), rng.random((4, 5)) + 0.5
    )
    write_nurbs(patch, tmp_path / "r.smesh")
    back = read_nurbs(tmp_path / "r.smesh")
    np.testing.assert_allclose(back.weights, patch.weights, rtol=1e-15)
    # geomdl keeps weighted points internally: the division costs an ulp or two
    np.testing.assert_allclose(back.control_points, patch.control_points, rtol=1e-14, atol=1e-14)


def test_smesh_matches_geomdls_own_export_and_is_smaller(patch, tmp_path):
    exchange.export_smesh(patch.to_geomdl(), str(tmp_path / "geomdl.smesh"))
    theirs = read_nurbs(tmp_path / "geomdl.smesh")
    np.testing.assert_allclose(theirs.control_points, patch.control_points, atol=1e-15)
    ours = write_nurbs(patch, tmp_path / "ours.smesh")
    assert ours < (tmp_path / "geomdl.smesh").stat().st_size


def test_smesh_known_answer():
    k = clamped_uniform_knots(3, 2)
    pts = np.zeros((3, 3, 3))
    pts[..., 0] = np.arange(3)[:, None]
    pts[..., 1] = np.arange(3)[None, :] * 2
    pts[1, 2, 2] = 0.5
    text = smesh_text(NurbsPatch(2, 2, k, k, pts, np.ones((3, 3))))
    lines = text.splitlines()
    assert lines[:5] == ["3", "2 2", "3 3", "0 0 0 1 1 1", "0 0 0 1 1 1"]
    assert lines[5:8] == ["0 0 0 1", "1 0 0 1", "2 0 0 1"]  # u varies fastest
    assert lines[12] == "1 4 0.5 1" and lines[-1] == "1" and len(lines) == 15


def test_errors(patch, tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        read_nurbs(tmp_path / "none.smesh")
    (tmp_path / "bad.smesh").write_text("3\n2 2\nthree three\n")
    with pytest.raises(CloudFileError, match="not a readable smesh"):
        read_nurbs(tmp_path / "bad.smesh")
    with pytest.raises(InputError, match="suffix"):
        write_nurbs(patch, tmp_path / "n.igs")
    with pytest.raises(InputError, match="'iges'"):
        write_nurbs(patch, tmp_path / "n.smesh", "iges")


def test_a_full_disk_under_geomdl_s_json_writer_is_our_one_line_error(patch, tmp_path, monkeypatch):
    """geomdl wraps the system's error in a GeomdlException naming the temporary file: the
    command printed 'unexpected GeomdlException' with a name the user never gave."""
    import errno

    import geomdl._exchange

    from replication.errors import OutputError

    class FullDisk:
        def __init__(self, name, mode):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(geomdl._exchange, "open", FullDisk, raising=False)  # geomdl's own writer opens it
    target = tmp_path / "s.json"
    with pytest.raises(OutputError, match=rf"^cannot write {target}: No space left on device$"):
        write_nurbs(patch, target)
    assert list(tmp_path.iterdir()) == []  # no temporary left
