"""UFF58 interchange: campaign receptance to universal files and back, and other software's files."""

import numpy as np
import pyuff
import pytest
import xarray as xr

from rmbench.errors import InputError
from rmbench.io import read_uff58, write_uff58
from rmbench.io import uff58

COORDS = ["1X", "1Y", "1aX", "1aY"]
# rmbench's numbering: node 1 = tool tip, node 2 = point 1a; direction 1 = +X, 2 = +Y
NODE_DIR = {"1X": (1, 1), "1Y": (1, 2), "1aX": (2, 1), "1aY": (2, 2)}
# other software's test: evenly spaced lines that record 7's six digits hold exactly
LOW = 4.0 + 0.25 * np.arange(50)  # 4-16.25 Hz
HIGH = 600.0 + 2.5 * np.arange(40)  # 600-697.5 Hz
# pyuff's writer (the stand-in for other software) keeps 12 significant digits: 5e-12 relative
PYUFF_RTOL = 1e-10


def campaign(n_postures=3, seed=0):
    """A small campaign (DATA.md): random receptance over 6 decades, 50 + 40 lines, posture 1 failed."""
    rng = np.random.default_rng(seed)
    # awkward spacings, not exact in binary or in 6 digits: 35/49 Hz and 800/39 Hz
    freq = np.concatenate([np.linspace(5.0, 40.0, 50), np.linspace(600.0, 1400.0, 40)])
    shape = (n_postures, freq.size, 4, 4)
    h = 10 ** rng.uniform(-11, -5, shape) * np.exp(1j * rng.uniform(-np.pi, np.pi, shape))
    ok = np.ones(n_postures, bool)
    ok[1] = False
    h[~ok] = np.nan
    return xr.Dataset(
        {"H": (("posture", "freq", "out", "inp"), h),
         "coherence": (("posture", "freq", "out", "inp"), rng.uniform(0.9, 1.0, shape))},
        coords={"freq": freq, "band": ("freq", ["low"] * 50 + ["high"] * 40), "out": COORDS, "inp": COORDS,
                "x": ("posture", rng.uniform(1.3, 1.9, n_postures)),
                "y": ("posture", rng.uniform(-0.3, 0.3, n_postures)),
                "theta": ("posture", rng.uniform(-1.0, 1.0, n_postures)),
                "ok": ("posture", ok),
                "reason": ("posture", np.where(ok, "", "unreachable: joint 5 limit"))},
        attrs={"robot": "irb6660", "tool": "dummy", "seed": 7, "sensor_spacing_low": 0.0334,
               "created": "2025-03-04T10:11:12"})


def write_foreign(path, records, units=None):
    """Write FRFs as other modal software would, with pyuff's own writer.

    records: (out, inp, freq, data, numerator data type), out/inp as (node, direction).
    """
    sets = [] if units is None else [{"type": 164, "units_code": 5, "units_description": "mm newton",
                                     "temp_mode": 1, "length": units[0], "force": units[1], "temp": 1.0,
                                     "temp_offset": 273.15}]
    for (rsp_node, rsp_dir), (ref_node, ref_dir), freq, data, numerator in records:
        sets.append({"type": 58, "func_type": 4, "rsp_node": rsp_node, "rsp_dir": rsp_dir,
                     "ref_node": ref_node, "ref_dir": ref_dir, "x": freq, "data": data,
                     "abscissa_spacing": 1, "abscissa_spec_data_type": 18,
                     "ordinate_spec_data_type": numerator, "orddenom_spec_data_type": 13,
                     "id1": "exported by another package"})
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


def foreign_matrix(freq, seed=1):
    rng = np.random.default_rng(seed)
    shape = (freq.size, 4, 4)
    return 10 ** rng.uniform(-9, -6, shape) * np.exp(1j * rng.uniform(-np.pi, np.pi, shape))


def foreign_records(freq, matrix, numerator=8, nodes=(1, 2)):
    """16 records of a 4x4 matrix on nodes (tip, 1a)."""
    node = {"1": nodes[0], "1a": nodes[1]}
    return [((node[o[:-1]], 1 if o[-1] == "X" else 2), (node[i[:-1]], 1 if i[-1] == "X" else 2),
             freq, matrix[:, a, b], numerator)
            for a, o in enumerate(COORDS) for b, i in enumerate(COORDS)]


def omega(freq):
    return 2 * np.pi * freq[:, None, None]


# --- round trip -------------------------------------------------------------------------------------

def test_ascii_round_trip_preserves_H_to_1e_9_relative(tmp_path):
    # E20.12 fields keep 13 significant digits: 5e-13 relative per component; 1e-9 is the requirement
    ds = campaign()
    write_uff58(ds, tmp_path)
    back = read_uff58(tmp_path)
    ok = ds.ok.values
    rel = np.abs(back.H.values[ok] - ds.H.values[ok]) / np.abs(ds.H.values[ok])
    assert rel.max() < 1e-9


def test_binary_round_trip_preserves_H_bit_for_bit(tmp_path):
    ds = campaign()
    write_uff58(ds, tmp_path, binary=True)
    back = read_uff58(tmp_path)
    assert back.H.dtype == np.complex128
    np.testing.assert_array_equal(back.H.values.view(np.uint64), ds.H.values.view(np.uint64))


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_round_trip_preserves_frequency_lines_and_bands(tmp_path, binary):
    # ID line 5 keeps the first and last line at full precision; linspace rebuilds the lines to
    # round-off (record 7 alone would keep 6 digits: 7e-7 relative on 35/49 Hz)
    ds = campaign()
    write_uff58(ds, tmp_path, binary=binary)
    back = read_uff58(tmp_path)
    np.testing.assert_allclose(back.freq.values, ds.freq.values, rtol=1e-14)
    assert list(back.band.values) == list(ds.band.values)


def test_round_trip_preserves_postures_and_marks_failed_ones(tmp_path):
    # postures.csv holds mm and degrees in shortest round-trip text: the conversion costs an ulp
    ds = campaign()
    write_uff58(ds, tmp_path)
    back = read_uff58(tmp_path)
    assert back.H.dims == ("posture", "freq", "out", "inp")
    assert list(back.out.values) == COORDS and list(back.inp.values) == COORDS
    for name in ("x", "y", "theta"):
        np.testing.assert_allclose(back[name].values, ds[name].values, rtol=1e-15)
    assert list(back.ok.values) == [True, False, True]
    assert list(back.reason.values) == list(ds.reason.values)
    assert np.all(np.isnan(back.H.values[1]))


def test_round_trip_keeps_dataset_attributes_and_records_the_kind(tmp_path):
    ds = campaign()
    write_uff58(ds, tmp_path)
    back = read_uff58(tmp_path)
    assert {k: back.attrs[k] for k in ds.attrs} == ds.attrs
    assert back.attrs["original_kind"] == "receptance"


# --- what is written --------------------------------------------------------------------------------

def test_writes_one_file_per_measured_posture_and_band_and_a_posture_table(tmp_path):
    written = write_uff58(campaign(), tmp_path)
    assert [p.name for p in written] == ["posture_0000_low.uff", "posture_0000_high.uff",
                                         "posture_0002_low.uff", "posture_0002_high.uff",
                                         "postures.csv", "attributes.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in written)
    table = (tmp_path / "postures.csv").read_text().splitlines()
    assert table[0] == "index,stem,x_mm,y_mm,theta_deg,bands,ok,reason"
    assert table[2].startswith("1,posture_0001,") and table[2].endswith(",,false,unreachable: joint 5 limit")
    assert ",low;high,true," in table[1]


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_records_are_receptance_with_rmbench_node_and_direction_numbers(tmp_path, binary):
    # read with pyuff itself: what other software sees
    ds = campaign()
    write_uff58(ds, tmp_path, binary=binary)
    sets = pyuff.UFF(str(tmp_path / "posture_0002_high.uff")).read_sets()
    assert len(sets) == 16
    expected = ds.H.isel(posture=2).where(ds.band == "high", drop=True)
    for record, (out, inp) in zip(sets, [(o, i) for o in COORDS for i in COORDS]):
        assert record["binary"] == int(binary)
        assert (record["func_type"], record["ord_data_type"], record["abscissa_spacing"]) == (4, 6, 1)
        assert (record["abscissa_spec_data_type"], record["ordinate_spec_data_type"],
                record["orddenom_spec_data_type"]) == (18, 8, 13)
        assert (record["rsp_node"], record["rsp_dir"]) == NODE_DIR[out]
        assert (record["ref_node"], record["ref_dir"]) == NODE_DIR[inp]
        # pyuff's reader gets our values: 13 digits in ASCII, exact in binary
        np.testing.assert_allclose(record["data"], expected.sel(out=out, inp=inp).values,
                                   rtol=0 if binary else 1e-12)


def test_failed_write_leaves_no_partial_file(tmp_path, monkeypatch):
    def fail(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(uff58.os, "replace", fail)
    with pytest.raises(InputError, match="cannot write .*posture_0000_low.uff: No space left"):
        write_uff58(campaign(), tmp_path)
    assert list(tmp_path.iterdir()) == []


# --- other software's files -------------------------------------------------------------------------

def test_accelerance_import_is_converted_to_receptance(tmp_path):
    receptance = foreign_matrix(HIGH)
    write_foreign(tmp_path / "tip.unv",
                  foreign_records(HIGH, -omega(HIGH) ** 2 * receptance, numerator=12, nodes=(101, 102)))
    back = read_uff58(tmp_path, node_map={101: "1", 102: "1a"})
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)
    assert back.attrs["original_kind"] == "accelerance"


def test_mobility_import_is_converted_to_receptance(tmp_path):
    receptance = foreign_matrix(LOW)
    write_foreign(tmp_path / "tip.uff", foreign_records(LOW, 1j * omega(LOW) * receptance, numerator=11))
    back = read_uff58(tmp_path)
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)
    assert back.attrs["original_kind"] == "mobility"


def test_node_map_assigns_other_softwares_nodes_to_points(tmp_path):
    # node 7 is the tip and node 3 point 1a: the map, not the order of the numbers, decides
    receptance = foreign_matrix(LOW)
    write_foreign(tmp_path / "test.uff", foreign_records(LOW, receptance, nodes=(7, 3)))
    back = read_uff58(tmp_path, node_map={7: "1", 3: "1a"})
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)


def test_node_map_passes_over_nodes_it_does_not_name(tmp_path):
    receptance = foreign_matrix(LOW)
    extra = [((9, 1), (7, 1), LOW, receptance[:, 0, 0], 8)]  # a third point on the part
    write_foreign(tmp_path / "test.uff", foreign_records(LOW, receptance, nodes=(7, 3)) + extra)
    back = read_uff58(tmp_path, node_map={7: "1", 3: "1a"})
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)


def test_negative_uff_directions_flip_the_sign(tmp_path):
    receptance = foreign_matrix(LOW)
    records = foreign_records(LOW, receptance)
    (rsp_node, rsp_dir), ref, freq, data, kind = records[1]  # H(1X,1Y) measured along -X
    records[1] = ((rsp_node, -rsp_dir), ref, freq, -data, kind)
    write_foreign(tmp_path / "test.uff", records)
    back = read_uff58(tmp_path)
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)


def test_foreign_directory_is_one_posture_at_an_unknown_position_with_bands_by_frequency(tmp_path):
    low, high = foreign_matrix(LOW, seed=1), foreign_matrix(HIGH, seed=2)
    write_foreign(tmp_path / "b_high.uff", foreign_records(HIGH, high))
    write_foreign(tmp_path / "a_low.uff", foreign_records(LOW, low))
    back = read_uff58(tmp_path)
    assert back.sizes["posture"] == 1
    assert np.isnan(back.x.values[0]) and np.isnan(back.theta.values[0]) and back.ok.values[0]
    np.testing.assert_allclose(back.freq.values, np.concatenate([LOW, HIGH]))
    assert list(back.band.values) == ["low"] * LOW.size + ["high"] * HIGH.size
    np.testing.assert_allclose(back.H.values[0, LOW.size:], high, rtol=PYUFF_RTOL)


def test_posture_table_gives_the_position_of_a_foreign_posture(tmp_path):
    write_foreign(tmp_path / "test.uff", foreign_records(LOW, foreign_matrix(LOW)))
    table = tmp_path / "where.csv"
    table.write_text("index,x_mm,y_mm,theta_deg\n0,1800,-200,30\n")
    back = read_uff58(tmp_path, posture_table=table)
    # mm and degrees to m and rad: one rounding
    np.testing.assert_allclose([back.x.values[0], back.y.values[0], back.theta.values[0]],
                               [1.8, -0.2, np.radians(30)], rtol=1e-15)


def test_units_dataset_164_converts_millimetres_to_metres(tmp_path):
    receptance = foreign_matrix(LOW)
    write_foreign(tmp_path / "mm.uff", foreign_records(LOW, 1000.0 * receptance), units=(1000.0, 1.0))
    back = read_uff58(tmp_path)
    np.testing.assert_allclose(back.H.values[0], receptance, rtol=PYUFF_RTOL)


# --- errors -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_truncated_file_is_an_input_error(tmp_path, binary):
    write_uff58(campaign(), tmp_path, binary=binary)
    path = tmp_path / "posture_0002_low.uff"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2 + 123])  # inside the 9th record
    with pytest.raises(InputError, match="posture_0002_low.uff is truncated or corrupt"):
        read_uff58(tmp_path)


def test_corrupt_value_is_an_input_error(tmp_path):
    write_uff58(campaign(), tmp_path)
    path = tmp_path / "posture_0000_high.uff"
    lines = path.read_text().splitlines(keepends=True)
    lines[20] = "  not a number here " + lines[20][20:]
    path.write_text("".join(lines))
    with pytest.raises(InputError, match=r"posture_0000_high.uff is truncated or corrupt: dataset 1 "):
        read_uff58(tmp_path)


def test_missing_direction_is_an_input_error(tmp_path):
    records = [r for r in foreign_records(LOW, foreign_matrix(LOW)) if r[1] != (2, 2)]  # no 1aY hits
    write_foreign(tmp_path / "test.uff", records)
    with pytest.raises(InputError, match=r"test.uff: missing FRFs in the low band: 4 of the 16 .*"
                                         r"H\(1X,1aY\), H\(1Y,1aY\), H\(1aX,1aY\), H\(1aY,1aY\)"):
        read_uff58(tmp_path)


def test_missing_file_of_a_listed_band_is_an_input_error(tmp_path):
    write_uff58(campaign(), tmp_path)
    (tmp_path / "posture_0002_high.uff").unlink()
    with pytest.raises(InputError, match="lists band high of posture 2, but posture_0002_high.uff is missing"):
        read_uff58(tmp_path)


@pytest.mark.parametrize("content", [None, b"exported spectra, not a universal file\n"],
                         ids=["empty-directory", "no-records"])
def test_directory_without_uff58_records_is_an_input_error(tmp_path, content):
    if content is not None:
        (tmp_path / "notes.uff").write_bytes(content)
    with pytest.raises(InputError, match="no UFF58 FRF records in"):
        read_uff58(tmp_path)


def test_inconsistent_frequency_axes_are_an_input_error(tmp_path):
    records = foreign_records(LOW, foreign_matrix(LOW))
    out, inp, _, data, kind = records[5]
    records[5] = (out, inp, 4.0 + 0.2 * np.arange(LOW.size), data, kind)
    write_foreign(tmp_path / "test.uff", records)
    with pytest.raises(InputError, match="inconsistent frequency axes in the low band: test.uff, dataset 6"):
        read_uff58(tmp_path)


def test_unknown_node_numbers_without_node_map_are_an_input_error(tmp_path):
    write_foreign(tmp_path / "test.uff", foreign_records(LOW, foreign_matrix(LOW), nodes=(101, 102)))
    with pytest.raises(InputError, match=r"test.uff, dataset 1: unknown node number\(s\) \[101\]; .*node_map"):
        read_uff58(tmp_path)


def test_frf_given_twice_is_an_input_error(tmp_path):
    records = foreign_records(LOW, foreign_matrix(LOW))
    write_foreign(tmp_path / "test.uff", records + records[:1])
    with pytest.raises(InputError, match=r"H\(1X,1X\) of the low band is given twice"):
        read_uff58(tmp_path)


@pytest.mark.parametrize("spoil, message", [
    (lambda ds: ds.drop_vars("H"), "no receptance variable 'H'"),
    (lambda ds: ds.assign(H=np.abs(ds.H)), "H must be complex"),
    (lambda ds: ds.assign_coords(out=["1X", "1Y", "1aX", "1aZ"]), "out labels must be 1X 1Y 1aX 1aY"),
    (lambda ds: ds.drop_vars("band"), "coordinate 'band'"),
    (lambda ds: ds.assign_coords(freq=ds.freq ** 1.01), "low band's frequency lines .* not increasing "
                                                        "and evenly spaced"),
], ids=["no-H", "real-H", "bad-labels", "no-band", "uneven-band"])
def test_dataset_off_the_conventions_cannot_be_written(tmp_path, spoil, message):
    with pytest.raises(InputError, match=message):
        write_uff58(spoil(campaign()), tmp_path)
