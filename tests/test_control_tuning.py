"""Issue 41 (deliverable 4): the control study's gradient tuning converges or says so, and a design whose peak
force is within 5 % of the EMPS drive's limit is reported "at the limit", not "feasible"."""

import numpy as np
import pytest

from helpers import EMPS_MAT, requires_emps
from jaxsdp.control import REAL_DRIVE
from jaxsdp.control._metrics import AT_LIMIT_MARGIN, force_verdict
from jaxsdp.studies.control import control_study, control_summary, report_markdown, text_output
from jaxsdp.studies.control._study import at_limit_warning, tuned_force_warning
from jaxsdp.studies.control._tuning import CONVERGENCE_TEST, NAMES, TUNE_TOL

LIMIT = float(REAL_DRIVE.force_limit)  # N, 10 V * 35.15 N/V
NOT_CONVERGED = "the gradient tuning did not converge"


def test_the_five_percent_rule():
    assert force_verdict(0.9 * LIMIT, LIMIT) == "feasible"
    assert force_verdict(0.96 * LIMIT, LIMIT) == "at the limit"
    assert force_verdict(LIMIT, LIMIT) == "at the limit"  # a saturated drive gives exactly its limit
    assert force_verdict(1.01 * LIMIT, LIMIT) == "infeasible"
    assert force_verdict((1 - AT_LIMIT_MARGIN) * LIMIT * (1 - 1e-6), LIMIT) == "feasible"
    assert force_verdict(float("nan"), LIMIT) is None and force_verdict(None, LIMIT) is None
    with pytest.raises(ValueError, match="margin"):
        force_verdict(1.0, LIMIT, margin=1.5)


def test_at_limit_warnings_name_the_designs_and_the_tunings_part():
    designs = {
        "near": dict(max_force=0.96 * LIMIT, drive_verdict=force_verdict(0.96 * LIMIT, LIMIT)),
        "fine": dict(max_force=0.9 * LIMIT, drive_verdict=force_verdict(0.9 * LIMIT, LIMIT)),
    }
    (w,) = at_limit_warning(designs)
    assert w.startswith("at the EMPS drive's limit (peak |F| within 5 %") and "near (337.4 N)" in w and "fine" not in w
    assert at_limit_warning({"fine": designs["fine"]}) == []
    hand = designs["fine"]
    tuned = dict(max_force=LIMIT, drive_verdict="at the limit", max_command=1400.0, saturated=True)
    (w,) = tuned_force_warning(tuned, hand)
    assert "the tuning itself pushed it onto the limit" in w and "commands up to 1400 N" in w
    assert "saturation is active at the tuned optimum" in w
    (w,) = tuned_force_warning(dict(tuned, max_force=0.97 * LIMIT, saturated=False, max_command=0.97 * LIMIT), hand)
    assert "the tuning moved it there from the hand-tuned design's 316.4 N" in w
    assert tuned_force_warning(dict(tuned, drive_verdict="feasible"), hand) == []


def _check_tuned(study):
    """The tuning's record, warnings and report agree, and the tuning converged by the stated test."""
    t = study.gradients["tuned"]
    assert t["converged"] and t["reason"] is None, t["runs"]
    assert not [w for w in study.warnings if w.startswith(NOT_CONVERGED)]
    assert t["convergence_test"] == CONVERGENCE_TEST and t["probe"]["decrease"] <= TUNE_TOL
    assert all(r["steps"] <= (r["restarts"] + 1) * t["max_steps"] for r in t["runs"])
    assert t["improved"] and t["cost"] < 0.6 * t["hand_tuned_cost"]  # measured: 0.557 of it
    for name in NAMES:  # within the bounds
        lo, hi = t["bounds"][name]
        assert lo <= t[name] <= hi
    assert t["stable"] and t["max_velocity"] <= 1.02 * study.settings.v_limit
    assert t["drive_verdict"] == force_verdict(t["max_force"], LIMIT)
    assert t["saturated"] == (t["max_command"] > LIMIT * (1 + 1e-9))
    report = report_markdown(study)
    assert CONVERGENCE_TEST in report and f"from wn {t['start_wn']:.3g} rad/s: converged: yes" in report
    summary = control_summary(study)["gradients"]["tuned"]
    assert summary["converged"] is True and summary["steps"] == t["steps"]
    # a saturated step is at the limit everywhere the verdict shows: record, warning, tables
    assert study.real_drive["saturation"]["drive_verdict"] == "at the limit"
    assert study.real_drive["saturation"]["max_force"] == pytest.approx(LIMIT, rel=1e-9)
    (w,) = [w for w in study.warnings if w.startswith("at the EMPS drive's limit")]
    assert "with saturation only" in w
    rows = [line for line in text_output(study).splitlines() if "saturation only" in line]
    assert rows and rows[0].rstrip().endswith("at the limit")
    assert ("the gradient-tuned design is at the EMPS drive's limit" in " ".join(study.warnings)) == (
        t["drive_verdict"] == "at the limit"
    )
    return t


@pytest.fixture(scope="module")
def builtin():
    return control_study()


def test_tuning_converges_on_the_builtin_data(builtin):
    t = _check_tuned(builtin)
    assert t["drive_verdict"] == "feasible" and not t["saturated"]  # measured: 196 N
    assert np.isfinite(t["gradient_norm"])


@requires_emps
def test_tuning_converges_on_the_real_data():
    t = _check_tuned(control_study(str(EMPS_MAT)))
    assert t["drive_verdict"] == "feasible" and not t["saturated"]  # measured: 198 N
