"""`selfmanip calibrate DATA.csv --preset leap --fit NAME=LO:HI … --out DIR`: a table in the
thesis's §3.5 layout (mm, degrees, `*` missing) written from leaps at known parameters is
fitted back to them; the tables it writes agree with each other and with a direct leap; bad
data and bad `--fit` arguments are errors naming the field."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

import selfmanip
from selfmanip.cli import main
from selfmanip.cli_calibrate import OUTPUT_FILES, parse_fit
from selfmanip.errors import InvalidInputError

pytest.importorskip("scipy")
pytest.importorskip("matplotlib")

M_B, OFFSET_Z = 7.8, 0.025  # defaults: 7.15 kg, offset 0
T2 = [-0.08, -0.03, 0.04, 0.09]


def _read(path) -> dict[str, list[str]]:
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return {h: [r[j] for r in rows[1:]] for j, h in enumerate(rows[0])}


@pytest.fixture(scope="module")
def thesis_table(tmp_path_factory):
    """The (−,−) series at `m_b = 7.8` kg with the marker 25 mm above the centre of mass, in
    the §3.5 layout: t2 s; z, x mm; φ deg; ẋ mm/s; φ̇ deg/s; one entry missing (`*`)."""
    t = selfmanip.sweep("--", t2=T2, m_b=M_B, control_free_joints=True, threads=2)
    assert np.asarray(t["flew"], dtype=bool).all()
    path = tmp_path_factory.mktemp("calib") / "series.csv"
    lines = ["t2 [s],z [mm],x [mm],phi [deg],xdot [mm/s],phidot [deg/s]"]
    for i, t2 in enumerate(T2):
        z = "*" if i == 2 else f"{(t['apex_z_m'][i] + OFFSET_Z) * 1e3:.6f}"
        lines.append(f"{t2},{z},{t['apex_x_m'][i] * 1e3:.6f},{math.degrees(t['apex_phi_rad'][i]):.7f},"
                     f"{t['apex_xdot_m_s'][i] * 1e3:.5f},{math.degrees(t['apex_phidot_rad_s'][i]):.6f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_cli_recovers_the_parameters_of_a_thesis_layout_table_and_writes_consistent_tables(thesis_table, tmp_path,
                                                                                         capsys):
    out = tmp_path / "fit"
    code = main(["calibrate", str(thesis_table), "--preset", "leap", "--strategy", "--", "--fit", "m_b=5:9.5",
                 "--fit", "offset:apex_z_m=-0.1:0.1", "--threads", "2", "--plot", "--out", str(out)])
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUT_FILES + ("fit.png",))
    assert (out / "fit.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "calibration of `leap`" in capsys.readouterr().out
    params = _read(out / "params.csv")
    value = dict(zip(params["name"], map(float, params["value"])))
    # noise-free data (rounded at 1e-6 mm): the fit lands on the generating parameters
    assert value["m_b"] == pytest.approx(M_B, abs=1e-4)
    assert value["offset:apex_z_m"] == pytest.approx(OFFSET_Z, abs=1e-6)
    assert params["determined"] == ["True", "True"]
    stderr = dict(zip(params["name"], map(float, params["stderr"])))
    cov = _read(out / "covariance.csv")
    assert cov["name"] == params["name"]
    for p in cov["name"]:
        assert float(cov[p][cov["name"].index(p)]) == pytest.approx(stderr[p] ** 2, rel=1e-9)
    assert float(cov["m_b"][1]) == pytest.approx(float(cov["offset:apex_z_m"][0]), rel=1e-12)
    res = _read(out / "residuals.csv")
    assert res["apex_z_m_measured"][2] == "nan" and len(res["t2_s"]) == len(T2)
    # predictions: every strategy at the data's t2; the (−,−) rows are the fitted values, and
    # a (+,+) row is a direct leap at the fitted mass plus the fitted offset
    pred = _read(out / "predictions.csv")
    assert len(pred["strategy"]) == 4 * len(T2)
    rows = [i for i, s in enumerate(pred["strategy"]) if s == "--"]
    assert np.allclose([float(pred["apex_x_m"][i]) for i in rows], list(map(float, res["apex_x_m_fitted"])),
                       rtol=0, atol=1e-12)
    i = pred["strategy"].index("++")
    direct = selfmanip.leap("++", float(pred["t2_s"][i]), m_b=value["m_b"], dt=None, control_free_joints=True)
    assert float(pred["apex_z_m"][i]) == pytest.approx(direct.apex.z_m + value["offset:apex_z_m"], abs=1e-12)
    assert float(pred["apex_z_m_std"][i]) > 0
    assert (out / "report.txt").read_text().startswith("calibration of `leap`")


@pytest.mark.parametrize("header, value, field", [
    ("z [furlong]", "300", "z [furlong]"),   # a column with unknown units
    ("phi [deg]", "*", "phi [deg]"),         # every entry missing
])
def test_cli_bad_data_is_an_error_naming_the_column(tmp_path, capsys, header, value, field):
    path = tmp_path / "bad.csv"
    path.write_text(f"t2 [s],x [mm],{header}\n0.0,500,{value}\n0.05,510,{value}\n")
    code = main(["calibrate", str(path), "--strategy", "++", "--fit", "m_b=5:9.5", "--out", str(tmp_path / "o")])
    assert code == 2
    assert f"`{field}`" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("fit, field", [
    ("m_b=9.5:5", "`m_b`"),                        # bounds inverted
    ("wheel_radius=0.1:0.2", "`wheel_radius`"),    # a parameter the model does not have
    ("offset:apex_z_m=-0.1:0.1", "`offset:apex_z_m`"),  # an offset of a channel not measured
    ("m_b=5", "`--fit m_b`"),                      # malformed bounds
])
def test_cli_bad_fit_arguments_are_errors_naming_the_parameter(tmp_path, capsys, fit, field):
    path = tmp_path / "ok.csv"
    path.write_text("t2 [s],x [mm]\n0.0,500\n0.05,510\n")
    code = main(["calibrate", str(path), "--strategy", "++", "--fit", fit, "--out", str(tmp_path / "o")])
    assert code == 2
    assert field in capsys.readouterr().err


@pytest.mark.parametrize("text, field", [
    ("m_b", "--fit"), ("=5:6", "--fit"), ("m_b=5:6:7", "--fit m_b"), ("m_b=a:6", "--fit m_b"),
])
def test_parse_fit_errors_are_typed_and_name_the_field(text, field):
    with pytest.raises(InvalidInputError) as e:
        parse_fit(text)
    assert e.value.field == field


def test_parse_fit_reads_names_with_a_colon_and_negative_bounds():
    assert parse_fit("offset:apex_z_m=-0.05:0.1") == ("offset:apex_z_m", (-0.05, 0.1))
    assert parse_fit(" m_b = 5:9.5") == ("m_b", (5.0, 9.5))
