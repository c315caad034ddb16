"""Control study figures (Figs. 13, 14, the PIP-SDP cascade, SRIVC) on a small fake study.

The figure functions read only a `ControlStudy`'s fields, so a
`SimpleNamespace` with analytic step responses and an analytic friction
curve stands in for the study (no closed-loop simulation, no
identification): the tests check what is drawn (labels, legends, limits,
the friction forms' values) and what is written.
"""

import math
import struct
import types

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

from jaxsdp.control import ControlSimulation, sdp_friction, step_metrics  # noqa: E402
from jaxsdp.studies.control import FrictionEstimate  # noqa: E402
from jaxsdp.studies.control._figures import (  # noqa: E402
    CONTROL_FIGURE_NAMES,
    control_figures,
    fig_cascade,
    fig_friction_forms,
    fig_srivc,
    fig_step_responses,
    save_control_figures,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FIGURES = (fig_friction_forms, fig_step_responses, fig_cascade, fig_srivc)
STEP = 0.05  # m
V_LIMIT = 0.15  # m/s


def _response(t, wn, eta, *, lag=0.0, force_limit=None):
    """A ControlSimulation of the step response of wn^2 / (s^2 + 2 eta wn s + wn^2), eta <= 1."""
    tt = np.maximum(t - lag, 0.0)
    if eta < 1:
        wd = wn * math.sqrt(1 - eta**2)
        e = np.exp(-eta * wn * tt)
        q = STEP * (1 - e * (np.cos(wd * tt) + eta * wn / wd * np.sin(wd * tt)))
        dq = STEP * e * wn**2 / wd * np.sin(wd * tt)
    else:
        q = STEP * (1 - (1 + wn * tt) * np.exp(-wn * tt))
        dq = STEP * wn**2 * tt * np.exp(-wn * tt)
    force = 95.0 * np.gradient(dq, t) + 200.0 * dq
    if force_limit is not None:
        force = np.clip(force, -force_limit, force_limit)
    aux = STEP * (1 - np.exp(-2 * wn * t)) if lag else np.zeros_like(t)
    return ControlSimulation(t, np.full_like(t, STEP), q, dq, np.gradient(dq, t), q, force, force, aux)


def _diverging(t):
    q = STEP * np.exp(60 * t) * np.sin(300 * t)
    return ControlSimulation(t, np.full_like(t, STEP), q, 300 * q, q, q, 1e6 * q, 1e6 * q, 0 * t)


def _fake_study():
    rng = np.random.default_rng(1)
    v = np.linspace(-0.1, 0.1, 401)
    f = np.where(v > 0, 170 * v + 20, 240 * v - 20) * (1 - np.exp(-np.abs(v) / 0.005))
    t = np.arange(300) * 1e-3
    tc = np.arange(1500) * 1e-3
    sims = dict(
        sdp_pd=_response(t, 250.0, 1.0),
        linear_pd=_response(t, 160.0, 0.4),
        sdp_pd_tabulated=_response(t, 250.0, 1.0),
        sdp_pd_parametric=_response(t, 250.0, 1.0),
        delay=_response(t, 250.0, 0.5),
        delay_wn_max=_response(t, 210.0, 0.8),
        saturation=_response(t, 30.0, 0.3, force_limit=351.5),
        real_wn_max=_response(t, 30.0, 0.3, lag=1e-3, force_limit=351.5),
        pip_sdp=_response(tc, 5.0, 1.0, lag=0.01),
        pip_sdp_paper_lg=_diverging(tc),
        pip_sdp_real=_response(tc, 5.0, 1.0, lag=0.011, force_limit=351.5),
        pip_sdp_tuned=_response(tc, 7.0, 0.9, lag=0.01),
    )
    ti = np.arange(3000) * 1e-3
    ri = np.repeat(rng.uniform(-STEP, STEP, 15), 200)
    x = np.zeros_like(ri)
    for k in range(1, ri.size):
        x[k] = 0.8 * x[k - 1] + 0.2 * ri[k - 1]
    sims["ident"] = dict(t=ti, r=ri, y=x + 0.05 * np.std(x) * rng.standard_normal(x.size), y_model=x)
    return types.SimpleNamespace(
        settings=types.SimpleNamespace(wn=250.0, eta=1.0, v_limit=V_LIMIT, step=STEP),
        friction=dict(
            curve=(v, f),
            velocity_range=[-0.1, 0.1],
            asymmetric=dict(M=95.0, Fv_pos=170.0, Fc_pos=20.0, Fv_neg=240.0, Fc_neg=-1.0),  # Fc_neg < 0: clipped
        ),
        real_drive=dict(largest_wn_delay=210.0, delay_largest_wn=dict(wn=210.0)),
        pip_sdp=dict(loop_gain=0.0133, real_drive=dict(wn=210.0), paper_loop_gain=dict(stable=False, loop_gain=5.0)),
        gradients=dict(tuned=dict(loop_gain=0.0137, wn=10.0, ew=10.0, xw=1.0)),
        srivc=dict(num=[223.14], den=[1.0, 223.14], fit_pct=99.7, noise_pct=5.0),
        sims=sims,
    )


@pytest.fixture
def study():
    return _fake_study()


def _legend_texts(ax) -> list[str]:
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def _line(ax, label_start):
    (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith(label_start)]
    return np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)


# --------------------------------------------------------------------------- #
# Every figure: a Figure whose panels all carry labels with units
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize("fn", FIGURES, ids=[f.__name__ for f in FIGURES])
def test_figure_axes_are_labelled(study, fn):
    fig = fn(study)
    assert isinstance(fig, Figure) and fig.axes
    for k, ax in enumerate(fig.axes):
        x, y = ax.get_xlabel(), ax.get_ylabel()
        assert x.strip() and y.strip(), (fn.__name__, k, x, y)
        assert "(" in x and "(" in y, (fn.__name__, k, x, y)  # units
        lo, hi = ax.get_ylim()
        assert np.isfinite([lo, hi]).all() and hi > lo
    assert any(ax.get_legend() is not None for ax in fig.axes) or fig.legends


@pytest.mark.parametrize("fn", FIGURES, ids=[f.__name__ for f in FIGURES])
def test_not_a_study(fn):
    with pytest.raises(ValueError, match="ControlStudy"):
        fn(types.SimpleNamespace())


# --------------------------------------------------------------------------- #
# Fig. 13: friction forms
# --------------------------------------------------------------------------- #


def test_friction_forms_values_and_range(study):
    fig = fig_friction_forms(study)
    ax1, ax2 = fig.axes
    assert np.allclose(ax1.get_xlim(), (-0.3, 0.3))  # 3x the measured range
    texts = "\n".join(_legend_texts(ax1))
    for word in ("hybrid", "tabulated", "parametric", "N/(m/s)", "measured velocity range", "SDP"):
        assert word in texts, texts
    v, f = study.friction["curve"]
    # beyond the data, the blue line is the hybrid law (fitted lines), the green one is flat
    x, y = _line(ax1, "hybrid: fitted")
    beyond = np.isfinite(x) & (x < -0.1)
    assert beyond.sum() > 10
    law = sdp_friction(v, f, form="hybrid")
    assert np.allclose(y[beyond], np.asarray(law(x[beyond])), atol=1e-9)
    slope = np.polyfit(x[beyond], y[beyond], 1)[0]
    assert 200 < slope < 280  # the negative side's viscous slope (240 N/(m/s)), not the positive one
    x, y = _line(ax1, "tabulated")
    assert np.ptp(y[x > 0.15]) < 1e-9 and np.ptp(y[x < -0.15]) < 1e-9
    # the parametric law jumps at 0 (no vertical segment drawn) and uses max(Fc-, 0) = 0
    x, y = _line(ax1, "parametric")
    assert np.isnan(x[np.nanargmin(np.abs(x)) + 1]) or np.any(np.isnan(x))
    left = np.isfinite(x) & (x < 0)
    assert abs(y[left][-1]) < 1.0  # Fc- clipped to 0: f(0-) = 0
    assert "$F_c^-$ = 0.00 N" in texts
    # (b) is the measured range
    lo, hi = ax2.get_xlim()
    assert lo < -0.1 < 0.1 < hi and hi - lo < 0.25


def test_friction_forms_from_a_friction_estimate(study):
    v, f = study.friction["curve"]
    est = FrictionEstimate(v, f, dict(M=95.0, Fv=200.0, Fc=20.0, offset=0.0), study.friction["asymmetric"], "fake")
    ax = fig_friction_forms(est).axes[0]
    assert np.allclose(ax.get_xlim(), (-0.3, 0.3))
    x, y = _line(ax, "hybrid: SDP inside")
    inside = np.isfinite(x)
    assert np.allclose(y[inside], np.asarray(sdp_friction(v, f, form="hybrid")(x[inside])))


def test_friction_forms_extent(study):
    ax = fig_friction_forms(study, extent=2.0).axes[0]
    assert np.allclose(ax.get_xlim(), (-0.2, 0.2))
    with pytest.raises(ValueError, match="extent"):
        fig_friction_forms(study, extent=0.5)


# --------------------------------------------------------------------------- #
# Fig. 14: step responses
# --------------------------------------------------------------------------- #


def test_step_responses_settling_times(study):
    fig = fig_step_responses(study)
    ax1, ax2, ax3, ax4 = fig.axes
    texts = _legend_texts(ax1)
    for key, name in (("sdp_pd", "SDP-PD"), ("linear_pd", "linear PD")):
        sim = study.sims[key]
        m = step_metrics(sim.t, sim.q, STEP, y0=0.0)
        (label,) = [s for s in texts if s.startswith(name)]
        assert f"{1e3 * m.settling_time:.0f} ms" in label and f"{m.overshoot:.1f} %" in label, label
    assert any("2 % band" in s for s in texts)
    # the band is +-2 % of the 50 mm step around 50 mm
    (band,) = [p for p in ax1.patches if p.get_label().startswith("$\\pm$2")]
    ys = band.get_path().transformed(band.get_patch_transform()).vertices[:, 1]
    assert np.allclose([ys.min(), ys.max()], [49.0, 51.0])
    # the real-drive panels name the wn values; the force panel shows the limit
    assert any("210" in s and "2 % overshoot" in s for s in _legend_texts(ax2))
    assert any("351.5 N limit" in s for s in _legend_texts(ax3))
    assert ax4.get_ylim()[1] < 500 and "x the limit" in ax4.get_title(loc="left")


def test_step_responses_diverging_and_missing_cases(study):
    study.sims["delay"] = _diverging(study.sims["delay"].t)
    del study.sims["real_wn_max"]
    fig = fig_step_responses(study)
    ax2, ax3 = fig.axes[1], fig.axes[2]
    assert any(s.endswith("unstable") for s in _legend_texts(ax2))
    assert ax2.get_ylim()[1] < 5 * 1e3 * STEP  # a diverging response does not squash the others
    assert not any("real drive" in s for s in _legend_texts(ax3))
    with pytest.raises(ValueError, match="linear_pd"):
        del study.sims["linear_pd"]
        fig_step_responses(study)


# --------------------------------------------------------------------------- #
# PIP-SDP cascade
# --------------------------------------------------------------------------- #


def test_cascade_designs_limits_and_paper_note(study):
    fig = fig_cascade(study)
    ax1, ax2, ax3, ax4, ax5 = fig.axes
    texts = _legend_texts(ax1)
    assert sum(("hand-tuned" in s) or ("gradient-tuned" in s) for s in texts) == 3, texts
    assert any("inner reference" in s for s in texts)
    assert any("0.0133" in s for s in texts) and any("0.0137" in s for s in texts)
    for ax in (ax2, ax4):
        levels = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines() if len(ln.get_ydata()) == 2)
        assert np.allclose(levels, [-V_LIMIT, V_LIMIT])
        assert ax.get_ylim()[1] > V_LIMIT
    for ax in (ax3, ax5):
        levels = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines() if len(ln.get_ydata()) == 2)
        assert np.allclose(levels, [-351.5065188, 351.5065188])
    assert "unstable" in fig._suptitle.get_text()
    # the zoom panels show a window of the record around the velocity peak
    lo, hi = ax4.get_xlim()
    t_peak = float(study.sims["pip_sdp"].t[np.argmax(np.abs(study.sims["pip_sdp"].dq))])
    assert lo <= t_peak <= hi and hi - lo <= 0.08 + 1e-12


def test_cascade_without_tuning_and_stable_paper_lg(study):
    del study.sims["pip_sdp_tuned"]
    study.pip_sdp["paper_loop_gain"] = dict(stable=True, loop_gain=5.0)
    fig = fig_cascade(study)
    assert not any("gradient-tuned" in s for s in _legend_texts(fig.axes[0]))
    assert "unstable" not in fig._suptitle.get_text()


# --------------------------------------------------------------------------- #
# SRIVC
# --------------------------------------------------------------------------- #


def test_srivc_title_window_and_residual(study):
    fig = fig_srivc(study, window=1.0, zoom=0.05)
    ax1, ax2, ax3 = fig.axes
    title = fig._suptitle.get_text()
    assert "G(s) = (223.14) / (s + 223.14)" in title and "poles -223.14 rad/s" in title, title
    assert "fit 99.70 %" in title and "poles -250, -250 rad/s" in title, title
    lo, hi = ax1.get_xlim()
    assert np.isclose(hi - lo, 1.0)
    zlo, zhi = ax2.get_xlim()
    assert np.isclose(zhi - zlo, 0.05) and lo <= zlo and zhi <= hi
    d = study.sims["ident"]
    r = d["r"][(d["t"] >= zlo) & (d["t"] <= zhi)]
    assert np.ptp(r) > 0  # the zoom holds a reference step
    (resid,) = [s for s in _legend_texts(ax3) if s.startswith("y - model")]
    assert f"{1e3 * np.std(d['y'] - d['y_model']):.3g} mm" in resid
    with pytest.raises(ValueError, match="window"):
        fig_srivc(study, window=0.0)


# --------------------------------------------------------------------------- #
# All figures, saving
# --------------------------------------------------------------------------- #


def _png_size(path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == PNG_MAGIC and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def test_save_control_figures_png(study, tmp_path):
    figs = control_figures(study)
    assert tuple(figs) == CONTROL_FIGURE_NAMES
    dpi = 30
    paths = save_control_figures(study, tmp_path, dpi=dpi)
    assert paths == [tmp_path / f"{n}.png" for n in CONTROL_FIGURE_NAMES]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    for name, path in zip(CONTROL_FIGURE_NAMES, paths):
        w_in, h_in = figs[name].get_size_inches()
        w, h = _png_size(path)
        assert abs(w - w_in * dpi) <= 1 and abs(h - h_in * dpi) <= 1, (name, w, h)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(fmt="jpg"), "fmt"),
        (dict(fmt="PNG"), "fmt"),
        (dict(dpi=0), "dpi"),
        (dict(dpi=float("nan")), "dpi"),
        (dict(dpi="150"), "dpi"),
        (dict(dpi=True), "dpi"),
    ],
)
def test_save_bad_arguments(study, tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        save_control_figures(study, tmp_path, **kwargs)
    assert not any(tmp_path.iterdir())


def test_save_bad_destination(study, tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        save_control_figures(study, tmp_path / "missing")
    with pytest.raises(TypeError):
        save_control_figures(study, tmp_path, "pdf")  # fmt is keyword-only
