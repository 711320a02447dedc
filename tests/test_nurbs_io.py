"""NURBS files: complete, compact, read back by geomdl."""

import numpy as np
import pytest
from geomdl import exchange
from hypothesis import given, settings
from hypothesis import strategies as hst

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


def test_a_full_disk_under_the_json_writer_is_our_one_line_error(patch, tmp_path, monkeypatch):
    """geomdl's writer wrapped the system's error in a GeomdlException naming the temporary
    file (the command printed 'unexpected GeomdlException'); the writer is ours now, and a
    full disk is the one-line error every file write gives."""
    import errno
    from pathlib import Path

    from replication.errors import OutputError

    def full(self, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", full)
    target = tmp_path / "s.json"
    with pytest.raises(OutputError, match=rf"^cannot write {target}: No space left on device$"):
        write_nurbs(patch, target)
    assert list(tmp_path.iterdir()) == []  # no temporary left


def _geomdl_json(patch, path):
    exchange.export_json(patch.to_geomdl(), str(path))
    return path.read_text()


@pytest.mark.parametrize("n", [9, 45, 200])
def test_json_is_the_file_geomdl_writes_byte_for_byte(n, tmp_path):
    """Table 1's JSON file sizes and any reader of geomdl's files see the same bytes."""
    patch = fit_nurbs(random_cloud(n, rng=n), tessellation=None).patch
    write_nurbs(patch, tmp_path / "ours.json")
    assert (tmp_path / "ours.json").read_bytes() == _geomdl_json(patch, tmp_path / "geomdl.json").encode()


@settings(max_examples=40, deadline=None)
@given(
    degrees=hst.tuples(hst.integers(1, 3), hst.integers(1, 3)),
    extra=hst.tuples(hst.integers(0, 4), hst.integers(0, 4)),
    seed=hst.integers(0, 2**32 - 1),
    scale=hst.sampled_from([1e-300, 1e-8, 1.0, 1e8, 1e300]),
    rational=hst.booleans(),
    uniform=hst.booleans(),
)
def test_json_matches_geomdl_on_rational_and_non_uniform_patches(
    degrees, extra, seed, scale, rational, uniform
):
    """The weighted points ((x * w) / w), the knots' 18-decimal normalisation and every float's
    decimals, as geomdl writes them; weights and knots of any kind, values of any magnitude."""
    import tempfile
    from pathlib import Path

    rng = np.random.default_rng(seed)
    (p_u, p_v), (e_u, e_v) = degrees, extra
    m_u, m_v = p_u + 1 + e_u, p_v + 1 + e_v

    def knots(m, p):
        if uniform:
            return clamped_uniform_knots(m, p)
        inner = np.sort(rng.random(m - p - 1)) * 7.3 + 0.1
        return np.concatenate([[0.1] * (p + 1), inner, [7.4] * (p + 1)])

    patch = NurbsPatch(
        p_u, p_v, knots(m_u, p_u), knots(m_v, p_v),
        rng.normal(size=(m_u, m_v, 3)) * scale,
        rng.random((m_u, m_v)) * 3 + 0.01 if rational else np.ones((m_u, m_v)),
    )  # fmt: skip
    with tempfile.TemporaryDirectory() as scratch:
        ours = write_nurbs(patch, Path(scratch) / "ours.json")
        theirs = _geomdl_json(patch, Path(scratch) / "geomdl.json")
        assert (Path(scratch) / "ours.json").read_text() == theirs and ours == len(theirs.encode())
