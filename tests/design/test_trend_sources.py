"""Trend sources: the study's tables with ornitail signs, campaign/tunnel/user tables, bad input;
the study's Table 3 tails predicted by leave-one-out fits."""

from __future__ import annotations

import json
import math

import pytest

from ornitail.core.errors import UserInputError
from ornitail.design.trend_data import (
    observations_from_campaign,
    observations_from_study_table_3,
    observations_from_study_table_4,
    observations_from_tunnel,
    observations_from_user_csv,
)
from ornitail.design.trends import fit_trends, leave_one_out_predictions


def _find(observations, configuration, quantity):
    (match,) = [
        o for o in observations if o.configuration == configuration and o.quantity == quantity
    ]
    return match


@pytest.mark.parametrize(
    ("quantity", "published", "rel_sigma_pct", "sign"),
    [
        ("Mq", -4.41e-04, 0.48, 1),
        ("Mu", -1.90e-03, 0.45, -1),
        ("Mw", -3.76e-05, 23.30, -1),
        ("Xq", 1.89e-02, 0.77, -1),
        ("Zq", -1.26e-03, 19.63, -1),
        ("Xu", -1.30e-01, 0.56, 1),
    ],
)
def test_table_4_reads_with_ornitail_signs(quantity, published, rel_sigma_pct, sign):
    observation = _find(observations_from_study_table_4(), "S1b", quantity)
    assert observation.value == pytest.approx(sign * published, rel=1e-12)
    assert observation.sigma == pytest.approx(rel_sigma_pct / 100 * abs(published), rel=1e-12)
    assert observation.x_h_m == pytest.approx(0.098)
    assert observation.tail_id == "S1" and observation.source == "study-table-4"


def test_table_4_has_four_tails_nine_derivatives():
    observations = observations_from_study_table_4()
    assert len(observations) == 36
    assert {o.tail_id for o in observations} == {"S1", "S2", "S3", "S5"}


def test_table_3_steady_states_in_si_with_recovered_sigma():
    observations = observations_from_study_table_3()
    theta = _find(observations, "AR2a", "theta_ss_rad")
    assert theta.value == pytest.approx(math.radians(21.20))
    assert theta.sigma == pytest.approx(math.radians(0.72 / 0.54))
    assert theta.x_h_m == pytest.approx(0.057)
    # V of AR4: |0.74 - 0.75| / 0.19 with a difference known only to +-0.01: left out.
    assert _find(observations, "AR4a", "v_ss_m_s").sigma is None
    assert _find(observations, "S6a", "f_ss_hz").sigma == pytest.approx(0.19 / 0.61)


def test_table_3_tails_predicted_by_fits_on_the_others():
    """The study: linear fits in AR or S on some tails predicted others within ~1 sigma. Here each
    Table 3 tail is predicted by a plane in S and AR fitted to the other five (leave-one-out)."""
    observations = observations_from_study_table_3()
    worst = {}
    for quantity in ("theta_ss_rad", "v_ss_m_s", "f_ss_hz"):
        held_out = leave_one_out_predictions(observations, quantity, "linear")
        ratios = [
            abs(item.measured - item.prediction.value) / item.measured_sigma
            for item in held_out
            if item.measured_sigma is not None
        ]
        worst[quantity] = max(ratios)
        extrapolated = {
            item.configuration for item in held_out if item.prediction.outside_fitted_range
        }
        # S6 (largest S) and AR6, AR2 (largest / smallest AR) lie outside the other five tails.
        assert {"S6a", "AR6a", "AR2a"} <= extrapolated and "AR4a" not in extrapolated
    # Measured (fit on 5 tails, 2 degrees of freedom): 1.32, 0.83, 1.21 sigma(meas). The study's own
    # fits reached 1.00 at worst; we allow 1.5 for the smaller training set.
    assert all(value < 1.5 for value in worst.values()), worst


CAMPAIGN_CSV = (
    (
        "configuration,tail,x_h_m,area_m2,aspect_ratio,mass_kg,iyy_kg_m2,theta0_rad,theta0_deg,"
        "airspeed_m_s,flapping_frequency_hz,Mq,Mq_sigma,Xu,Xu_sigma\n"
    )
    + """S3@98,S3,0.098,0.01188,3.469,0.0234,1.35e-4,0.37,21.2,0.68,,-0.0017,6.1e-05,-0.12,0.004
S1@98,S1,0.098,0.00798,3.453,0.0232,1.30e-4,0.33,18.9,0.64,13.6,-0.0011,5e-05,-0.11,0.004
"""
)


def test_campaign_csv_and_json_give_the_same_observations(tmp_path):
    csv_path = tmp_path / "representative_models.csv"
    csv_path.write_text(CAMPAIGN_CSV)
    from_csv = observations_from_campaign(csv_path)
    mq = _find(from_csv, "S3@98", "Mq")
    assert (mq.value, mq.sigma, mq.source) == (-0.0017, 6.1e-05, f"flight-campaign:{csv_path}")
    assert _find(from_csv, "S3@98", "mass_kg").value == 0.0234
    assert not [o for o in from_csv if o.configuration == "S3@98" and o.quantity == "f_ss_hz"]
    records = [
        {
            "configuration": "S3@98",
            "tail": "S3",
            "x_h_m": 0.098,
            "area_m2": 0.01188,
            "mass_kg": 0.0234,
            "iyy_kg_m2": 1.35e-4,
            "theta0_rad": 0.37,
            "airspeed_m_s": 0.68,
            "flapping_frequency_hz": None,
            "derivatives": {
                "Mq": {"value": -0.0017, "sigma": 6.1e-05},
                "Xu": {"value": -0.12, "sigma": 0.004},
            },
        },
    ]
    json_path = tmp_path / "representative_models.json"
    json_path.write_text(
        json.dumps({"format": "ornitail flight campaign", "version": 1, "configurations": records})
    )
    from_json = observations_from_campaign(json_path)

    def pairs(items):
        return sorted((o.quantity, o.value, o.sigma) for o in items if o.configuration == "S3@98")

    assert pairs(from_json) == pairs(from_csv)


TUNNEL_CSV = (
    (
        "configuration,name,value,sigma,unit,with_respect_to,variance_inflation,reduced_chi_square,"
        "degrees_of_freedom,sigma_inflation,frame\n"
    )
    + """S3 x_h=98mm,Xu,-0.1199,0.046,N/(m/s),u,2.60,11097.4,5,105.3,study body frame
S3 x_h=98mm,Mu,0.0021,0.0003,N m/(m/s),u,2.60,3.1,5,1.7,study body frame
S3 x_h=98mm,Zf,-0.02923,0.00024,N/Hz,f,1.0,65.4,5,8.09,study body frame
S3 x_h=98mm,Mq,,,N m/(rad/s),q,,,0,,study body frame
"""
)


def test_tunnel_derivatives_table(tmp_path):
    path = tmp_path / "S3-xh98mm-derivatives.csv"
    path.write_text(TUNNEL_CSV)
    observations = observations_from_tunnel(path)
    assert sorted(o.quantity for o in observations) == [
        "Mu",
        "Xu",
    ]  # Zf no trend quantity; Mq empty
    xu = _find(observations, "S3 x_h=98mm", "Xu")
    assert (xu.tail_id, xu.x_h_m, xu.value, xu.sigma) == ("S3", 0.098, -0.1199, 0.046)
    assert xu.source == f"tunnel:{path}"
    json_path = tmp_path / "S3-xh98mm-derivatives.json"
    json_path.write_text(
        json.dumps(
            {
                "configuration": "S3 x_h=98mm",
                "derivatives": {
                    "Xu": {"value": -0.1199, "sigma": 0.046, "unit": "N/(m/s)"},
                    "Mq": {"value": None, "sigma": None},
                },
            }
        )
    )
    assert [(o.quantity, o.value) for o in observations_from_tunnel(json_path)] == [("Xu", -0.1199)]


def test_user_csv_with_own_planform(tmp_path):
    path = tmp_path / "mine.csv"
    path.write_text(
        "tail,x_h_mm,quantity,value,sigma,b_mm,b_le_mm,c_r_mm,c_t_mm\n"
        "X1,98,Mq,-0.0009,0.0001,210,110,68,36\n"
        "S3,126,theta_ss_rad,0.35,,,,,\n"
    )
    first, second = observations_from_user_csv(path)
    assert first.geometry.area_m2 == pytest.approx(((0.110 + 0.210) / 2) * 0.032 + 0.210 * 0.036)
    assert (first.sigma, second.sigma, second.tail_id) == (0.0001, None, "S3")


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        ("tail,x_h_mm,value\nS3,98,1\n", "missing column(s) quantity"),
        (
            "tail,x_h_mm,quantity,value\nS3,98,Mq,nan\n",
            "row 2: value: value 'nan' is not a finite number",
        ),
        ("tail,x_h_mm,quantity,value\nS3,98,Mqq,1\n", "unknown quantity 'Mqq'"),
        ("tail,x_h_mm,quantity,value\nX9,98,Mq,1\n", "tail 'X9' is not a study tail"),
        ("tail,x_h_mm,quantity,value,sigma\nS3,98,Mq,1,-2\n", "sigma -2.0 must be positive"),
        ("tail,x_h_mm,quantity,value\nS3,980,Mq,1\n", "980 mm is outside 20-300 mm"),
        ("tail,x_h_mm,quantity,value\nS3,98,Mq,\n", "row 2: value: missing"),
    ],
)
def test_bad_user_csv_is_refused_with_the_place(tmp_path, content, fragment):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(UserInputError, match=None) as caught:
        observations_from_user_csv(path)
    assert str(path) in str(caught.value) and fragment in str(caught.value)


def test_bad_campaign_tables_are_refused(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text(CAMPAIGN_CSV.replace("-0.0017,6.1e-05", "nan,6.1e-05"))
    with pytest.raises(UserInputError, match=r"configuration 'S3@98': Mq: value 'nan'"):
        observations_from_campaign(path)
    path.write_text(CAMPAIGN_CSV.replace("S3,0.098,0.01188", "S3,0.098,0.02"))
    with pytest.raises(UserInputError, match="does not match the planform of tail 'S3'"):
        observations_from_campaign(path)
    path.write_text(CAMPAIGN_CSV.replace("x_h_m,", "xh,"))
    with pytest.raises(UserInputError, match=r"missing column\(s\) x_h_m"):
        observations_from_campaign(path)


def test_study_tables_alone_fit_every_published_quantity():
    model = fit_trends(observations_from_study_table_3() + observations_from_study_table_4())
    assert set(model.trends) == {
        "theta_ss_rad",
        "v_ss_m_s",
        "f_ss_hz",
        "Mq",
        "Mu",
        "Mw",
        "Xq",
        "Xu",
        "Xw",
        "Zq",
        "Zu",
        "Zw",
    }
    # The study: larger S -> larger theta_ss and more negative (stronger) M_q.
    assert model.trends["theta_ss_rad"].coefficients[1] > 0
    assert model.trends["Mq"].coefficients[1] < 0
    assert model.trends["Mq"].sources == ("study-table-4",)
