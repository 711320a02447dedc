"""Point-cloud files in layouts other programs write: numpy structured arrays, rows ending in a comma."""

import itertools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hst
from hypothesis.extra import numpy as hnp

from replication.errors import CloudFileError, CloudFileWarning
from replication.io import load_cloud, save_cloud

CLOUD = np.array([[0.0, 1.5, -2.0], [3.0, 4.25, 5.0], [0.1, 1e-5, 7.0], [-1.0, 2.0, 0.5]])


def _records(cloud, names, formats=("f8", "f8", "f8"), order=(0, 1, 2)):
    """The cloud as a structured array whose k-th field holds coordinate ``order[k]``."""
    records = np.zeros(len(cloud), dtype=list(zip(names, formats)))
    for name, axis in zip(names, order):
        records[name] = cloud[:, axis]
    return records


def test_a_structured_array_of_x_y_z_reads_as_the_plain_array(tmp_path):
    # was: "must be numeric, got ndarray: Cannot cast array data from dtype([('x', '<f8'), ...
    np.save(tmp_path / "r.npy", _records(CLOUD, ["x", "y", "z"]))
    np.save(tmp_path / "plain.npy", CLOUD)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # fields named x, y, z in order: nothing to say
        np.testing.assert_array_equal(load_cloud(tmp_path / "r.npy"), load_cloud(tmp_path / "plain.npy"))
    np.save(tmp_path / "rec.npy", np.rec.fromarrays(CLOUD.T, names="x,y,z"))  # a record array
    np.testing.assert_array_equal(load_cloud(tmp_path / "rec.npy"), CLOUD)


@pytest.mark.parametrize("order", list(itertools.permutations(range(3))))
@pytest.mark.parametrize(
    "style", [("x", "y", "z"), ("X [mm]", "Y [mm]", "Z [mm]"), ("pos_x", "pos_y", "pos_z")]
)
def test_field_names_say_which_field_is_which_axis_as_a_header_does(tmp_path, order, style):
    """The same names give the same cloud as a structured .npy and as a .csv header."""
    names = [style[axis] for axis in order]
    np.save(tmp_path / "r.npy", _records(CLOUD, names, order=order))
    rows = "".join(",".join(repr(float(point[axis])) for axis in order) + "\n" for point in CLOUD)
    (tmp_path / "c.csv").write_text(",".join(names) + "\n" + rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloudFileWarning)  # the .csv says it reordered its columns
        from_csv = load_cloud(tmp_path / "c.csv")
    np.testing.assert_array_equal(load_cloud(tmp_path / "r.npy"), CLOUD)
    np.testing.assert_array_equal(from_csv, CLOUD)


def test_fields_of_other_numeric_types_are_read_as_float64(tmp_path):
    cloud = np.array([[1, 2, 3], [4, 5, 6], [7, 8, 10]], dtype=np.float64)
    np.save(tmp_path / "r.npy", _records(cloud, ["z", "x", "y"], ("f4", "i2", "u8"), order=(2, 0, 1)))
    loaded = load_cloud(tmp_path / "r.npy")
    assert loaded.dtype == np.float64 and loaded.flags.c_contiguous
    np.testing.assert_array_equal(loaded, cloud)


def test_fields_that_name_no_axis_are_read_in_their_order_with_a_warning(tmp_path):
    np.save(tmp_path / "r.npy", _records(CLOUD, ["east", "north", "height"]))
    with pytest.warns(CloudFileWarning, match=r"the fields east, north, height name none of the axes"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "r.npy"), CLOUD)


@pytest.mark.parametrize(
    ("dtype", "shape", "match"),
    [
        (
            [("x", "f8"), ("y", "f8"), ("z", "f8"), ("i", "f8")],
            (4,),
            r"4 field\(s\) \(x, y, z, i\); a point cloud has 3",
        ),
        ([("x", "f8"), ("y", "f8")], (4,), r"2 field\(s\) \(x, y\)"),
        ([("x", "f8"), ("y", "U3"), ("z", "f8")], (4,), r"not all real numbers \(y: <U3\)"),
        ([("x", "f8"), ("y", "c16"), ("z", "f8")], (4,), r"not all real numbers \(y: complex128\)"),
        ([("x", "f8"), ("y", "?"), ("z", "f8")], (4,), r"not all real numbers \(y: bool\)"),
        ([("xyz", "f8", (3,))], (4,), r"the field xyz .* holds 3 values per record; .*data\['xyz'\]"),
        (
            [("p", [("a", "f8"), ("b", "f8")]), ("y", "f8"), ("z", "f8")],
            (4,),
            r"the field p .* the fields a, b",
        ),
        (
            [("x", "f8"), ("X [mm]", "f8"), ("z", "f8")],
            (4,),
            r"name the axis x more than once: name the fields",
        ),
        ([("a", "f8"), ("x", "f8"), ("b", "f8")], (4,), r"name x as field 2 but not the other axes"),
        ([("x", "f8"), ("y", "f8"), ("z", "f8")], (2, 2), r"one dimension .*got shape \(2, 2\)"),
    ],
)
def test_structured_arrays_that_are_not_a_cloud_are_refused_by_name(tmp_path, dtype, shape, match):
    np.save(tmp_path / "r.npy", np.zeros(shape, dtype=dtype))
    with pytest.raises(CloudFileError, match=match) as caught:
        load_cloud(tmp_path / "r.npy")
    assert str(caught.value).startswith(str(tmp_path / "r.npy")) and "\n" not in str(caught.value)


def test_a_structured_array_with_non_ascii_field_names_is_read_and_its_size_checked(tmp_path):
    """numpy saves non-ASCII field names in .npy format 3.0, whose header was not size-checked."""
    records = _records(CLOUD, ["x", "y", "ζ"])
    with pytest.warns(UserWarning, match="format 3.0"):  # numpy's own note on the format
        np.save(tmp_path / "r.npy", records)
    assert (tmp_path / "r.npy").read_bytes()[6:8] == b"\x03\x00"
    np.testing.assert_array_equal(load_cloud(tmp_path / "r.npy"), CLOUD)  # "ζ" names no axis: z
    data = (tmp_path / "r.npy").read_bytes()
    size = int.from_bytes(data[8:12], "little")
    header = data[12 : 12 + size].replace(b"(4,)", b"(100000000000,)")
    (tmp_path / "huge.npy").write_bytes(
        data[:8] + len(header).to_bytes(4, "little") + header + data[12 + size :]
    )
    # was: "not enough memory: Unable to allocate 2.18 TiB", where a 2.0 header had this error
    with pytest.raises(
        CloudFileError, match=r"truncated or damaged: its header announces shape \(100000000000,\)"
    ):
        load_cloud(tmp_path / "huge.npy")
    (tmp_path / "bad.npy").write_bytes(data[:8] + (9).to_bytes(4, "little") + b"{'descr':")
    with pytest.raises(CloudFileError, match=r"damaged header"):
        load_cloud(tmp_path / "bad.npy")


def test_pandas_row_index_is_never_taken_for_an_axis(tmp_path):
    """A frame of two axes saved with its index: the index was read as the third axis."""
    import pandas as pd

    frame = pd.DataFrame({"x": CLOUD[:, 0], "y": CLOUD[:, 1]})
    np.save(tmp_path / "r.npy", frame.to_records())  # fields index, x, y
    frame.to_csv(tmp_path / "c.csv")  # header ",x,y"
    (tmp_path / "u.csv").write_text("Unnamed: 0,y,x\n0,1,2\n1,3,4\n2,5,7\n")
    expected = {
        "r.npy": r"the fields index, x, y name two axes, and its field 1 \('index'\) is pandas' row index, "
        r"not the third axis: save the frame without its index \(to_records\(index=False\)\), or name the "
        r"field z",
        "c.csv": r"its column 1 \(''\) is pandas' row index, .*\(to_csv\(index=False\)\), or name the "
        r"column z",
        "u.csv": r"its column 1 \('Unnamed: 0'\) is pandas' row index",
    }
    for name, match in expected.items():
        with pytest.raises(CloudFileError, match=match):
            load_cloud(tmp_path / name)
    np.save(tmp_path / "all.npy", pd.DataFrame(CLOUD, columns=list("xyz")).to_records())
    with pytest.raises(
        CloudFileError, match=r"4 field\(s\) .* \(DataFrame.to_records\(index=False\) leaves out"
    ):
        load_cloud(tmp_path / "all.npy")
    frame["z"] = CLOUD[:, 2]
    np.save(tmp_path / "ok.npy", frame.to_records(index=False))
    np.testing.assert_array_equal(load_cloud(tmp_path / "ok.npy"), CLOUD)


def test_a_structured_cloud_is_checked_like_a_plain_one(tmp_path):
    cloud = CLOUD.copy()
    cloud[2, 1] = np.nan
    np.save(tmp_path / "r.npy", _records(cloud, ["x", "y", "z"]))
    with pytest.raises(CloudFileError, match=r"NaN or infinite coordinates in 1 row\(s\), counted from 0: 2"):
        load_cloud(tmp_path / "r.npy")


@pytest.mark.parametrize("header", ["x,y,z,\n", "x,y,z\n", ""])
@pytest.mark.parametrize("ending", ["\n", "\r\n"])
def test_rows_that_end_in_a_comma_have_three_columns(tmp_path, header, ending):
    # was: "line 2 has 4 column(s), expected 3 (x, y, z): '0.0,1.5,-2.0,'"
    rows = "".join(",".join(repr(float(v)) for v in point) + "," + ending for point in CLOUD)
    (tmp_path / "c.csv").write_bytes((header.replace("\n", ending) + rows).encode())
    np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), CLOUD)
    (tmp_path / "spaced.csv").write_text(header + rows.replace(",", ", ").replace(", \n", " ,  \n"))
    np.testing.assert_array_equal(load_cloud(tmp_path / "spaced.csv"), CLOUD)


@pytest.mark.parametrize("closing", [",", ""])
def test_a_header_ending_in_a_comma_still_names_the_columns(tmp_path, closing):
    # was: "z,x,y," made four names, so the axis order was not read and the file was read in
    # file order, its axes swapped without a word
    rows = "".join(f"{z},{x},{y}{closing}\n" for x, y, z in CLOUD)
    (tmp_path / "c.csv").write_text("z,x,y,\n" + rows)
    with pytest.warns(CloudFileWarning, match=r"the header z, x, y names the columns in another order"):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), CLOUD)
    (tmp_path / "labels.csv").write_text("east,north,height,\n" + rows)
    with pytest.warns(CloudFileWarning, match=r"the header east, north, height names none"):
        load_cloud(tmp_path / "labels.csv")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x,y,z,\n0,1,2,\n1,0,3,\n1,1,,\n", r"line 4, column 3: '' is not a number"),  # a missing z
        (
            "0,1,2,\n1,0,3,\n1,1,4,,\n",
            r"line 3 has 4 column\(s\), expected 3 \(x, y, z\): '1,1,4,,'",
        ),  # as written
        ("0,1,2,\n1,0,3,\n1,1,4,5,\n", r"line 3 has 4 column\(s\), expected 3"),  # a fourth value
        ("0,1,5\n1,0,3,\n1,1,4\n", r"line 2 has 4 column\(s\), expected 3"),  # the first row has none
    ],
)
def test_a_closing_comma_does_not_hide_a_missing_or_extra_value(tmp_path, text, match):
    (tmp_path / "c.csv").write_text(text)
    with pytest.raises(CloudFileError, match=match):
        load_cloud(tmp_path / "c.csv")


@settings(max_examples=25, deadline=None)
@given(
    hnp.arrays(
        np.float64,
        hst.tuples(hst.integers(1, 10), hst.just(3)),
        elements=hst.floats(allow_nan=False, allow_infinity=False, allow_subnormal=True),
    ),
    hst.permutations(range(3)),
)
def test_a_cloud_reads_the_same_from_csv_plain_npy_and_structured_npy(cloud, order):
    import tempfile
    from pathlib import Path

    cloud = cloud + 0.0  # -0.0 may read back as 0.0 from text
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        save_cloud(cloud, scratch / "c.csv")
        save_cloud(cloud, scratch / "c.npy")
        np.save(scratch / "r.npy", _records(cloud, ["xyz"[axis] for axis in order], order=order))
        for name in ("c.csv", "c.npy", "r.npy"):
            np.testing.assert_array_equal(load_cloud(scratch / name), cloud)


@pytest.mark.parametrize("order", list(itertools.permutations(range(3))))
def test_a_dataframe_s_column_names_say_which_column_is_which_axis(tmp_path, order):
    # was: the columns were taken in their order (z, x, y as x, y, z), and save_cloud wrote the
    # z values under the header x
    import pandas as pd

    import replication as rp

    frame = pd.DataFrame({"xyz"[axis]: CLOUD[:, axis] for axis in order})
    np.testing.assert_array_equal(rp.adt(frame, depth="z").points, rp.adt(CLOUD, depth="z").points)
    save_cloud(frame, tmp_path / "c.csv")
    assert (tmp_path / "c.csv").read_text().splitlines()[1] == "0,1.5,-2"
    np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), CLOUD)
    records = _records(CLOUD, ["xyz"[axis] for axis in order], order=order)
    np.testing.assert_array_equal(rp.adt(records, depth="z").points, rp.adt(CLOUD, depth="z").points)


def test_a_dataframe_without_axis_names_keeps_its_column_order_and_bad_names_are_refused():
    import pandas as pd

    from replication.errors import InputError
    from replication.surfaces.cloud import as_cloud

    np.testing.assert_array_equal(as_cloud(pd.DataFrame(CLOUD)), CLOUD)  # columns 0, 1, 2
    np.testing.assert_array_equal(as_cloud(pd.DataFrame(CLOUD, columns=["e", "n", "h"])), CLOUD)
    with pytest.raises(InputError, match=r"the columns index, x, y name two axes, .* drop that column"):
        as_cloud(pd.DataFrame({"x": CLOUD[:, 0], "y": CLOUD[:, 1]}).reset_index())
    with pytest.raises(InputError, match=r"the columns x, X, z name the axis x more than once") as caught:
        as_cloud(pd.DataFrame(CLOUD, columns=["x", "X", "z"]))
    assert type(caught.value) is InputError  # an argument, not a file
    with pytest.raises(InputError, match=r"a structured array of 2 field\(s\)") as caught:
        as_cloud(np.zeros(4, dtype=[("x", "f8"), ("y", "f8")]))
    assert type(caught.value) is InputError


@pytest.mark.parametrize("order", list(itertools.permutations(range(3))))
@pytest.mark.parametrize("where", ["inner", "outer"])
def test_hierarchical_columns_name_the_axes_in_any_level(order, where):
    # was: MultiIndex columns ("p", "z"), ("p", "x"), ("p", "y") read as text named no axis,
    # so the columns were taken in their order and the axes swapped without a word
    import pandas as pd

    from replication.surfaces.cloud import as_cloud

    names = [("pos", "xyz"[axis]) if where == "inner" else ("xyz"[axis], "mean") for axis in order]
    frame = pd.DataFrame(CLOUD[:, list(order)], columns=pd.MultiIndex.from_tuples(names))
    np.testing.assert_array_equal(as_cloud(frame), CLOUD)
    # flattened to tuple labels (to_flat_index(), as after a groupby().agg): read the same
    flat = frame.set_axis(frame.columns.to_flat_index(), axis=1)
    assert isinstance(flat.columns[0], tuple)
    np.testing.assert_array_equal(as_cloud(flat), CLOUD)


def test_hierarchical_columns_whose_levels_disagree_or_say_nothing():
    import pandas as pd

    from replication.errors import InputError
    from replication.surfaces.cloud import as_cloud

    plain = pd.MultiIndex.from_tuples([("a", "e"), ("a", "n"), ("b", "h")])
    np.testing.assert_array_equal(as_cloud(pd.DataFrame(CLOUD, columns=plain)), CLOUD)  # their order
    crossed = pd.MultiIndex.from_tuples([("x", "z"), ("y", "x"), ("z", "y")])
    with pytest.raises(
        InputError, match=r"name different axes for the same columns \(level 0: x, y, z; level 1"
    ):
        as_cloud(pd.DataFrame(CLOUD, columns=crossed))
    # a level whose names make no order is passed over when another level makes one
    stray = pd.MultiIndex.from_tuples([("x", "z"), ("y", "w"), ("z", "v")])
    np.testing.assert_array_equal(as_cloud(pd.DataFrame(CLOUD, columns=stray)), CLOUD)
    with pytest.raises(
        InputError, match=r"a frame of 6 columns \(0, 1, 2, 3, 4, 5\): a cloud is three columns"
    ):
        as_cloud(pd.DataFrame(np.hstack([CLOUD, CLOUD])))
    twice = pd.MultiIndex.from_tuples([("x", "lo"), ("x", "hi"), ("y", "mid")])
    with pytest.raises(InputError, match=r"the columns x, x, y name the axis x more than once"):
        as_cloud(pd.DataFrame(CLOUD, columns=twice))


def test_names_of_one_axis_warn_that_the_other_two_are_a_guess(tmp_path):
    """lat,lon,z was read as x = lat, y = lon without a word (east,north,height warned): in
    geographic data latitude is the y. Header, .npy fields and frame columns all say so."""
    import pandas as pd

    from replication.surfaces.cloud import as_cloud

    said = r"name only the axis z, so the other (columns|fields) were read in their order, 'lat' as x"
    (tmp_path / "c.csv").write_text("lat,lon,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in CLOUD))
    with pytest.warns(CloudFileWarning, match=said.replace("name only", "names only")):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.csv"), CLOUD)
    records = np.rec.fromarrays(CLOUD.T, names=["lat", "lon", "z"])
    np.save(tmp_path / "c.npy", records)
    with pytest.warns(CloudFileWarning, match=said):
        np.testing.assert_array_equal(load_cloud(tmp_path / "c.npy"), CLOUD)
    for columns in (["lat", "lon", "z"], pd.MultiIndex.from_tuples([("p", "lat"), ("p", "lon"), ("p", "z")])):
        with pytest.warns(CloudFileWarning, match=said):
            np.testing.assert_array_equal(as_cloud(pd.DataFrame(CLOUD, columns=columns)), CLOUD)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # two axes named (the third by elimination), or all three: no guess
        for names in (["x", "y", "height"], ["depth", "x", "y"], ["z", "x", "y"]):
            (tmp_path / "d.csv").write_text(",".join(names) + "\n1,2,3\n4,5,6\n")
            try:
                load_cloud(tmp_path / "d.csv")
            except CloudFileWarning as warned:
                assert "another order" in str(warned), names  # (the reordering's own warning)
        as_cloud(pd.DataFrame(CLOUD))  # a frame's default column numbers name nothing: no warning
        as_cloud(pd.DataFrame(CLOUD, columns=["x", "y", "height"]))
