"""File formats: compact legacy VTK, VTP, point-cloud files, atomic writes."""

import os
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as hst
from hypothesis.extra import numpy as hnp

from replication.errors import CloudFileError, InputError, OutputError
from replication.io import atomic as atomic_module
from replication.io import (
    atomic_write_text,
    format_number,
    legacy_vtk_text,
    load_cloud,
    read_surface,
    save_cloud,
    shortest_decimals,
    write_surface,
    write_vtk,
    write_vtp,
)
from replication.surfaces import adt


@pytest.fixture
def surface():
    rng = np.random.default_rng(0)
    cloud = rng.random((50, 3)) * [30, 20, 5]
    cloud[:5] = np.round(cloud[:5])  # some integer-valued coordinates
    cloud[5] = [0.1, 1e-300, 1e150]  # awkward values must round-trip too
    return adt(cloud, depth="z")


def test_legacy_vtk_known_answer():
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.25], [0.0, 2.0, -1.5]])
    text = legacy_vtk_text(points, np.array([[0, 1, 2]]), title="t")
    assert text == (
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n"
        "0 0 0\n1 0 0.25\n0 2 -1.5\nPOLYGONS 1 4\n3 0 1 2\n"
    )


@pytest.mark.parametrize(
    ("value", "text"), [(3.0, "3"), (0.1, "0.1"), (-0.0, "-0"), (1e-300, "1e-300"), (2.5e16, "2.5e+16")]
)
def test_format_number_is_shortest_round_trip(value, text):
    assert format_number(value) == text
    assert float(text) == value


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, hst.integers(0, 40), elements=hst.floats(width=64)))
def test_shortest_decimals_is_format_number_of_each_value(values):
    # the writers format whole columns at once; the text must be the value-by-value one
    assert shortest_decimals(values) == [format_number(v) for v in values.tolist()]


def test_shortest_decimals_edge_values():
    values = np.array([3.0, -0.0, 10.0, 100.05, 1e16, 1e-5, np.inf, np.nan, 0.5, 30.0])
    assert shortest_decimals(values) == [
        "3",
        "-0",
        "10",
        "100.05",
        "1e+16",
        "1e-05",
        "inf",
        "nan",
        "0.5",
        "30",
    ]
    assert shortest_decimals(np.empty(0)) == []


@pytest.mark.parametrize("suffix", [".vtk", ".vtp"])
def test_round_trip_with_pyvista(surface, tmp_path, suffix):
    path = tmp_path / f"s{suffix}"
    size = write_surface(surface, path)
    assert size == path.stat().st_size > 0
    mesh = pv.read(path)
    np.testing.assert_array_equal(mesh.points, surface.points)
    np.testing.assert_array_equal(mesh.faces.reshape(-1, 4)[:, 1:], surface.triangles)
    points, triangles = read_surface(path)
    np.testing.assert_array_equal(points, surface.points)
    np.testing.assert_array_equal(triangles, surface.triangles)


def test_vtp_compressed_round_trip(surface, tmp_path):
    raw = write_vtp(surface, tmp_path / "raw.vtp")
    packed = write_vtp(surface, tmp_path / "zip.vtp", compress=True)
    assert packed < raw
    np.testing.assert_array_equal(read_surface(tmp_path / "zip.vtp")[0], surface.points)


def test_legacy_vtk_is_compact_on_lattices_and_exact_everywhere(surface, tmp_path):
    """Smaller than VTK's own ASCII on lattice clouds; exact where VTK's ASCII is lossy."""
    cloud = np.unique(np.random.default_rng(2).integers(0, 30, (60, 3)), axis=0).astype(float)
    lattice = adt(cloud[np.unique(cloud[:, :2], axis=0, return_index=True)[1]], depth="z")
    ours = write_vtk(lattice, tmp_path / "ours.vtk")
    lattice.to_polydata().save(tmp_path / "theirs.vtk", binary=False)
    assert ours < (tmp_path / "theirs.vtk").stat().st_size
    surface.to_polydata().save(tmp_path / "lossy.vtk", binary=False)
    assert not np.array_equal(pv.read(tmp_path / "lossy.vtk").points, surface.points)
    write_vtk(surface, tmp_path / "exact.vtk")
    np.testing.assert_array_equal(pv.read(tmp_path / "exact.vtk").points, surface.points)


def test_overflowing_coordinates_are_an_input_error():
    with pytest.raises(InputError, match="overflow"):
        adt([[0, 0, 0], [1, 0, 1e300], [0, 1, -1e300]])


def test_explicit_format_and_unknown_suffix(surface, tmp_path):
    write_surface(surface, tmp_path / "surface.dat", "vtk")
    assert (tmp_path / "surface.dat").read_text().startswith("# vtk DataFile")
    with pytest.raises(InputError, match="suffix"):
        write_surface(surface, tmp_path / "surface.dat")
    with pytest.raises(InputError, match="'stl'"):
        write_surface(surface, tmp_path / "surface.vtk", "stl")


def test_missing_output_directory(surface, tmp_path):
    with pytest.raises(OutputError, match="does not exist"):
        write_vtk(surface, tmp_path / "nope" / "s.vtk")
    with pytest.raises(OutputError, match="is a directory"):
        write_vtk(surface, tmp_path)


def test_interrupted_write_leaves_no_partial_file(surface, tmp_path, monkeypatch):
    """A failure mid-write keeps the old file and leaves no temporary behind."""
    target = tmp_path / "s.vtk"
    target.write_text("old content")

    def half_then_fail(self, data):
        with open(self, "wb") as fh:
            fh.write(data[: len(data) // 2])
        raise KeyboardInterrupt

    monkeypatch.setattr(Path, "write_bytes", half_then_fail)
    with pytest.raises(KeyboardInterrupt):
        write_vtk(surface, target)
    assert target.read_text() == "old content"
    assert os.listdir(tmp_path) == ["s.vtk"]


def test_failed_vtp_write_leaves_nothing(surface, tmp_path, monkeypatch):
    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(atomic_module.os, "replace", boom)
    with pytest.raises(RuntimeError):
        write_vtp(surface, tmp_path / "s.vtp")
    assert os.listdir(tmp_path) == []


def test_atomic_text_size(tmp_path):
    assert atomic_write_text(tmp_path / "a.txt", "héllo\n") == len("héllo\n".encode())


# ---- point-cloud files ---------------------------------------------------------------------


CLOUD = np.array([[0.0, 1.5, -2.0], [3.0, 4.25, 5.0], [0.1, 1e-5, 7.0]])


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("a.csv", "x,y,z\n0,1.5,-2\n3,4.25,5\n0.1,1e-05,7\n"),
        ("b.csv", "0, 1.5, -2\n3, 4.25, 5\n0.1, 1e-05, 7\n"),
        ("c.xyz", "0 1.5 -2\n3\t4.25   5\n\n0.1 1e-05 7\n"),
        ("d.txt", "# a comment\nX Y Z\n0 1.5 -2\n3 4.25 5\n0.1 1e-05 7\n"),
    ],
)
def test_load_text_clouds(tmp_path, name, text):
    (tmp_path / name).write_text(text)
    np.testing.assert_array_equal(load_cloud(tmp_path / name), CLOUD)


@pytest.mark.parametrize("name", ["c.csv", "c.txt", "c.xyz", "c.npy", "C.CSV"])
def test_save_load_round_trip(tmp_path, name):
    cloud = np.random.default_rng(1).normal(size=(40, 3)) * 1e3
    size = save_cloud(cloud, tmp_path / name)
    assert size == (tmp_path / name).stat().st_size
    np.testing.assert_array_equal(load_cloud(tmp_path / name), cloud)


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("a.csv", "x,y,z\n1,2,3\n4,5\n", r"line 3 has 2 column\(s\), expected 3"),
        ("b.csv", "1,2,3,4\n5,6,7,8\n", r"line 1 has 4 column\(s\)"),
        ("c.txt", "1 2 3\n4 five 6\n", r"line 2, column 2: 'five' is not a number"),
        ("d.xyz", "", "empty"),
        ("e.xyz", "\n# only a comment\n\n", "empty"),
        ("f.csv", "x,y,z\n", "header but no data"),
        ("g.txt", "1 2 3\n4 5 nan\n7 8 9\n1 inf 2\n", r"2 line\(s\): 2, 4"),
        ("h.dat", "1 2 3\n", "unsupported point-cloud file type '.dat'"),
        ("i.txt", b"\xff\xfe\x00binary", "not a UTF-8 text file"),
        ("j.npy", b"not numpy", "not a .npy array file"),
    ],
)
def test_bad_cloud_files(tmp_path, name, content, match):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(path)


def test_bad_npy_shapes(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros((4, 2)))
    with pytest.raises(CloudFileError, match=r"shape \(n, 3\)"):
        load_cloud(tmp_path / "a.npy")
    np.save(tmp_path / "b.npy", np.array([[1.0, 2.0, np.nan]]))
    with pytest.raises(CloudFileError, match=r"row\(s\): 0"):
        load_cloud(tmp_path / "b.npy")


def test_missing_cloud_file(tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        load_cloud(tmp_path / "nothing.csv")
    with pytest.raises(CloudFileError, match="directory"):
        load_cloud(tmp_path)


def test_save_cloud_bad_suffix(tmp_path):
    with pytest.raises(CloudFileError, match="'.vtk'"):
        save_cloud(CLOUD, tmp_path / "c.vtk")


# ---- reading surfaces -----------------------------------------------------------------------


def test_read_surface_rejects_non_triangles(tmp_path):
    pv.Plane(i_resolution=2, j_resolution=2).save(tmp_path / "quads.vtk")
    with pytest.raises(CloudFileError, match="triangles only"):
        read_surface(tmp_path / "quads.vtk")


def test_read_surface_missing_and_garbage(tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        read_surface(tmp_path / "none.vtk")
    (tmp_path / "bad.vtp").write_text("this is not xml")
    with pytest.raises(CloudFileError):
        read_surface(tmp_path / "bad.vtp")


# ---- found in review ------------------------------------------------------------------------


def test_byte_order_mark_is_not_data(tmp_path):
    """Excel's 'CSV UTF-8' starts with a BOM; the first row must not be taken for a header."""
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf0,0,0\n1,0,0\n0,1,0\n1,1,1\n")
    assert load_cloud(tmp_path / "bom.csv").shape == (4, 3)
    (tmp_path / "bomh.csv").write_bytes(b"\xef\xbb\xbfx,y,z\n0,0,0\n1,0,0\n0,1,0\n")
    assert load_cloud(tmp_path / "bomh.csv").shape == (3, 3)


def test_malformed_first_line_is_an_error_not_a_header(tmp_path):
    (tmp_path / "c.csv").write_text("1,2,x\n0,0,0\n1,0,0\n0,1,1\n")
    with pytest.raises(CloudFileError, match=r"line 1, column 3: 'x' is not a number"):
        load_cloud(tmp_path / "c.csv")


@pytest.mark.skipif(
    not Path("/proc/self").is_dir(), reason="needs /proc (an unwritable directory even for root)"
)
def test_unwritable_directory_is_an_output_error(surface):
    with pytest.raises(OutputError, match="cannot write /proc/x.vtk"):
        write_vtk(surface, "/proc/x.vtk")


def test_replacing_a_file_keeps_its_permissions(surface, tmp_path):
    target = tmp_path / "s.vtk"
    target.write_text("old")
    target.chmod(0o600)
    write_vtk(surface, target)
    assert target.stat().st_mode & 0o777 == 0o600
