"""Kinematics against hand calculation: the paper's Table 2 and a second gearbox."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from gbpipe import kinematics
from gbpipe.tables import PAPER_TABLE2, TABLE1_STAGES, table2


def test_stage_ratios_of_table1():
    # docs/architecture.md, "Physics": 1 + 96/24 = 5, 1 + 114/21 = 6.4286, 96/29 = 3.3103,
    # total 106.40
    ratios = [float(kinematics.stage_ratio(s)) for s in TABLE1_STAGES]
    np.testing.assert_allclose(ratios, [5.0, 135 / 21, 96 / 29])
    assert kinematics.total_ratio(TABLE1_STAGES) == Fraction(5 * 135 * 96, 21 * 29)
    assert f"{float(kinematics.total_ratio(TABLE1_STAGES)):.2f}" == "106.40"


def _same_printed(x: float, printed: float) -> bool:
    # Table 2 prints 4 decimals (0.0470, 0.0094): agree to 4 significant digits, or to the
    # printed decimals where the paper gives fewer significant digits than that.
    return f"{x:.4g}" == f"{printed:.4g}" or round(x, 4) == round(printed, 4)


def test_table2_reproduced_to_4_digits_except_gmf2():
    ds = kinematics.frequencies(TABLE1_STAGES, 1120.0)
    rows, notes = table2(ds, TABLE1_STAGES)
    by_label = {r["paper_label"]: r for r in rows if "paper_label" in r}
    assert set(by_label) == set(PAPER_TABLE2)
    for label, (_, f_paper, o_paper) in PAPER_TABLE2.items():
        f = float(by_label[label]["frequency_hz"])
        o = float(by_label[label]["order"])
        assert _same_printed(o, o_paper), label
        if label == "GMF2":
            # the paper's 5.6389 Hz contradicts its own order and the teeth: 114 x f_PC2
            assert f == pytest.approx(114 * 1120 / 60 * 21 / 135 * 29 / 96, rel=1e-9)
            assert f"{f:.1f}" == "100.0"
        else:
            assert _same_printed(f, f_paper), label
    assert len(notes) == 1 and "GMF2" in notes[0] and "100.0 Hz" in notes[0]


def test_second_gearbox_by_hand():
    stages = [
        {"type": "planetary", "ring": 99, "planet": 39, "sun": 21, "planets": 3},
        {"type": "parallel", "wheel": 82, "pinion": 23},
        {"type": "parallel", "wheel": 88, "pinion": 22},
    ]
    ds = kinematics.frequencies(stages, 1500.0)
    f_hss = 25.0
    f_is2 = f_hss * 22 / 88          # wheel 3 shaft
    f_is1 = f_is2 * 23 / 82          # sun 1 / wheel 2 shaft
    f_lss = f_is1 / (1 + 99 / 21)    # carrier 1
    np.testing.assert_allclose(ds.shaft_frequency.values, [f_lss, f_is1, f_is2, f_hss],
                               rtol=1e-12)
    np.testing.assert_allclose(ds.mesh_frequency.values,
                               [99 * f_lss, 82 * f_is1, 88 * f_is2], rtol=1e-12)
    assert float(ds.total_ratio) == pytest.approx(120 / 21 * 82 / 23 * 4, rel=1e-12)
    assert kinematics.order_of(stages, "mesh3") == 22
    assert list(ds.shaft_members.values) == ["carrier1", "sun1/wheel2", "pinion2/wheel3",
                                             "pinion3"]


def test_virtual_tachometer_orders_are_exact():
    carrier2 = kinematics.order_of(TABLE1_STAGES, "carrier2")
    mesh2 = kinematics.order_of(TABLE1_STAGES, "mesh2")
    assert isinstance(carrier2, Fraction)
    assert mesh2 == 114 * carrier2                       # mesh 2 is carrier 2's 114th order
    assert f"{float(carrier2):.4f}" == "0.0470" and f"{float(mesh2):.4f}" == "5.3569"
    # planet spin relative to the carrier: Zr/Zp per carrier revolution
    assert kinematics.order_of(TABLE1_STAGES, "planet1") == Fraction(96, 35) * kinematics.order_of(
        TABLE1_STAGES, "carrier1")


def test_rpm_vector_adds_dimension():
    ds = kinematics.frequencies(TABLE1_STAGES, [400.0, 1120.0])
    assert ds.shaft_frequency.dims == ("rpm", "shaft")
    np.testing.assert_allclose(ds.mesh_frequency.sel(rpm=400.0) / ds.mesh_frequency.sel(rpm=1120.0),
                               400 / 1120)


@pytest.mark.parametrize(
    ("stage", "match"),
    [
        ({"type": "planetary", "ring": 20, "planet": 5, "sun": 24, "planets": 3}, "ring"),
        ({"type": "planetary", "ring": 24, "planet": 5, "sun": 24, "planets": 3}, "ring"),
        ({"type": "parallel", "wheel": 96.5, "pinion": 29}, "wheel"),
        ({"type": "parallel", "wheel": 96}, "pinion"),
        ({"type": "worm", "wheel": 96, "pinion": 29}, "type"),
        ({"type": "parallel", "wheel": 0, "pinion": 29}, "wheel"),
    ],
)
def test_bad_stages_name_the_field(stage, match):
    with pytest.raises(ValueError, match=rf"gearbox\.stages\[0\]\.{match}"):
        kinematics.parse_stages([stage])


def test_bad_speed():
    with pytest.raises(ValueError, match="hss_rpm"):
        kinematics.frequencies(TABLE1_STAGES, -5.0)


def test_pulsating_orders_are_electrical_harmonics_on_the_shaft():
    # 2 pole pairs at 1120 rpm: electrical 37.33 Hz; its 6th harmonic, 224 Hz, is order 12
    # of the 18.67 Hz shaft; 12th harmonic order 24
    ripple = {"pole_pairs": 2, "pulsating": [{"harmonic": 6, "amplitude": 100.0},
                                             {"harmonic": 12, "amplitude": 40.0}]}
    shaft_hz = 1120.0 / 60.0
    orders = kinematics.pulsating_orders(ripple)
    assert orders == [(12, 100.0), (24, 40.0)]
    assert orders[0][0] * shaft_hz == pytest.approx(224.0)
    one_pair = {"pulsating": [{"harmonic": 6, "amplitude": 1.0}]}  # pole_pairs: 1
    assert kinematics.pulsating_orders(one_pair) == [(6, 1.0)]
