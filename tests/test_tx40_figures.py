"""TX40 study figures (paper Figs. 7-11, the residual autocorrelation) on the built-in example study.

The figures of `example_study()` (computed once per process) are inspected
as `Figure` objects: the number of panels, labelled axes with units, the
plotted data against the study's arrays (SDP curves, measured and
reconstructed torque, autocorrelations), titles; then what
`save_tx40_figures` writes.
"""

import pathlib

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

import jaxsdp.studies.tx40._figures as figures_module  # noqa: E402
from jaxsdp.studies.tx40 import (  # noqa: E402
    FIGURE_NAMES,
    example_study,
    fig_autocorrelation,
    fig_reconstruction,
    fig_shapes,
    save_tx40_figures,
    tx40_figures,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
AXES = {"fig7_shapes": 2, "fig8_sdp_reconstruction": 2, "fig9_idim_ls_reconstruction": 2, "fig_autocorrelation": 1}


@pytest.fixture(scope="module")
def study():
    return example_study()


@pytest.fixture(scope="module")
def figs(study):
    return tx40_figures(study)


def _line(ax, prefix: str):
    lines = [ln for ln in ax.get_lines() if ln.get_label().startswith(prefix)]
    assert len(lines) == 1, [ln.get_label() for ln in ax.get_lines()]
    return lines[0]


def _finite(a):
    a = np.asarray(a, dtype=float)
    return a[np.isfinite(a)]


def _legend_texts(ax) -> list[str]:
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def test_names_and_axes(figs):
    assert tuple(figs) == FIGURE_NAMES
    for name, fig in figs.items():
        assert isinstance(fig, Figure), name
        assert len(fig.axes) == AXES[name], name


def test_every_axis_is_labelled_with_units(figs):
    for name, fig in figs.items():
        for ax in fig.axes:
            x, y = ax.get_xlabel(), ax.get_ylabel()
            assert x and y, (name, x, y)
            assert "(" in x, (name, x)  # a unit or a scale in parentheses
            if name != "fig_autocorrelation" and y != "probability density":
                assert "(N m)" in y, (name, y)
    shapes = figs["fig7_shapes"].axes
    assert shapes[0].get_xlabel().endswith("(rad/s)") and shapes[1].get_xlabel().endswith("(rad)")
    assert figs["fig8_sdp_reconstruction"].axes[0].get_xlabel().startswith("time (s)")
    assert figs["fig_autocorrelation"].axes[0].get_xlabel() == "lag (samples of 2 ms)"


def test_shapes_plot_the_study_curves(study, figs):
    res, s, n = study.sdp.result, study.sdp, study.names()
    ax_f, ax_g = figs["fig7_shapes"].axes
    for ax, j, proj in ((ax_f, 1, s.friction), (ax_g, 0, s.gravity)):
        sdp = _line(ax, "SDP")
        np.testing.assert_array_equal(sdp.get_xdata(), np.asarray(res.x_sorted[j], dtype=float))
        # the convention: the SDP curve minus its projection's offset
        expected = np.asarray(res.d_sorted[j], dtype=float) - float(proj["offset"])
        np.testing.assert_allclose(sdp.get_ydata(), expected, rtol=0, atol=1e-12)
        assert ax.collections, "no standard-error band"
    ls = study.idim.result
    v, f = (np.asarray(a, dtype=float) for a in _line(ax_f, "IDIM-LS").get_data())
    ok = np.isfinite(v)
    np.testing.assert_allclose(f[ok], ls[n["Fv"]] * v[ok] + ls[n["Fc"]] * np.sign(v[ok]), atol=1e-9)
    assert np.isnan(v).sum() == 1  # the Coulomb step drawn as a jump
    q, gq = (np.asarray(a, dtype=float) for a in _line(ax_g, "IDIM-LS").get_data())
    np.testing.assert_allclose(gq, -9.81 * ls[n["MX"]] * np.cos(q) + 9.81 * ls[n["MY"]] * np.sin(q), atol=1e-9)
    legend = " ".join(_legend_texts(ax_f) + _legend_texts(ax_g))
    for unit in ("N m s/rad", "N m", "kg m", "s.e."):
        assert unit in legend
    title = figs["fig7_shapes"].get_suptitle()
    assert "offsets removed" in title and f"{s.offset_sum:.3g} N m" in title


@pytest.mark.parametrize("model", ["sdp", "idim_ls"])
def test_reconstruction_plots_the_fit(study, figs, model):
    fig = figs["fig8_sdp_reconstruction" if model == "sdp" else "fig9_idim_ls_reconstruction"]
    ax1, ax2 = fig.axes
    measured = _finite(_line(ax1, "measured").get_ydata())
    # the whole record, samples at rest included (the multi-SDP fits every sample, the paper's figures)
    np.testing.assert_array_equal(measured, np.asarray(study.sdp.y, dtype=float))
    np.testing.assert_allclose(measured, np.asarray(study.idim.regression.y, dtype=float))
    reg = study.idim.regression
    coulomb = np.asarray(reg.X)[:, list(reg.names).index("Fc2")] * np.asarray(study.idim.moving)  # off at rest
    X = np.asarray(reg.X).copy()
    X[:, list(reg.names).index("Fc2")] = coulomb
    fit = study.sdp.result.fit if model == "sdp" else X @ np.asarray(study.idim.result.theta)
    rec = [ln for ln in ax1.get_lines() if "reconstruction" in ln.get_label()]
    assert len(rec) == 1
    np.testing.assert_allclose(_finite(rec[0].get_ydata()), np.asarray(fit, dtype=float), atol=1e-9)
    t = _finite(rec[0].get_xdata())
    np.testing.assert_allclose(t, np.arange(measured.size) * study.inputs.dt)
    rel = study.sdp.relative_error if model == "sdp" else study.idim.relative_error_record
    assert f"relative error {rel:.2f} % (whole record)" in fig.get_suptitle()
    moving = np.asarray(study.sdp.moving)
    rel_moving = study.sdp.relative_error_moving if model == "sdp" else float(study.idim.result.relative_error)
    assert f"{rel_moving:.2f} % in motion" in fig.get_suptitle()
    np.testing.assert_array_equal(moving, np.asarray(study.idim.moving))
    # the histogram is a density of the normalised residual, all of it in range
    bars = ax2.patches
    assert sum(p.get_height() * p.get_width() for p in bars) == pytest.approx(1.0, rel=1e-6)
    assert any(ln.get_label() == "N(0, 1)" for ln in ax2.get_lines())
    assert ax2.get_xlim()[0] <= -4 and ax2.get_xlim()[1] >= 4


def test_autocorrelation_plots_both_residuals(study, figs):
    fig = figs["fig_autocorrelation"]
    (ax,) = fig.axes
    for prefix, w in (("IDIM-LS", study.idim.whiteness), ("multi-SDP", study.sdp.whiteness)):
        line = _line(ax, prefix)
        np.testing.assert_array_equal(line.get_ydata(), np.asarray(w.acf, dtype=float))
        assert f"p = {float(w.p_value):.2g}" in ax.get_title(loc="left")
    null = _line(ax, "null")
    np.testing.assert_array_equal(null.get_ydata(), np.asarray(study.sdp.whiteness.null, dtype=float))
    assert len(fig.legends) == 1 and ax.collections  # the legend below the panel, the band shaded


def test_bad_arguments(study):
    with pytest.raises(ValueError, match="model"):
        fig_reconstruction(study, model="ls")
    with pytest.raises(ValueError, match="bins"):
        fig_reconstruction(study, bins=0)
    with pytest.raises(ValueError, match="band"):
        fig_shapes(study, band=-1.0)
    for fn in (fig_shapes, fig_reconstruction, fig_autocorrelation, tx40_figures):
        with pytest.raises(ValueError, match="TX40Study"):
            fn(study.sdp)


def test_save_writes_every_figure(study, tmp_path):
    paths = save_tx40_figures(study, tmp_path, dpi=30)
    assert [p.name for p in paths] == [f"{n}.png" for n in FIGURE_NAMES]
    for p in paths:
        assert isinstance(p, pathlib.Path) and p.parent == tmp_path
        assert p.read_bytes()[:8] == PNG_MAGIC
    svg = save_tx40_figures(study, tmp_path, fmt="svg")
    assert [p.suffix for p in svg] == [".svg"] * len(FIGURE_NAMES) and all(p.stat().st_size > 0 for p in svg)


@pytest.mark.parametrize("kwargs", [dict(fmt="jpg"), dict(fmt="PNG"), dict(dpi=0), dict(dpi=True)])
def test_save_rejects_bad_options(study, tmp_path, kwargs):
    with pytest.raises(ValueError, match="fmt" if "fmt" in kwargs else "dpi"):
        save_tx40_figures(study, tmp_path, **kwargs)
    assert not list(tmp_path.iterdir())


def test_save_needs_an_existing_folder(study, tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        save_tx40_figures(study, tmp_path / "missing")
    with pytest.raises(TypeError):
        save_tx40_figures(study, tmp_path, "pdf")  # fmt is keyword-only


def test_no_pyplot():
    source = pathlib.Path(figures_module.__file__).read_text()
    assert "matplotlib.pyplot" not in source and "import pyplot" not in source
