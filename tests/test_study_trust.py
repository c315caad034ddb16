"""The EMPS study says when a result cannot be trusted (issue 13, items 2, 5, 6-7).

- item 2: physically impossible parameters (negated drive gain) give a warning
  in `EMPSStudy.warnings`, the summary and the report, and the findings start
  with a caveat;
- item 5: an NVR on its cap is reported as such, with no standard error; the
  mass-constancy finding is checked at neighbouring decimation factors and
  called fragile when it changes (the real data at decimation 5);
- item 6 (reporting part): on the built-in plant the recovery states each
  error in stated standard deviations and warns when they do not cover it;
- item 7: summary.json carries std, rel_std, covariance and condition number.
"""

import json

import equinox as eqx
import numpy as np
import pytest

from helpers import requires_emps
from jaxsdp._idim.trust import CAVEAT, conditioning_warnings, nvr_text, sign_warnings
from jaxsdp.studies._output import finite_or_none
from jaxsdp.studies.emps import emps_sdp_stage, emps_study, findings, recovery, report_markdown


class _Fit(eqx.Module):
    theta: np.ndarray
    std: np.ndarray
    rel_std: np.ndarray
    names: tuple = eqx.field(static=True)


def _fit(names, theta, std):
    theta, std = np.asarray(theta, float), np.asarray(std, float)
    return _Fit(theta, std, 100 * std / np.abs(theta), tuple(names))


@pytest.fixture(scope="module")
def builtin(emps_builtin):
    return emps_builtin


@pytest.fixture(scope="module")
def builtin_study(emps_builtin_study):
    return emps_builtin_study


def _summary(study, truth=None, desc=None):
    summary = study.summary()
    summary["data"].update(desc or {})
    summary["simulation"] = {"skipped": "not run in this test"}
    summary["timings"] = {}
    summary["truth"] = truth
    if truth is not None:
        summary["recovery"] = recovery(summary, truth)
    return summary


# --------------------------------------------------------------------------- #
# item 2: physically impossible results
# --------------------------------------------------------------------------- #


def test_sign_warnings_one_message_per_model():
    ok = _fit(("M", "Fv", "Fc"), [95.0, 200.0, 20.0], [0.1, 1.0, 0.1])
    assert sign_warnings(ok, label="LS", positive=("M",), nonnegative=("Fv", "Fc")) == []
    flipped = _fit(("M", "Fv", "Fc"), [-95.0, -200.0, -20.0], [0.1, 1.0, 0.1])
    (w,) = sign_warnings(flipped, label="LS", positive=("M",), nonnegative=("Fv", "Fc"), units={"M": "kg"})
    assert "M = -95 kg (must be > 0)" in w and "Fv = -200" in w and "every sign is inverted" in w
    one = _fit(("M", "Fv", "Fc"), [95.0, 200.0, -0.5], [0.1, 1.0, 0.4])
    (w,) = sign_warnings(one, label="LS", positive=("M",), nonnegative=("Fv", "Fc"))
    assert "Fc = -0.5" in w and "every sign" not in w


def test_conditioning_warnings_collinear_and_imprecise():
    rng = np.random.default_rng(0)
    a = rng.standard_normal(200)
    X = np.column_stack([a, a + 1e-5 * rng.standard_normal(200), np.ones(200)])
    fit = _fit(("M", "Fv", "offset"), [1.0, 1.0, 0.0 + 1e-3], [0.01, 0.5, 1.0])
    w = conditioning_warnings(fit, X, label="LS", check=("M", "Fv"))
    assert any("nearly collinear" in m for m in w)
    assert any("Fv is poorly determined" in m for m in w)
    assert not any("M is poorly" in m for m in w)  # 1 % rel. std is fine
    good = np.column_stack([a, rng.standard_normal(200), np.ones(200)])
    assert not any("collinear" in m for m in conditioning_warnings(fit, good, label="LS"))


def test_negated_drive_gain_is_flagged_everywhere(builtin):
    data = builtin[0]
    bad = eqx.tree_at(lambda d: (d.force, d.gtau), data, (-data.force, -data.gtau))
    study = emps_study(bad, check_decimation=False)
    assert not study.plausible
    text = " ".join(study.warnings)
    assert "M = -9" in text and "must be > 0" in text and "every sign is inverted" in text
    assert "SDP mass" in text and "not positive" in text
    summary = _summary(study)
    assert summary["plausible"] is False and summary["warnings"] == list(study.warnings)
    found = findings(study, summary)
    assert found[0] == CAVEAT
    report = report_markdown(study, summary, {})
    assert "## Warnings" in report and report.index("## Warnings") < report.index("## Findings")
    assert study.tables().startswith("WARNINGS")
    json.dumps(finite_or_none(summary), allow_nan=False)


def test_sound_model_has_no_physical_warning(builtin_study):
    assert builtin_study.plausible
    assert not any("physically impossible" in w for w in builtin_study.warnings)
    assert CAVEAT not in findings(builtin_study, _summary(builtin_study))


# --------------------------------------------------------------------------- #
# item 5: NVRs on a bound, fragile findings
# --------------------------------------------------------------------------- #


def test_nvr_text_never_gives_a_standard_error_on_a_bound():
    assert "no standard error" in nvr_text(1.0, 0.05, "upper", max_nvr=1.0)
    assert "s.e. 0.05" not in nvr_text(1.0, 0.05, "upper", max_nvr=1.0)
    assert "lower bound" in nvr_text(1e-30, 0.05, "lower")
    assert "flat likelihood" in nvr_text(3.8e-12, 805.0, None)
    assert "flat likelihood" in nvr_text(3.8e-12, float("inf"), None)
    assert nvr_text(0.1, 0.07, None) == "0.1 (log10 s.e. 0.07)"
    assert nvr_text(0.1, float("nan"), None) == "0.1 (fixed)"


def test_friction_nvr_on_its_cap_is_reported(builtin_study):
    stage = builtin_study.sdp
    cap = 1e-6
    capped = emps_sdp_stage(builtin_study.inputs, max_nvr=cap)
    assert capped.nvr_bound[1] == "upper" and capped.nvr_friction == pytest.approx(cap)
    assert np.isnan(capped.log10_nvr_se[1])
    line = [ln for ln in capped.table().splitlines() if "NVR d_fric" in ln][0]
    assert "at its cap" in line and "s.e." not in line
    # the default study: whatever the bounds, the summary records them and warnings mention them
    summary = _summary(builtin_study)
    assert summary["sdp"]["nvr_at_bound"] == {"mass": stage.nvr_bound[0], "friction": stage.nvr_bound[1]}
    for term, bound in zip(("M(ddq)", "d_fric(dq)"), stage.nvr_bound):
        assert (bound is not None) == any(f"NVR of {term}" in w for w in builtin_study.warnings)


@requires_emps
def test_mass_finding_checked_at_neighbouring_decimations(emps_real_study_dec5):
    study = emps_real_study_dec5
    assert sorted(study.mass_check) == [2, 5, 10]
    flags = {d: v["mass_constant"] for d, v in study.mass_check.items()}
    assert flags[5] is False and flags[10] is True  # the flip the issue reports
    assert any("depends on the decimation factor" in w for w in study.warnings)
    summary = _summary(study)
    mass = findings(study, summary)[0]
    assert mass.startswith("Mass constancy is NOT established robustly")
    assert "acceleration-weighted SDP mass" in mass
    assert set(summary["mass_constancy"]) == {"2", "5", "10"}
    assert "Mass constancy at neighbouring decimation factors" in report_markdown(study, summary, {})


# --------------------------------------------------------------------------- #
# items 6-7: uncertainty in the summary, coverage on the built-in plant
# --------------------------------------------------------------------------- #


def test_summary_carries_uncertainty(builtin_study):
    summary = _summary(builtin_study)
    for key, res in (("idim_ls", builtin_study.idim), ("idim_ls_asym", builtin_study.idim_asym)):
        sec = summary[key]
        assert list(sec["std"]) == list(res.names) == list(sec["rel_std"])
        np.testing.assert_allclose(list(sec["std"].values()), np.asarray(res.std))
        np.testing.assert_allclose(list(sec["rel_std"].values()), np.asarray(res.rel_std))
        assert sec["cov"]["names"] == list(res.names)
        np.testing.assert_allclose(sec["cov"]["matrix"], np.asarray(res.cov))
        assert sec["cond"] == pytest.approx(float(res.cond))
    fit = summary["idim_sdp"]["curve_fit"]
    assert set(fit["std"]) == {"Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"}
    assert summary["sdp"]["max_nvr"] == 1.0 and "converged" in summary["sdp"]
    json.dumps(finite_or_none(summary), allow_nan=False)


def test_recovery_states_errors_in_standard_deviations(builtin_study, builtin):
    _, truth, desc = builtin
    summary = _summary(builtin_study, truth, desc)
    rec = summary["recovery"]
    a = summary["idim_ls_asym"]
    for k, z in rec["z"]["idim_ls_asym"].items():
        assert z == pytest.approx((a[k] - truth[k]) / a["std"][k])
    # the observation: Fv+ is several stated standard deviations off, and the study says so
    assert abs(rec["z"]["idim_ls_asym"]["Fv_pos"]) > 3
    assert any("Fv_pos" in u for u in rec["understated"])
    assert rec["warnings"] and "do not cover" in rec["warnings"][0]
    report = report_markdown(builtin_study, summary, {})
    assert "error in stated std" in report
