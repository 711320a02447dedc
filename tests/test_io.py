"""File formats: compact legacy VTK, VTP, point-cloud files, atomic writes."""

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as hst
from hypothesis.extra import numpy as hnp

from replication.errors import CloudFileError, CloudFileWarning, InputError, OutputError
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


@pytest.mark.parametrize("suffix", ["vtk", "vtp"])
def test_surface_files_with_names_that_are_not_utf8(surface, tmp_path, suffix, monkeypatch):
    # VTK takes file names as UTF-8 text; a byte name such as b"a\xff.vtp" (valid on POSIX)
    # raised UnicodeEncodeError. The file must be the one written under a plain name.
    scratch = tmp_path.parent / f"{tmp_path.name}-scratch"
    scratch.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(scratch))
    odd = Path(os.fsdecode(bytes(tmp_path) + b"/a\xff." + suffix.encode()))
    plain = tmp_path / f"plain.{suffix}"
    assert write_surface(surface, odd) == write_surface(surface, plain)
    assert odd.read_bytes() == plain.read_bytes()
    points, triangles = read_surface(odd)
    np.testing.assert_array_equal(points, surface.points)
    np.testing.assert_array_equal(triangles, surface.triangles)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([odd.name, plain.name])
    assert list(scratch.iterdir()) == []  # the staged copies are removed


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


def test_coordinates_whose_squares_overflow_are_triangulated():
    # their spreads overflowed float64 and the cloud was refused; they are computed at unit scale now
    surface = adt([[0, 0, 0], [1, 0, 1e300], [0, 1, -1e300]])
    assert surface.depth_axis_name != "z" and surface.triangles.shape == (1, 3)


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


@pytest.mark.parametrize("signum", ["SIGINT", "SIGTERM"])
def test_an_interrupt_as_the_temporary_file_is_made_leaves_none(tmp_path, monkeypatch, signum):
    """Ctrl-C, or a SIGTERM taken as one, that arrives just after the temporary file exists and
    before the writer has named it: a stopped GA run kept a checkpoint's temporary (seen once in
    the SIGTERM test of the interrupts)."""
    import signal
    import tempfile

    from replication.io.atomic import atomic_write_text
    from replication.sigterm import sigterm_interrupts

    target = tmp_path / "run-0.json"
    target.write_text("old\n")
    real = tempfile.mkstemp

    def made_then_signalled(*args, **kwargs):
        made = real(*args, **kwargs)
        os.kill(os.getpid(), getattr(signal, signum))  # handled at the next line of Python
        return made

    monkeypatch.setattr(atomic_module.tempfile, "mkstemp", made_then_signalled)
    with pytest.raises(KeyboardInterrupt), sigterm_interrupts():  # (raised again at its end if caught in it)
        atomic_write_text(target, "new\n")
    assert sorted(os.listdir(tmp_path)) == ["run-0.json"] and target.read_text() == "old\n"


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


@pytest.mark.parametrize("name", ["c.csv", "c.txt", "c.xyz", "c.npy", "C.CSV", "C.NPY", "c.Txt"])
def test_save_load_round_trip(tmp_path, name):
    # the first point (0, 1, 2) among non-integer points: .txt/.xyz dropped it as pandas' header;
    # "C.NPY" was a 0-byte file (np.save added ".npy" to the temporary name) reported as written
    cloud = np.random.default_rng(1).normal(size=(40, 3)) * 1e3
    cloud[0] = [0, 1, 2]
    (tmp_path / name).write_text("an older file of the same name")
    size = save_cloud(cloud, tmp_path / name)
    assert size == (tmp_path / name).stat().st_size > 40 * 3 * 4
    assert [p.name for p in tmp_path.iterdir()] == [name]
    np.testing.assert_array_equal(load_cloud(tmp_path / name), cloud)


@pytest.mark.parametrize(
    "text",
    [
        "0,1,2\n1.5,2,3\n4,5.25,6\n7,8,1.5\n",  # was: skipped as pandas' header, with a warning
        "0 1 2\n1.5 2 3\n4 5.25 6\n7 8 1.5\n",
        "0, 1, 2\n1,2,3\n4,5,6\n7,1,1\n",  # was: kept as a point, with a warning
        "\n0,1,2\n1.5,2,3\n4,5.25,6\n",
    ],
)
def test_a_first_line_0_1_2_without_a_comment_is_refused(tmp_path, text):
    """pandas' header of column numbers, or the point (0, 1, 2)? Skipping it by a guess made
    `compare` on the same cloud give other numbers as .csv than as .npy."""
    (tmp_path / "p.csv").write_text(text)
    with pytest.raises(CloudFileError, match=r"line \d \('0,? ?1,? ?2'\) is either pandas' header") as info:
        load_cloud(tmp_path / "p.csv")
    assert "delete the line if it is a header" in str(info.value) and "\n" not in str(info.value)


def test_a_pandas_frame_with_column_names_or_a_comment_above_reads_like_the_npy(tmp_path):
    import pandas as pd

    cloud = np.array([[0.0, 1.0, 2.0], [1.5, 2, 3], [4, 5.25, 6]])
    np.save(tmp_path / "c.npy", cloud)
    pd.DataFrame(cloud, columns=["x", "y", "z"]).to_csv(tmp_path / "named.csv", index=False)
    (tmp_path / "points.csv").write_text("# the first point is (0, 1, 2)\n0,1,2\n1.5,2,3\n4,5.25,6\n")
    save_cloud(cloud, tmp_path / "ours.txt")
    assert (tmp_path / "ours.txt").read_text().startswith("# x y z\n0 1 2\n")
    for name in ("named.csv", "points.csv", "ours.txt"):
        np.testing.assert_array_equal(load_cloud(tmp_path / name), load_cloud(tmp_path / "c.npy"))
    pd.DataFrame(cloud).to_csv(tmp_path / "unnamed.csv", index=False)  # its header is 0,1,2
    with pytest.raises(CloudFileError, match="either pandas' header"):
        load_cloud(tmp_path / "unnamed.csv")


@pytest.mark.parametrize("header", ["y x z", "Y [mm] X [mm] Z [mm]", "y,x,z"])
def test_a_comment_line_naming_the_axes_is_a_header(tmp_path, header):
    """numpy.savetxt(..., header="y x z") writes "# y x z": the comment was ignored in .txt,
    while the same names as a CSV header reordered the columns."""
    from replication.errors import CloudFileWarning

    yxz = CLOUD[:, [1, 0, 2]]
    np.savetxt(tmp_path / "c.txt", yxz, header=header)
    with pytest.warns(CloudFileWarning, match=r"x, y and z were read from columns 2, 1 and 3"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), CLOUD)
    # a blank line between the comment and the data does not matter (it was ignored, silently)
    text = (tmp_path / "c.txt").read_text()
    (tmp_path / "gap.txt").write_text(text.replace("\n", "\n\n", 1))
    with pytest.warns(CloudFileWarning, match=r"columns 2, 1 and 3"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "gap.txt"), CLOUD)
    # nor does a label header under it (east,north,height names no axis)
    (tmp_path / "label.txt").write_text(text.replace("\n", "\neast north height\n", 1))
    with pytest.warns(CloudFileWarning, match=r"columns 2, 1 and 3"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "label.txt"), CLOUD)
    np.savetxt(tmp_path / "in_order.txt", CLOUD, header="x y z")  # no reordering, no warning
    np.testing.assert_array_equal(load_cloud(tmp_path / "in_order.txt"), CLOUD)


@pytest.mark.parametrize(
    "comment", ["# x vs y", "# y x z of the first run, in mm", "# a b c", "# y x z\n# made by hand"]
)
def test_other_comments_are_comments(tmp_path, comment):
    (tmp_path / "c.txt").write_text(comment + "\n" + "".join(f"{x} {y} {z}\n" for x, y, z in CLOUD))
    np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), CLOUD)


def test_a_comment_and_a_header_that_disagree_are_refused(tmp_path):
    (tmp_path / "c.csv").write_text("# y x z\nx,y,z\n0,1.5,-2\n3,4.25,5\n")
    with pytest.raises(CloudFileError, match="name the columns in different orders"):
        load_cloud(tmp_path / "c.csv")
    (tmp_path / "units.txt").write_text("y [mm] x (mm) z [mm]\n1.5 0 -2\n4.25 3 5\n0.5 1 1\n")
    with pytest.warns(UserWarning, match="columns 2, 1 and 3"):  # was: six names, read in file order
        np.testing.assert_array_equal(load_cloud(tmp_path / "units.txt")[0], [0, 1.5, -2])
    (tmp_path / "same.csv").write_text("# y x z\ny,x,z\n1.5,0,-2\n4.25,3,5\n0.5,1,1\n")
    with pytest.warns(UserWarning, match="columns 2, 1 and 3"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "same.csv")[0], [0, 1.5, -2])


@settings(max_examples=30, deadline=None)
@given(
    hnp.arrays(
        np.float64,
        hst.tuples(hst.integers(1, 12), hst.just(3)),
        elements=hst.floats(allow_nan=False, allow_infinity=False, allow_subnormal=True),
    ),
    hst.sampled_from([".csv", ".txt", ".xyz", ".npy"]),
)
def test_every_cloud_format_round_trips_exactly(cloud, suffix):
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / f"c{suffix}"
        save_cloud(cloud, path)
        np.testing.assert_array_equal(load_cloud(path), cloud + 0.0)  # -0.0 may read back as 0.0


@pytest.mark.parametrize(
    "header",
    ["z,x,y", "Z,X,Y", "z [mm],x [mm],y [mm]", '"z","x","y"', "z_mm,x_mm,y_mm"],
)
def test_a_header_naming_the_axes_says_which_column_is_which(tmp_path, header):
    # was: the header was skipped and the columns taken as x, y, z: another cloud, another depth axis
    from replication.errors import CloudFileWarning

    rows = "".join(f"{z},{x},{y}\n" for x, y, z in CLOUD)
    (tmp_path / "zxy.csv").write_text(f"{header}\n{rows}")
    with pytest.warns(
        CloudFileWarning, match=r"in another order, so x, y and z were read from columns 2, 3 and 1"
    ):
        np.testing.assert_array_equal(load_cloud(tmp_path / "zxy.csv"), CLOUD)
    (tmp_path / "zxy.txt").write_text("Z X Y\n" + rows.replace(",", " "))
    with pytest.warns(CloudFileWarning, match=r"columns 2, 3 and 1 \(X, Y, Z\)"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "zxy.txt"), CLOUD)
    (tmp_path / "labels.csv").write_text(
        "east,north,height\n" + "".join(f"{x},{y},{z}\n" for x, y, z in CLOUD)
    )
    with pytest.warns(CloudFileWarning, match=r"the header east, north, height names none of the axes"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "labels.csv"), CLOUD)  # other names: file order


def test_a_csv_header_is_read_with_csv_quoting(tmp_path):
    # was: '"z, mm","x, mm","y, mm"' split at every comma gave six names, a label: the columns
    # were read in file order, without a word (depth axis x instead of z), while pandas reads it right
    import pandas as pd

    from replication.errors import CloudFileWarning

    pd.DataFrame(CLOUD[:, [2, 0, 1]], columns=["z, mm", "x, mm", "y, mm"]).to_csv(
        tmp_path / "h.csv", index=False
    )
    assert (tmp_path / "h.csv").read_text().startswith('"z, mm","x, mm","y, mm"\n')
    with pytest.warns(
        CloudFileWarning,
        match=r'the header "z, mm", "x, mm", "y, mm" names .* columns 2, 3 and 1 \("x, mm", ',
    ):
        np.testing.assert_array_equal(load_cloud(tmp_path / "h.csv"), CLOUD)
    (tmp_path / "c.txt").write_text(
        '# "y, mm","x, mm","z, mm"\n' + "".join(f"{y} {x} {z}\n" for x, y, z in CLOUD)
    )
    with pytest.warns(CloudFileWarning, match="columns 2, 1 and 3"):  # a comment above the data, too
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), CLOUD)


@pytest.mark.parametrize(
    ("name", "header"),
    [
        ("pos.csv", "pos_z,pos_x,pos_y"),  # the last _-separated part of each name is an axis
        ("pos_mm.csv", "pos_Z [mm],pos_X [mm],pos_Y [mm]"),
        ("matlab.txt", "% z x y"),  # a MATLAB/Octave comment sign before the names
        ("semicolons.txt", "# z;x;y"),  # a comment naming the axes with ; between them
        ("datum.txt", "z [m; NAP] x [m] y [m]"),  # a ';' inside a unit separates no names
    ],
)
def test_more_headers_naming_the_axes_say_which_column_is_which(tmp_path, name, header):
    # was: each read in file order without a word (z taken for x)
    from replication.errors import CloudFileWarning

    sep = "," if name.endswith(".csv") else " "
    (tmp_path / name).write_text(f"{header}\n" + "".join(f"{z}{sep}{x}{sep}{y}\n" for x, y, z in CLOUD))
    with pytest.warns(CloudFileWarning, match=r"x, y and z were read from columns 2, 3 and 1"):
        np.testing.assert_array_equal(load_cloud(tmp_path / name), CLOUD)
    # not recognised, as before: a comment with other words, or names whose axis is not their last part
    rows = "".join(f"{x},{y},{z}\n" for x, y, z in CLOUD)
    (tmp_path / "comment.csv").write_text("# Z X Y units mm\n" + rows)
    np.testing.assert_array_equal(load_cloud(tmp_path / "comment.csv"), CLOUD)  # a comment: nothing said
    for other in ("pos_z_mm,pos_x_mm,pos_y_mm", "posz,posx,posy"):  # a header: file order, and it says so
        (tmp_path / "other.csv").write_text(f"{other}\n" + rows)
        with pytest.warns(CloudFileWarning, match=r"names none of the axes x, y and z, so its columns"):
            np.testing.assert_array_equal(load_cloud(tmp_path / "other.csv"), CLOUD)


@pytest.mark.parametrize("header", ["py,px,pz", "lat,lon,alt", "yval xval zval"])
def test_a_header_naming_no_axis_says_the_columns_were_read_in_file_order(tmp_path, header):
    """Such a header was skipped without a word: 'py,px,pz' over y, x, z columns gave another
    cloud than the same points in a .npy, silently."""
    from replication.errors import CloudFileWarning

    sep = "," if "," in header else " "
    (tmp_path / "c.csv").write_text(f"{header}\n" + "".join(f"{x}{sep}{y}{sep}{z}\n" for x, y, z in CLOUD))
    said = r"names none of the axes x, y and z, so its columns were read in file order as x, y and z"
    with pytest.warns(CloudFileWarning, match=said):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), CLOUD)


@pytest.mark.parametrize("header", ["x,y,z,i", "x,y", "east\tnorth\theight\tintensity"])
def test_a_header_naming_other_than_three_columns_is_refused(tmp_path, header):
    """'x,y,z,i' over three columns was read as x, y, z without a word. (Names separated by
    spaces are not counted: they may hold spaces themselves.)"""
    sep = "," if "," in header else "\t"
    (tmp_path / "c.csv").write_text(f"{header}\n" + "".join(f"{x}{sep}{y}{sep}{z}\n" for x, y, z in CLOUD))
    with pytest.raises(CloudFileError, match=r"c\.csv: the header .* names \d columns, but a point cloud"):
        load_cloud(tmp_path / "c.csv")


def test_quoted_numbers_are_numbers(tmp_path):
    # csv.QUOTE_ALL (spreadsheets' "quote all values") was refused: "'\"1e-05\"' is not a number"
    (tmp_path / "q.csv").write_text('"1e-05","2","3"\n')  # not a header either
    np.testing.assert_array_equal(load_cloud(tmp_path / "q.csv"), [[1e-05, 2, 3]])
    (tmp_path / "h.csv").write_text('"z","x","y"\n"0","1.5","-2"\n4, "5" ,6\n')
    with pytest.warns(CloudFileWarning, match="another order"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "h.csv"), [[1.5, -2, 0], [5, 6, 4]])


def test_quoted_files_read_as_the_plain_file(tmp_path):
    import csv

    rng = np.random.default_rng(7)
    cloud = rng.normal(size=(40, 3))
    with open(tmp_path / "q.csv", "w", newline="") as handle:
        writer = csv.writer(handle, quoting=csv.QUOTE_ALL)
        writer.writerow(["x", "y", "z"])
        writer.writerows(cloud.tolist())
    save_cloud(cloud, tmp_path / "p.csv")
    np.testing.assert_array_equal(load_cloud(tmp_path / "q.csv"), load_cloud(tmp_path / "p.csv"))


def test_a_quoted_non_number_is_named_with_its_line(tmp_path):
    (tmp_path / "q.csv").write_text('"x","y","z"\n"0","1.5","-2"\n"1","abc","2"\n')
    with pytest.raises(CloudFileError, match=r"line 3, column 2: '\"abc\"' is not a number"):
        load_cloud(tmp_path / "q.csv")
    (tmp_path / "u.csv").write_text('"0","1.5","-2"\n"1,"2","3"\n')  # unbalanced quotes: as written
    with pytest.raises(CloudFileError, match=r"line 2, column 1: '\"1' is not a number"):
        load_cloud(tmp_path / "u.csv")


def test_quoted_column_numbers_are_ambiguous_as_plain_ones(tmp_path):
    (tmp_path / "q.csv").write_text('"0","1","2"\n"1.5","2","3"\n')
    with pytest.raises(CloudFileError, match="pandas' header of column numbers or the point"):
        load_cloud(tmp_path / "q.csv")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("% exported 2026-11-25\nx,y,z\n1,2,3\n4,5,6\n", [[1, 2, 3], [4, 5, 6]]),  # was: 'x' is not a number
        ("% exported\n% by a tool\nz,x,y\n1,2,3\n4,5,6\n", [[2, 3, 1], [5, 6, 4]]),
        ("x,y,z\n1,2,3\n% a comment between the rows\n4,5,6\n", [[1, 2, 3], [4, 5, 6]]),
        ("% a comment\n1 2 3\n4 5 6\n", [[1, 2, 3], [4, 5, 6]]),  # two words: no header
        ("% z x y\n1 2 3\n4 5 6\n", [[2, 3, 1], [5, 6, 4]]),  # a header, as before
        ("%depth,x,y\n1,2,3\n4,5,6\n", [[2, 3, 1], [5, 6, 4]]),  # one axis named: a header
    ],
    ids=["above-header", "two-above-header", "between-rows", "comment", "header", "partial-header"],
)
def test_percent_lines_are_matlab_comments(tmp_path, text, expected):
    (tmp_path / "c.csv").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloudFileWarning)  # (the reordering headers say so)
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), expected)


@pytest.mark.parametrize(
    "text",
    [
        "% z x y\n% ------\n1 2 3\n4 5 6\n",  # (the header was dropped: read in file order, silently)
        "% z x y\n% units: mm\n1 2 3\n4 5 6\n",
        "% z x y\n%\n1 2 3\n4 5 6\n",
        "% z,x,y\n% mm,mm,mm\n1,2,3\n4,5,6\n",
        "# z x y\n% exported\n1 2 3\n4 5 6\n",  # (the '#' header was lost behind the '%' comment)
        "% exported\n% z x y\n1 2 3\n4 5 6\n",
    ],
)
def test_a_percent_header_is_found_among_percent_comments(tmp_path, text):
    (tmp_path / "c.txt").write_text(text)
    with pytest.warns(CloudFileWarning, match="another order"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), [[2, 3, 1], [5, 6, 4]])


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("% z x y\n% x y z\n1 2 3\n", r"lines 1 \('% z x y'\) and 2 \('% x y z'\) both name"),
        ("% Export\n% Columns: z x y\n1 2 3\n", r"names the axes z, x, y in that order among 4 names"),
        ("Columns: z x y\n1 2 3\n", r"names the axes z, x, y in that order"),  # was: read in file order
    ],
)
def test_headers_whose_columns_cannot_be_told_are_refused(tmp_path, text, match):
    (tmp_path / "c.txt").write_text(text)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "c.txt")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('"1,5","2"\n"3,5","4"\n', r"line 1, column 1: '\"1' is not a number"),  # a decimal comma
        ('x,y,z\n"1,000","2"\n', r"line 2, column 1: '\"1' is not a number"),
        ('1,"2,3"\n4,5,6\n', r"line 1, column 2: '\"2' is not a number"),
        ('1,2,"3\n4,5,6\n', r"line 1, column 3: '\"3' is not a number"),  # quotes that do not close
        ('x,y,z\n"1"x,2,3\n', r"line 2, column 1: '\"1\"x' is not a number"),
        ('x,y,z\n"",2,3\n', r"line 2, column 1: '\"\"' is not a number"),
        ('" 0","1","2"\n1.5,2,3\n', r"pandas' header of column numbers or the point"),
    ],
)
def test_quoted_values_that_are_not_one_number_each_are_refused_as_written(tmp_path, text, match):
    """Their values joined again by commas were other columns: "1,5","2" read as 1, 5, 2."""
    (tmp_path / "c.csv").write_text(text)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "c.csv")


def test_a_percent_line_naming_three_columns_is_a_header_that_warns(tmp_path):
    (tmp_path / "c.txt").write_text("% east north height\n1 2 3\n4 5 6\n")
    with pytest.warns(CloudFileWarning, match="names none of the axes"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), [[1, 2, 3], [4, 5, 6]])


def test_a_file_of_percent_comments_only_is_empty(tmp_path):
    (tmp_path / "c.csv").write_text("% nothing\n% here\n")
    with pytest.raises(CloudFileError, match="empty"):
        load_cloud(tmp_path / "c.csv")


@pytest.mark.parametrize("sep", [" ", ",", "\t"])
def test_fortran_d_exponents_read_as_e_exponents(tmp_path, sep):
    """A first line '1.0D+00 2.0D+00 3.0D+00' (Fortran's double-precision output) was taken
    for a header, and the error blamed line 2."""
    fortran = [f"{x:.16E}".replace("E", "D" if i % 2 else "d") for i, x in enumerate(CLOUD.ravel())]
    lines = [sep.join(fortran[3 * i : 3 * i + 3]) for i in range(len(CLOUD))]
    (tmp_path / "f.txt").write_text("\n".join(lines) + "\n")
    np.testing.assert_array_equal(load_cloud(tmp_path / "f.txt"), CLOUD)
    (tmp_path / "h.txt").write_text("x y z\n" + "\n".join(lines) + "\n")  # under a header too
    np.testing.assert_array_equal(load_cloud(tmp_path / "h.txt"), CLOUD)
    (tmp_path / "big.txt").write_text(f"1D0{sep}2D0{sep}3D0\n4D0{sep}5D0{sep}1D400\n")  # quoted as written
    with pytest.raises(
        CloudFileError, match=r"big\.txt: line 2, column 3: '1D400' is too large for a float64"
    ):
        load_cloud(tmp_path / "big.txt")
    (tmp_path / "bad.txt").write_text(f"1D0{sep}2D0{sep}3D0\n4D0{sep}5D0{sep}6Dx\n")  # not a number
    with pytest.raises(CloudFileError, match=r"bad\.txt: line 2, column 3: '6Dx' is not a number"):
        load_cloud(tmp_path / "bad.txt")


@pytest.mark.parametrize(
    ("header", "columns"),
    [("depth,x,y", "2, 3 and 1"), ("y,x,height", "2, 1 and 3"), ("Y [mm];X [mm];h", "2, 1 and 3")],
)
def test_a_header_naming_two_axes_names_the_third_column_too(tmp_path, header, columns):
    # was: any header not naming all three axes was a label, so "depth,x,y" read depth as x
    from replication.errors import CloudFileWarning

    by_name = {"x": 0, "y": 1, "depth": 2, "height": 2, "Y [mm]": 1, "X [mm]": 0, "h": 2}
    names = header.replace(";", ",").split(",")
    rows = "".join(",".join(str(p[by_name[n]]) for n in names) + "\n" for p in CLOUD)
    (tmp_path / "h.csv").write_text(f"{header.replace(';', ',')}\n{rows}")
    with pytest.warns(CloudFileWarning, match=rf"x, y and z were read from columns {columns}"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "h.csv"), CLOUD)
    (tmp_path / "labels.csv").write_text("x,y,height\n" + "".join(f"{x},{y},{z}\n" for x, y, z in CLOUD))
    np.testing.assert_array_equal(load_cloud(tmp_path / "labels.csv"), CLOUD)  # axes in place: no warning


@pytest.mark.parametrize(
    ("header", "match"),
    [
        ("a,x,b", "names x as column 2 but not the other axes"),
        ("x,x,z", "names the axis x more than once"),
        ("id,pos_x,c", "names x as column 2 but not the other axes"),  # was: a label, file order
    ],
)
def test_a_header_that_cannot_say_which_column_is_which_is_refused(tmp_path, header, match):
    (tmp_path / "h.csv").write_text(f"{header}\n0,1,2.5\n3,4,5\n6,7.5,8\n")
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "h.csv")


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("a.csv", "x,y,z\n1,2,3\n4,5\n", r"line 3 has 2 column\(s\), expected 3"),
        ("b.csv", "1,2,3,4\n5,6,7,8\n", r"line 1 has 4 column\(s\)"),
        ("c.txt", "1 2 3\n4 five 6\n", r"line 2, column 2: 'five' is not a number"),
        # Python's float() takes these, numpy's reader does not: the message named no line
        ("c2.csv", "0,0,0\n1,0,0\n0,1_0,1\n", r"line 3, column 2: '1_0' is not a number"),
        ("c3.csv", "0,0,0\n0,\u0661,1\n", r"line 2, column 2: '\u0661' is not a number"),
        ("d.xyz", "", "empty"),
        ("e.xyz", "\n# only a comment\n\n", "empty"),
        ("f.csv", "x,y,z\n", "header but no data"),
        ("g.txt", "1 2 3\n4 5 nan\n7 8 9\n1 inf 2\n", r"2 line\(s\): 2, 4"),
        ("h.dat", "1 2 3\n", "unsupported point-cloud file type '.dat'"),
        ("i.txt", b"\xff\xfe\x00binary", "not a UTF-8 text file"),
        ("j.npy", b"not numpy", "not a .npy array file"),
        # was "the file has a header but no data lines": the NUL bytes made one header-like line
        ("k.csv", b"\x00" * 100, r"not a UTF-8 text file \(a NUL byte at byte 0: binary data, or UTF-16"),
        ("l.xyz", "\ufeff# \u00e9\n1 2 3\n4 5 6\x00\n".encode(), r"NUL byte at byte 19"),
        ("m.csv", "x,y,z\n1,2,3\n".encode("utf-16-le"), r"NUL byte at byte 1: binary data, or UTF-16 text"),
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
    with pytest.raises(CloudFileError, match=r"row\(s\), counted from 0: 0"):
        load_cloud(tmp_path / "b.npy")


@pytest.mark.parametrize("text", [["1_000"], [" 2 "], ["0x5"]])
@pytest.mark.parametrize("kind", ["U", "S"])
def test_a_npy_of_text_is_refused_not_parsed_by_numpy(tmp_path, text, kind):
    # was: numpy's own parsing, looser than the text reader's: '1_000' read as 1000 from a .npy
    # and refused from the .csv; '0x5' gave numpy's "could not convert string to float"
    rows = np.array([["0", "0", "0"], ["1", "0", "0"], ["0", "1", "1"], ["1", "1", text[0]]], dtype=kind)
    np.save(tmp_path / "t.npy", rows)
    with pytest.raises(CloudFileError, match=rf"t.npy: holds text \(dtype [<|]?{kind}\d+\), not numbers"):
        load_cloud(tmp_path / "t.npy")


def test_missing_cloud_file(tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        load_cloud(tmp_path / "nothing.csv")
    with pytest.raises(CloudFileError, match="directory"):
        load_cloud(tmp_path)


def test_save_cloud_bad_suffix(tmp_path):
    with pytest.raises(CloudFileError, match="'.vtk'"):
        save_cloud(CLOUD, tmp_path / "c.vtk")


# ---- reading surfaces -----------------------------------------------------------------------


def test_read_surface_rejects_warped_quads(tmp_path):
    plane = pv.Plane(i_resolution=2, j_resolution=2)
    plane.points[:, 2] = plane.points[:, 0] * plane.points[:, 1]  # a saddle: no quad is flat
    plane.save(tmp_path / "quads.vtk")
    with pytest.raises(CloudFileError, match=r"4 of its 4 polygon\(s\) of more than 3 corners are not flat"):
        read_surface(tmp_path / "quads.vtk")


def test_read_surface_missing_and_garbage(tmp_path):
    with pytest.raises(CloudFileError, match="not found"):
        read_surface(tmp_path / "none.vtk")
    (tmp_path / "bad.vtp").write_text("this is not xml")
    with pytest.raises(CloudFileError):
        read_surface(tmp_path / "bad.vtp")


@pytest.mark.parametrize(
    "content",
    [
        b"\xff\xfe not vtk\n",
        np.random.default_rng(0).bytes(300),
        "not vtk\n".encode("utf-16"),
        b"x\x1b[31m red" + b"y" * 500 + b"\n",  # text, but with a control character, and long
    ],
    ids=["ff-fe", "random", "utf-16", "escape"],
)
def test_a_vtk_file_that_is_not_text_is_not_a_readable_surface(tmp_path, content):
    # was: "unexpected TypeError: a bytes-like object is required, not 'str'": VTK's messages
    # came back as bytes when they quoted bytes that are not UTF-8
    (tmp_path / "bad.vtk").write_bytes(content)
    with pytest.raises(CloudFileError, match=r"bad.vtk: not a readable VTK surface \(VTK: ") as info:
        read_surface(tmp_path / "bad.vtk")
    assert str(info.value).isprintable() and len(str(info.value)) < len(str(tmp_path)) + 200


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


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("a.xyz", "0 1.5 -2 # first point, in mm\n3 4.25 5\n0.1 1e-05 7\n"),
        ("b.txt", "0 1.5 -2\n3 4.25 5 # a, b\n0.1 1e-05 7\n"),
        ("c.csv", "x,y,z # mm, mm, mm\n0,1.5,-2 # a, b\n3,4.25,5\n0.1,1e-05,7\n"),
        ("d.csv", "z,x,y # axes, in another order\n-2,0,1.5\n5,3,4.25\n7,0.1,1e-05\n"),
        ("e.csv", "0,1,2 # a point, not pandas' header\n0,1.5,-2\n3,4.25,5\n0.1,1e-05,7\n"),
    ],
)
def test_a_comment_at_the_end_of_a_line_is_not_data(tmp_path, name, text):
    # was: "0 1.5 -2 # first point, in mm" split at its comma had no number, was taken for a
    # header and the point dropped without a word (a.xyz); the comment's comma gave d.csv's header
    # four names, so it no longer named the axes and z was read as x, without a word either
    import warnings

    from replication.errors import CloudFileWarning

    (tmp_path / name).write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloudFileWarning)  # d.csv's reordering header says so
        cloud = load_cloud(tmp_path / name)
    np.testing.assert_array_equal(cloud, [[0, 1, 2], *CLOUD] if name == "e.csv" else CLOUD)


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


# ---- report data (CSV) ----------------------------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(
    hnp.arrays(np.float64, hst.integers(1, 20), elements=hst.floats(allow_nan=False, allow_infinity=False))
)
def test_report_csv_round_trip_is_exact(values):
    import tempfile

    import pandas as pd

    from replication.report.store import read_csv, write_csv

    frame = pd.DataFrame({"name": [f"s{k}" for k in range(values.size)], "value": values})
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "t.csv"
        write_csv(frame, path)
        back = read_csv(path, columns=("name", "value"))
    assert list(back["name"]) == list(frame["name"])
    np.testing.assert_array_equal(back["value"].to_numpy(np.float64), values)  # "0" reads as int: equal


@pytest.mark.parametrize(
    ("cut", "match"),
    [
        (lambda text: text[: text.rindex(",") + 3], "cut short"),  # in the last row's last field
        (lambda text: text[: text.rindex(",")] + "\n", "line 4 has 1 fields, the header 2"),  # a field lost
    ],
)
def test_report_csv_cut_short_is_refused(tmp_path, cut, match):
    # pandas alone read the half row with NaN: a report from damaged data without a word
    import pandas as pd

    from replication.errors import ReportDataError
    from replication.report.store import read_csv, write_csv

    path = tmp_path / "t.csv"
    write_csv(pd.DataFrame({"name": ["a", "b", "c"], "value": [1.5, 2.25, 3.125]}), path)
    path.write_text(cut(path.read_text()))
    with pytest.raises(ReportDataError, match=match):
        read_csv(path)


# ---- outputs that are not plain files -------------------------------------------------------------


def test_an_output_through_a_symbolic_link_writes_its_target_and_keeps_the_link(surface, tmp_path):
    # the rename replaced the link itself with a regular file
    (tmp_path / "real.vtk").write_text("old")
    (tmp_path / "link.vtk").symlink_to("real.vtk")
    size = write_vtk(surface, tmp_path / "link.vtk")
    assert (tmp_path / "link.vtk").is_symlink() and (tmp_path / "real.vtk").stat().st_size == size


def test_a_symbolic_link_loop_is_an_output_error(surface, tmp_path):
    # was: "unexpected RuntimeError: Symlink loop" from the input/output comparison
    (tmp_path / "a.vtk").symlink_to("b.vtk")
    (tmp_path / "b.vtk").symlink_to("a.vtk")
    with pytest.raises(OutputError, match="cannot follow the symbolic link"):
        write_vtk(surface, tmp_path / "a.vtk")
    from replication.io.paths import check_distinct

    with pytest.raises(OutputError, match="a.vtk: cannot follow the symbolic link"):
        check_distinct([("-o", tmp_path / "a.vtk")], [("INPUT", tmp_path / "in.csv")])
    assert (tmp_path / "a.vtk").is_symlink() and (tmp_path / "b.vtk").is_symlink()


def test_a_fifo_is_not_replaced_by_an_output(surface, tmp_path):
    # the rename replaced a named pipe (or, for root, a device node such as /dev/null) with a file
    for name in ("pipe.vtk", "pipe.vtp", "pipe.csv"):
        os.mkfifo(tmp_path / name)
    with pytest.raises(OutputError, match="exists and is not a regular file"):
        write_vtk(surface, tmp_path / "pipe.vtk")
    with pytest.raises(OutputError, match="exists and is not a regular file"):
        write_vtp(surface, tmp_path / "pipe.vtp")
    with pytest.raises(OutputError, match="exists and is not a regular file"):
        save_cloud(CLOUD, tmp_path / "pipe.csv")
    assert all(path.is_fifo() for path in tmp_path.iterdir()) and len(list(tmp_path.iterdir())) == 3


def test_an_output_through_an_open_descriptor_is_refused(tmp_path):
    # `-o /dev/stdout >> log` renamed the surface over log, the file the shell had opened:
    # its earlier lines were gone; through a pipe, the refusal named "/proc/NNN/fd"
    import subprocess
    import sys

    log = tmp_path / "log.txt"
    log.write_text("earlier lines\n")
    (tmp_path / "out.vtk").symlink_to("/dev/stdout")
    (tmp_path / "fds").symlink_to("/proc/self/fd")  # a link to the directory of descriptors
    names = [
        "/dev/stdout",
        "/dev/fd/1",
        "/proc/self/fd/1",
        str(tmp_path / "out.vtk"),
        str(tmp_path / "fds" / "1"),
    ]
    for name in names:
        command = [sys.executable, "-m", "replication", "adt", "--random", "9", "-o", name, "--format", "vtk"]
        with open(log, "a") as stream:
            done = subprocess.run(command, stdout=stream, stderr=subprocess.PIPE, text=True, check=False)
        assert done.returncode == 1 and log.read_text() == "earlier lines\n", name
        assert f"output path {name} names an open file descriptor" in done.stderr
        assert done.stderr.count("\n") == 1
    from replication.io.atomic import check_output_path

    with pytest.raises(
        OutputError, match=r"out.vtk names an open file descriptor \(/dev/stdout\), not a file"
    ):
        check_output_path(tmp_path / "out.vtk")
    (tmp_path / "fd").mkdir()  # a directory of that name elsewhere is anyone's
    assert check_output_path(tmp_path / "fd" / "1.vtk") == tmp_path / "fd" / "1.vtk"


# ---- report data sets ------------------------------------------------------------------------------


def _files(directory):
    return {str(p.relative_to(directory)): p.read_bytes() for p in directory.rglob("*") if p.is_file()}


def test_a_data_set_is_published_whole_with_its_provenance_last(tmp_path, monkeypatch):
    from replication.report import store

    data = tmp_path / "data"
    with store.data_set(data, "e_provenance.json", stale=["e_old.csv"]) as staged:
        (staged / "e_a.csv").write_text("a1\n")
        (staged / "e_old.csv").write_text("old\n")
        (staged / "e_provenance.json").write_text("{}\n")
    assert _files(data) == {"e_a.csv": b"a1\n", "e_old.csv": b"old\n", "e_provenance.json": b"{}\n"}
    replaced = []
    monkeypatch.setattr(store.os, "replace", lambda a, b: (replaced.append(Path(b).name), os.rename(a, b)))
    with store.data_set(data, "e_provenance.json", stale=["e_old.csv"]) as staged:
        (staged / "sub").mkdir()
        (staged / "sub" / "m.vtk").write_text("m\n")
        (staged / "e_a.csv").write_text("a2\n")
        (staged / "e_provenance.json").write_text('{"run": 2}\n')
    assert replaced[-1] == "e_provenance.json"
    assert _files(data) == {"e_a.csv": b"a2\n", "sub/m.vtk": b"m\n", "e_provenance.json": b'{"run": 2}\n'}


@pytest.mark.parametrize("how", ["one file", "all or none", "data set"])
def test_every_rename_into_place_is_followed_by_a_sync_of_its_directory(tmp_path, monkeypatch, how):
    """Files were synced before their rename, but the directories holding the renames were
    not: after a power cut the old file could be back, or none."""
    from replication.report import store

    events = []
    real_replace, real_fsync = os.replace, os.fsync

    def replace(a, b):
        real_replace(a, b)
        events.append(("rename", Path(b).resolve().parent))

    def fsync(fd):
        real_fsync(fd)
        path = Path(os.readlink(f"/proc/self/fd/{fd}"))
        if path.is_dir():
            events.append(("sync", path))

    monkeypatch.setattr(os, "replace", replace)
    monkeypatch.setattr(os, "fsync", fsync)
    if how == "one file":
        atomic_module.atomic_write_text(tmp_path / "a.txt", "a\n")
    elif how == "all or none":
        (tmp_path / "sub").mkdir()
        with atomic_module.all_or_none():
            atomic_module.atomic_write_text(tmp_path / "a.txt", "a\n")
            atomic_module.atomic_write_text(tmp_path / "sub" / "b.txt", "b\n")
    else:
        with store.data_set(tmp_path / "data", "e_provenance.json") as staged:
            (staged / "sub").mkdir()
            (staged / "sub" / "m.vtk").write_text("m\n")
            (staged / "e_provenance.json").write_text("{}\n")
    renamed = {directory for kind, directory in events if kind == "rename"}
    assert renamed
    for directory in renamed:
        last_rename = max(k for k, event in enumerate(events) if event == ("rename", directory))
        assert ("sync", directory) in events[last_rename:], (directory, events)


@pytest.mark.parametrize("stop", [KeyboardInterrupt, OSError])
def test_a_data_set_stopped_while_it_is_written_leaves_the_old_one_whole(tmp_path, stop):
    # was: files written one by one, so Ctrl-C before the provenance left one run's tables under
    # another run's provenance, and `replication report` rendered the mixture without a word
    from replication.report.store import data_set

    data = tmp_path / "data"
    with data_set(data, "e_provenance.json") as staged:
        (staged / "e_a.csv").write_text("run 1\n")
        (staged / "e_provenance.json").write_text("run 1\n")
    before = _files(data)
    with pytest.raises(stop), data_set(data, "e_provenance.json") as staged:
        (staged / "e_a.csv").write_text("run 2\n")
        raise stop
    assert _files(data) == before and [p.name for p in data.iterdir()] == sorted(before)


def test_a_ctrl_c_while_a_data_set_is_published_is_held_until_it_is_whole(tmp_path, monkeypatch):
    import signal

    from replication.report import store

    data = tmp_path / "data"
    real_replace = os.replace

    def replace_then_ctrl_c(a, b):
        real_replace(a, b)
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C after the first file

    monkeypatch.setattr(store.os, "replace", replace_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt), store.data_set(data, "e_provenance.json") as staged:
        for name in ("e_a.csv", "e_b.csv", "e_provenance.json"):
            (staged / name).write_text("new\n")
    assert sorted(_files(data)) == ["e_a.csv", "e_b.csv", "e_provenance.json"]  # published whole


def test_a_ctrl_c_held_while_a_move_fails_still_stops_and_names_the_failure(tmp_path, monkeypatch, capsys):
    """A Ctrl-C held while the files were moved into place was dropped when a later move
    failed: the write error alone came out, and a caller that handled it went on."""
    import errno
    import signal

    from replication.cli import _stopped
    from replication.errors import OutputError

    (tmp_path / "a.txt").write_text("old a\n")
    real_replace = os.replace
    calls = []

    def replace(a, b):
        calls.append(b)
        if len(calls) == 1:
            real_replace(a, b)
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C after the first move
        elif len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        else:  # putting the first file back
            real_replace(a, b)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt) as caught, atomic_module.all_or_none():
        atomic_module.atomic_write_text(tmp_path / "a.txt", "new a\n")
        atomic_module.atomic_write_text(tmp_path / "b.txt", "new b\n")
    assert isinstance(caught.value.__cause__, OutputError)
    assert atomic_module.written_before(caught.value) == ()  # nothing was left moved
    assert _files(tmp_path) == {"a.txt": b"old a\n"}
    assert _stopped("replication adt", caught.value) == 130
    err = capsys.readouterr().err
    said = f"cannot write {tmp_path / 'b.txt'}: No space left on device"
    assert err == f"replication adt: interrupted; meanwhile: {said}\n"
    monkeypatch.setattr(os, "replace", real_replace)
    with pytest.raises(OutputError), atomic_module.interrupt_deferred():  # no interrupt: the error
        raise OutputError("cannot write x")
    stop = KeyboardInterrupt()  # a cause that is no ReplicationError (a data set's own moves) is said too
    stop.__cause__ = PermissionError(errno.EACCES, "Permission denied", "out/data/e_b.csv")
    assert _stopped("replication table1", stop) == 130
    said = "replication table1: interrupted; meanwhile: out/data/e_b.csv: Permission denied"
    assert capsys.readouterr().err == said + "\n"


def test_a_directory_that_cannot_be_synced_for_an_io_error_says_so(tmp_path, monkeypatch):
    """The sync that makes a rename durable: skipped where a directory cannot be synced at all,
    an error naming the directory on an I/O error (the file is in place, but may not stay)."""
    import errno

    from replication.errors import OutputError

    real_fsync = os.fsync
    answer = [errno.EINVAL]

    def fsync(fd):
        if os.path.isdir(os.readlink(f"/proc/self/fd/{fd}")):
            raise OSError(answer[0], os.strerror(answer[0]))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    atomic_module.atomic_write_text(tmp_path / "a.txt", "a\n")  # EINVAL: cannot sync here, quietly
    answer[0] = errno.EIO
    with pytest.raises(OutputError, match=f"cannot make the files just written in {tmp_path} durable: "):
        atomic_module.atomic_write_text(tmp_path / "a.txt", "b\n")
    assert (tmp_path / "a.txt").read_text() == "b\n"  # in place, and the error does not say otherwise
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_two_saves_into_one_data_directory_publish_one_after_the_other(tmp_path, monkeypatch):
    """Two commands saving one experiment into one directory interleaved their publishing: the
    second's first file beside the first's others, under the first's provenance."""
    import threading
    import time

    from replication.report import store

    data = tmp_path / "data"
    first_inside, go = threading.Event(), threading.Event()
    real_publish = store._publish

    def publish(source, target):
        real_publish(source, target)
        if threading.current_thread().name == "first" and not first_inside.is_set():
            first_inside.set()
            assert go.wait(30)

    monkeypatch.setattr(store, "_publish", publish)

    def save(tag):
        with store.data_set(data, "e_provenance.json") as staged:
            for name in ("e_a.csv", "e_b.csv", "e_provenance.json"):
                (staged / name).write_text(f"{tag}\n")

    first = threading.Thread(target=save, args=("first",), name="first")
    second = threading.Thread(target=save, args=("second",), name="second")
    first.start()
    assert first_inside.wait(30)
    second.start()
    time.sleep(0.5)  # the second save reaches its publishing step (and, now, waits)
    go.set()
    first.join(30)
    second.join(30)
    contents = {(data / name).read_text() for name in ("e_a.csv", "e_b.csv", "e_provenance.json")}
    assert contents == {"second\n"}  # the later set, whole


def test_a_save_that_waits_for_another_says_so_and_then_publishes(tmp_path, capsys):
    """The wait for another save's publishing lock was silent and unbounded (a save stopped with
    Ctrl-Z holds it): the command line now says that it waits, once, and for which directory."""
    import fcntl
    import threading
    import time

    from replication.cli.common import say_when_publishing_waits
    from replication.report import store

    data = tmp_path / "data"
    data.mkdir()
    holder = os.open(data, os.O_RDONLY | os.O_DIRECTORY)  # another command, publishing
    fcntl.flock(holder, fcntl.LOCK_EX)

    after = []

    def save():
        with say_when_publishing_waits(), store.data_set(data, "e_provenance.json") as staged:
            (staged / "e_provenance.json").write_text("mine\n")
        after.append(store.PUBLISH_WAIT.get())  # the notice is the command's, only while it saves

    thread = threading.Thread(target=save)
    err = ""
    try:
        thread.start()
        for _ in range(300):  # up to 30 s for the save to reach its publishing step
            err += capsys.readouterr().err
            if err or not thread.is_alive():
                break
            time.sleep(0.1)
        published_meanwhile = (data / "e_provenance.json").exists()
    finally:
        fcntl.flock(holder, fcntl.LOCK_UN)
        os.close(holder)
        thread.join(30)
    assert not published_meanwhile  # it waited
    assert err == f"waiting for another command to finish saving its data into {data} ...\n"
    assert (data / "e_provenance.json").read_text() == "mine\n"
    assert after == [None]


def test_a_data_set_without_its_provenance_is_refused(tmp_path):
    from replication.report.store import data_set

    with pytest.raises(ValueError, match="no provenance e_provenance.json"):
        with data_set(tmp_path / "data", "e_provenance.json") as staged:
            (staged / "e_a.csv").write_text("x\n")
    assert list((tmp_path / "data").iterdir()) == []


# ---- messages that named the wrong problem ---------------------------------------------------------


def test_surface_and_cloud_file_names_that_are_not_files(surface, tmp_path):
    (tmp_path / "d.vtk").mkdir()
    with pytest.raises(CloudFileError, match="expected a surface file, got a directory: .*d.vtk"):
        read_surface(tmp_path / "d.vtk")  # was: "surface file not found"
    with pytest.raises(CloudFileError, match="the file name is empty"):
        load_cloud("")  # was: "got a directory: ."
    with pytest.raises(CloudFileError, match="the file name is empty"):
        read_surface("")


def test_a_legacy_vtk_cut_short_names_the_cut(surface, tmp_path):
    # was: "the surface must consist of triangles only" for a file cut in its points
    text = legacy_vtk_text(surface.points, surface.triangles)
    (tmp_path / "cut.vtk").write_text(text[: text.index("POLYGONS")])
    with pytest.raises(CloudFileError, match="points but no triangles in the file"):
        read_surface(tmp_path / "cut.vtk")
    (tmp_path / "cut2.vtk").write_text(text[:-20])
    with pytest.raises(CloudFileError, match="not a readable VTK surface"):
        read_surface(tmp_path / "cut2.vtk")


def test_a_cloud_of_complex_numbers_is_refused(tmp_path):
    # was: accepted with numpy's warning that the imaginary parts are discarded
    np.save(tmp_path / "c.npy", CLOUD + 1j)
    with pytest.raises(CloudFileError, match="must be real numbers, got complex values"):
        load_cloud(tmp_path / "c.npy")
    with pytest.raises(InputError, match="must be real numbers"):
        adt((CLOUD + 0j).tolist())
    with pytest.raises(
        InputError, match="points must be numeric, got list"
    ):  # ragged: not numpy's ValueError
        adt([[0, 0, 0], [1, 1], [2, 2, 2]])


def test_a_data_set_keeps_permissions_and_links_and_removes_stale_files(tmp_path):
    import subprocess
    import sys

    from replication.report.store import data_set

    data = tmp_path / "data"
    with data_set(data, "e_provenance.json") as staged:
        for name in ("e_a.csv", "e_provenance.json", "meshes/n9.vtk", "meshes/n45.vtk"):
            (staged / name).parent.mkdir(exist_ok=True)
            (staged / name).write_text("1\n")
    (data / "e_a.csv").chmod(0o600)
    (tmp_path / "kept.csv").write_text("linked\n")
    (data / "e_b.csv").symlink_to(tmp_path / "kept.csv")
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    from replication.io.atomic import writer_tag

    host = writer_tag().split(".", 1)[1]  # "<host>-": this machine's
    abandoned = data / f".staging-{int(dead.stdout)}.{host}x"  # a save that was killed
    abandoned.mkdir()
    (abandoned / "e_a.csv").write_text("partial")
    with data_set(data, "e_provenance.json", stale=["meshes/*"]) as staged:
        (staged / "meshes").mkdir()
        for name in ("e_a.csv", "e_b.csv", "e_provenance.json", "meshes/n9.vtk"):
            (staged / name).write_text("2\n")
    assert (data / "e_a.csv").stat().st_mode & 0o777 == 0o600
    assert (data / "e_b.csv").is_symlink() and (tmp_path / "kept.csv").read_text() == "2\n"
    assert not abandoned.exists() and sorted(p.name for p in (data / "meshes").iterdir()) == ["n9.vtk"]
    assert _files(data)["meshes/n9.vtk"] == b"2\n"


_KILLED_WHILE_PUBLISHING = """
import os, signal, sys
from pathlib import Path
from replication.report import store
real, moved = store._publish, []
def dying(source, target):
    if len(moved) == int(sys.argv[2]):
        os.kill(os.getpid(), signal.SIGKILL)
    moved.append(target)
    real(source, target)
store._publish = dying
with store.data_set(Path(sys.argv[1]), "e_provenance.json", stale=["e_old*.csv"]) as staged:
    (staged / "e_a.csv").write_text("new a\\n")
    (staged / "e_b.csv").write_text("new b\\n")
    (staged / "e_provenance.json").write_text('{"run": "new"}\\n')
"""


@pytest.mark.parametrize("how", ["report", "next save"])
@pytest.mark.parametrize("moves", [0, 1, 2])
def test_a_save_killed_while_it_publishes_is_finished_by_the_next_command(tmp_path, moves, how):
    """A SIGKILL between the first and the last move of a data set left a mix of the old and the
    new files without a provenance: both sets were lost. The plan of the moves is written first,
    and the next command that touches the data makes the moves left."""
    import subprocess
    import sys

    from replication.report import store

    data = tmp_path / "data"
    data.mkdir()
    old = {"e_a.csv": "old a\n", "e_b.csv": "old b\n", "e_old1.csv": "stale\n", "e_provenance.json": "{}\n"}
    for name, text in old.items():
        (data / name).write_text(text)
    killed = subprocess.run([sys.executable, "-c", _KILLED_WHILE_PUBLISHING, str(data), str(moves)])
    assert killed.returncode == -9
    assert not (data / "e_provenance.json").exists()  # killed in the middle: no provenance
    if how == "report":
        store.recover_data_sets(data)
    else:  # another data set saved into the same directory
        with store.data_set(data, "f_provenance.json") as staged:
            (staged / "f_provenance.json").write_text("{}\n")
    files = {p.name: p.read_text() for p in data.iterdir() if p.name.startswith("e_")}
    assert files == {"e_a.csv": "new a\n", "e_b.csv": "new b\n", "e_provenance.json": '{"run": "new"}\n'}
    assert not list(data.glob(".staging-*"))


def test_a_data_set_leaves_an_ignored_or_foreign_ctrl_c_alone(tmp_path, monkeypatch):
    # a background job ignores SIGINT: the held Ctrl-C became a KeyboardInterrupt after publishing
    import signal

    from replication.report import store

    real_replace = os.replace

    def replace_then_ctrl_c(a, b):
        real_replace(a, b)
        os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(store.os, "replace", replace_then_ctrl_c)
    seen = []
    for handler in (signal.SIG_IGN, lambda signum, frame: seen.append(signum)):
        previous = signal.signal(signal.SIGINT, handler)
        try:
            with store.data_set(tmp_path / "data", "e_provenance.json") as staged:
                (staged / "e_provenance.json").write_text("{}\n")
        finally:
            signal.signal(signal.SIGINT, previous)
    assert seen == [signal.SIGINT]


def test_report_csv_quirks(tmp_path):
    from replication.errors import ReportDataError
    from replication.report.store import read_csv

    path = tmp_path / "t.csv"
    path.write_bytes(b'name,note\na,"two\r\nlines"\nb,x\n')
    assert read_csv(path)["note"].tolist() == ["two\r\nlines", "x"]  # the quoted line end is data
    path.write_text('name,note\na,"two\nlines"\nb,"x"\nc\n')
    with pytest.raises(ReportDataError, match="line 5 has 1 fields"):  # the physical line
        read_csv(path)
    path.write_text("name,note\na," + "x" * 200_000 + "\n")
    with pytest.raises(ReportDataError, match="line 2: field larger than field limit"):  # was csv.Error
        read_csv(path)


def test_a_masked_cloud_is_refused_and_a_numpy_string_depth_is_a_str():
    # a masked array was triangulated with the values hidden under its mask, without a word
    masked = np.ma.masked_array(CLOUD, mask=[[0, 0, 0], [0, 1, 0], [0, 0, 0]])
    with pytest.raises(InputError, match="1 masked value"):
        adt(masked)
    assert adt(np.ma.masked_array(CLOUD)).n_vertices == 3  # nothing masked: the plain values
    assert type(adt(CLOUD, depth=np.str_("z")).depth_rule) is str


def test_the_temporary_of_a_killed_write_is_removed_by_the_next_write(surface, tmp_path):
    # SIGKILL during a write left its hidden temporary (80 MB for a 3e6-point surface) for good
    import signal
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(
        f"""
        import os, time
        from replication.io.atomic import atomic_path
        with atomic_path({str(tmp_path / "s.vtk")!r}) as tmp:
            tmp.write_text("partial")
            print(tmp.name, flush=True)
            time.sleep(60)
        """
    )
    with subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True) as child:
        name = child.stdout.readline().strip()
        child.send_signal(signal.SIGKILL)
    (tmp_path / ".s.vtk.1.ffffffff-abc.tmp.vtk").write_text("another machine's write")
    assert (tmp_path / name).is_file()
    write_vtk(surface, tmp_path / "s.vtk")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".s.vtk.1.ffffffff-abc.tmp.vtk", "s.vtk"]


def test_a_file_name_too_long_is_an_input_or_output_error(surface, tmp_path):
    # Python 3.11's Path.exists()/is_dir()/is_symlink() raise OSError on ENAMETOOLONG
    long = tmp_path / ("a" * 300)
    with pytest.raises(
        CloudFileError, match=r"cannot read the point-cloud file .*\.\.\..*: File name too long"
    ):
        load_cloud(f"{long}.csv")
    with pytest.raises(CloudFileError, match=r"cannot read the surface file .*: File name too long"):
        read_surface(f"{long}.vtk")
    with pytest.raises(OutputError, match=r"cannot write .*: File name too long"):
        write_surface(surface, f"{long}.vtk")
    with pytest.raises(OutputError, match=r"cannot write .*: File name too long"):
        save_cloud(CLOUD, f"{long}.npy")
    assert list(tmp_path.iterdir()) == []


def _npy_header_only(path, shape, version=(1, 0)):
    import io

    buf = io.BytesIO()
    header = {"descr": "<f8", "fortran_order": False, "shape": shape}
    write = (
        np.lib.format.write_array_header_1_0 if version == (1, 0) else np.lib.format.write_array_header_2_0
    )
    write(buf, header)
    path.write_bytes(buf.getvalue() + b"\0" * 5)


@pytest.mark.parametrize("version", [(1, 0), (2, 0)])
def test_a_npy_shorter_than_its_header_says_is_refused_before_allocating(tmp_path, version):
    # was: "unexpected MemoryError: Unable to allocate 2.18 TiB" for a header claiming 10**11 points
    _npy_header_only(tmp_path / "big.npy", (10**11, 3), version)
    with pytest.raises(
        CloudFileError, match=r"truncated or damaged: its header announces shape \(100000000000, 3\)"
    ):
        load_cloud(tmp_path / "big.npy")
    np.save(tmp_path / "ok.npy", CLOUD)
    (tmp_path / "cut.npy").write_bytes((tmp_path / "ok.npy").read_bytes()[:-8])
    with pytest.raises(CloudFileError, match=f"{CLOUD.size * 8:,} bytes of data, but the file holds"):
        load_cloud(tmp_path / "cut.npy")
    (tmp_path / "magic.npy").write_bytes(b"\x93NUMPY")
    with pytest.raises(CloudFileError, match="damaged header"):
        load_cloud(tmp_path / "magic.npy")


@pytest.mark.parametrize(
    "values, match",
    [
        (CLOUD > 1, r"got booleans \(dtype bool\)"),
        (CLOUD.astype("int64").astype("M8[D]"), r"got dates and times \(dtype datetime64\[D\]\)"),
        (CLOUD.astype("int64").astype("m8[s]"), r"got time spans \(dtype timedelta64\[s\]\)"),
    ],
)
def test_booleans_and_times_are_not_coordinates(tmp_path, values, match):
    # were: converted to numbers without a word (True -> 1, a date -> days since 1970)
    np.save(tmp_path / "c.npy", values)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "c.npy")
    with pytest.raises(InputError, match=match):
        adt(values)
    with pytest.raises(InputError, match=match):
        adt(values.tolist() if values.dtype.kind == "b" else values)


def test_a_failed_vtk_writer_is_one_line_with_its_reason_and_prints_nothing(surface, tmp_path, capfd):
    """A full disk made VTK print a 12-line pipeline dump (with colour codes) before 'VTK could
    not write out.vtp', which did not say why."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    from replication.io.vtk import _vtk_write

    writer = vtkXMLPolyDataWriter()
    writer.SetInputData(surface.to_polydata())
    with pytest.raises(OutputError) as caught:  # a real failure of VTK: its directory is missing
        _vtk_write(writer, tmp_path / "gone" / "s.vtp", "s.vtp")
    assert str(caught.value).startswith("VTK could not write s.vtp: ") and "\n" not in str(caught.value)
    assert capfd.readouterr().err == ""  # neither VTK's logger nor its output window printed


@pytest.mark.parametrize(
    ("code", "reason"),
    [
        (28, "No space left on device"),
        (27, "File too large"),
        (20007, "out of disk space"),
        (20002, "cannot open file"),
        (0, "the first message"),
    ],  # fmt: skip
)
def test_vtk_writer_failures_in_words(code, reason):
    from replication.io.vtk import _write_failure

    assert _write_failure(code, ["the first message", "another"]) == reason


def test_the_vtk_verbosity_is_restored_after_a_write(surface, tmp_path):
    from vtkmodules.vtkCommonCore import vtkLogger

    before = vtkLogger.GetCurrentVerbosityCutoff()
    write_vtp(surface, tmp_path / "s.vtp")
    assert vtkLogger.GetCurrentVerbosityCutoff() == before


@pytest.mark.parametrize("token", ["1e400", "-2.5E+309", "9" * 400])
def test_a_number_too_large_for_float64_is_named(tmp_path, token):
    """'1e400' was reported as 'NaN or infinite coordinates on 1 line(s): 3', quoting nothing."""
    (tmp_path / "c.csv").write_text(f"x,y,z\n1,2,3\n4,{token},6\n7,8,9\n")
    with pytest.raises(CloudFileError, match=r"c\.csv: line 3, column 2: '[-0-9.eE+]+(\.\.\.9+)?' is too"):
        load_cloud(tmp_path / "c.csv")
    (tmp_path / "n.txt").write_text("1 2 3\n4 inf 6\n7 8 nan\n")  # written as such: as before
    with pytest.raises(CloudFileError, match=r"NaN or infinite coordinates on 2 line\(s\): 2, 3"):
        load_cloud(tmp_path / "n.txt")


@pytest.mark.parametrize(
    ("header", "sep", "warned"),
    [
        ("Easting m\tNorthing m\tHeight m", "\t", "Easting m, Northing m, Height m"),  # names holding spaces
        ("point x\tpoint y\tpoint z", "\t", "point x, point y, point z"),
        ("x,y,z,", ",", None),
    ],  # a separator at the end names no fourth column  # fmt: skip
)
def test_headers_of_three_columns_that_split_oddly_still_load(tmp_path, header, sep, warned):
    """Review: counting the names of a tab-separated header at every space refused these files."""
    import warnings

    from replication.errors import CloudFileWarning

    (tmp_path / "c.txt").write_text(f"{header}\n" + "".join(f"{x}{sep}{y}{sep}{z}\n" for x, y, z in CLOUD))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CloudFileWarning)
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.txt"), CLOUD)
    said = [str(w.message) for w in caught]
    expected = [] if warned is None else [f"the header {warned} names none"]
    assert len(said) == len(expected) and all(text in said[0] for text in expected)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("% exported\n0,1,2\n3,4,5\n", [[0, 1, 2], [3, 4, 5]]),  # a commented file: 0,1,2 is a point
        ("X Coord Y Coord Z Coord\n1 2 3\n", [[1, 2, 3]]),  # axes named in file order, among more words
        ("Point X Y Z\n1 2 3\n", [[1, 2, 3]]),
        ("%% z x y\n1 2 3\n", [[2, 3, 1]]),  # MATLAB's cell mark
        ("%\tz\tx\ty\n1\t2\t3\n", [[2, 3, 1]]),
        ("% z x y\neast,north,up\n1,2,3\n", [[2, 3, 1]]),  # as '# z x y' above a label header
        ("% Z-scan data\n% x y z\n1 2 3\n", [[1, 2, 3]]),  # the line naming all three is the header
        ("% z,x,y\n% x-ray tube 3\n1,2,3\n", [[2, 3, 1]]),
    ],
)
def test_percent_comments_and_headers_of_more_words_read_as_they_say(tmp_path, text, expected):
    (tmp_path / "c.csv").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloudFileWarning)
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), expected)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("% z x y\nx,y,z\n1,2,3\n", r"the comment z, x, y and the header x, y, z name the columns"),
        ("z;x;y;w\n1;2;3\n", r"names the axes z, x, y in that order among 4 names"),
        (",lat,z\n0,1.5,2.5\n1,3.5,4.5\n", r"names one axis, and its column 1 \(''\) is pandas' row index"),
    ],
)
def test_percent_headers_contradicting_a_header_and_row_indexes_are_refused(tmp_path, text, match):
    (tmp_path / "c.csv").write_text(text)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "c.csv")
