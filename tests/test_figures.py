"""EMPS study figures (issue item 9): formats, resolution, legends, limits, labels.

The figures of a small study (the built-in plant, decimation 20) are
inspected as `Figure` objects: legend texts, axis limits against the
plotted data, x labels. The real-data case with a state-dependent mass
(decimation 5) runs when the shared EMPS file is present.
"""

import inspect
import struct
import subprocess
import sys

import equinox as eqx
import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

from helpers import requires_emps  # noqa: E402
from jaxsdp import Preprocessing  # noqa: E402
from jaxsdp.plants import asym_friction  # noqa: E402
from jaxsdp.studies._figure_style import FIGURE_FORMATS  # noqa: E402
from jaxsdp.studies.emps import (  # noqa: E402
    FIGURE_NAMES,
    emps_figures,
    emps_study,
    fig_force_reconstruction,
    fig_friction_asym,
    fig_sdp_mass,
    save_emps_figures,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
UNITS = {"kg", "N", "N/(m/s)", "m/s", "m/s$^2$"}


@pytest.fixture(scope="module")
def study(emps_builtin):
    return emps_study(emps_builtin[0], preprocessing=Preprocessing(decimate=20), source="built-in")


@pytest.fixture(scope="module")
def figs(study):
    return emps_figures(study)


def _legend_texts(ax) -> list[str]:
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def _png_size(path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == PNG_MAGIC and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def _ydata(ax) -> np.ndarray:
    """All y values of the data lines of `ax` (markers or long lines; not axhline)."""
    out = [np.asarray(ln.get_ydata(), dtype=float) for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
    return np.concatenate(out)


# --------------------------------------------------------------------------- #
# Saving: formats, resolution, argument checks
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize(
    "fmt, magic",
    [("png", PNG_MAGIC), ("pdf", b"%PDF-"), ("svg", None)],
)
def test_save_formats(study, tmp_path, fmt, magic):
    paths = save_emps_figures(study, tmp_path, fmt=fmt, dpi=30)
    assert tuple(paths) == FIGURE_NAMES
    for name, path in paths.items():
        assert path == tmp_path / f"{name}.{fmt}" and path.is_file()
        data = path.read_bytes()
        assert len(data) > 1000
        if magic is None:  # SVG: XML with an <svg> root
            assert data.lstrip().startswith(b"<?xml") and b"<svg" in data[:2000]
        else:
            assert data.startswith(magic)
    assert set(FIGURE_FORMATS) == {"png", "pdf", "svg"}


def test_dpi_sets_png_pixel_size(study, figs, tmp_path):
    dpi = 45
    paths = save_emps_figures(study, tmp_path, dpi=dpi)
    for name, path in paths.items():
        w_in, h_in = figs[name].get_size_inches()
        w, h = _png_size(path)
        assert abs(w - w_in * dpi) <= 1 and abs(h - h_in * dpi) <= 1, (name, w, h)
    params = inspect.signature(save_emps_figures).parameters
    assert params["fmt"].default == "png" and params["dpi"].default == 150
    assert params["fmt"].kind is params["dpi"].kind is inspect.Parameter.KEYWORD_ONLY


@pytest.mark.parametrize("fmt", ["jpg", "PNG", ".png", "", None, "eps"])
def test_bad_format(study, tmp_path, fmt):
    with pytest.raises(ValueError, match="fmt"):
        save_emps_figures(study, tmp_path, fmt=fmt)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("dpi", [0, -100, float("nan"), float("inf"), "150", None, True])
def test_bad_dpi(study, tmp_path, dpi):
    with pytest.raises(ValueError, match="dpi"):
        save_emps_figures(study, tmp_path, dpi=dpi)
    assert not any(tmp_path.iterdir())


def test_bad_destination_and_keyword_only(study, tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        save_emps_figures(study, tmp_path / "missing")
    with pytest.raises(TypeError):
        save_emps_figures(study, tmp_path, "pdf")  # fmt is keyword-only
    with pytest.raises(ValueError, match="EMPSStudy"):
        save_emps_figures(study.sdp, tmp_path)


def test_matplotlib_imported_lazily():
    code = "import sys, jaxsdp.studies.emps; assert 'matplotlib' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


# --------------------------------------------------------------------------- #
# Content: labels, legends, limits
# --------------------------------------------------------------------------- #


def test_every_panel_has_an_x_label(figs):
    assert tuple(figs) == FIGURE_NAMES and all(isinstance(f, Figure) for f in figs.values())
    for name, fig in figs.items():
        for k, ax in enumerate(fig.axes):
            assert ax.get_xlabel().strip(), (name, k)
            # shared x axes keep their tick labels
            assert ax.xaxis.get_tick_params(which="major").get("labelbottom", True), (name, k)
            assert "(s)" in ax.get_xlabel() or "(m/s" in ax.get_xlabel() or "(N)" in ax.get_xlabel(), (name, k)


def test_fig3_mass_line_band_and_units(study, figs):
    ax = figs["fig3_sdp_mass"].axes[0]
    texts = _legend_texts(ax)
    assert any("s.e." in t for t in texts), texts
    assert all("kg" in t for t in texts if "=" in t), texts
    # the IDIM-LS mass is a horizontal line (not dots) at the IDIM-LS value
    (ls,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("IDIM-LS")]
    assert ls.get_linestyle() not in ("None", "none", "") and ls.get_marker() in ("None", "none", "", None)
    m_ls = float(np.asarray(study.idim.theta)[list(study.idim.names).index("M")])
    assert np.allclose(np.asarray(ls.get_ydata(), dtype=float), m_ls)
    assert "s.d." in ls.get_label()  # with its +-2 std band


def test_fig4_legend_band_zoom_units(figs):
    ax1, ax2 = figs["fig4_friction_linear"].axes
    texts = _legend_texts(ax1)
    joined = "\n".join(texts)
    assert any("s.e." in t for t in texts), texts  # the pink band
    assert any("zoom" in t for t in texts), texts  # the grey area
    assert "N/(m/s)" in joined and "$F_c$ = " in joined and joined.count(" N") >= 3, joined
    lo, hi = ax2.get_xlim()
    assert hi < 0


def test_fig5_residuals_not_clipped_and_units(figs):
    ax1, ax2 = figs["fig5_friction_asym"].axes
    joined = "\n".join(_legend_texts(ax1))
    assert any("s.e." in t for t in _legend_texts(ax1))
    assert joined.count("N/(m/s)") == 2 and "$F_c^+$ = " in joined and "$F_c^-$ = " in joined, joined
    assert all(" N" in t for t in _legend_texts(ax2) if "rms" in t)
    y = _ydata(ax2)
    lo, hi = ax2.get_ylim()
    assert lo <= y.min() and y.max() <= hi, (lo, hi, y.min(), y.max())
    assert abs(lo + hi) < 1e-9 * hi  # symmetric about 0


def test_force_figure_zoom_residuals_and_labels(study, figs):
    fig = figs["force_reconstruction"]
    ax1, ax2, ax3, ax4 = fig.axes
    t_end = (study.sdp.y.shape[0] - 1) * study.sdp.dt
    lo, hi = ax2.get_xlim()
    assert 0.3 <= hi - lo <= 1.5 and 0 <= lo and hi <= t_end + 1e-9
    # the zoom window holds a direction reversal
    t = np.arange(study.sdp.y.shape[0]) * study.sdp.dt
    dq = np.asarray(study.sdp.dq)[(t >= lo) & (t <= hi)]
    assert dq.min() < 0 < dq.max()
    assert any("window" in s for s in _legend_texts(ax1))
    assert {"measured", "SDP", "IDIM-LS linear", "IDIM-LS asymmetric"} <= set(_legend_texts(ax2))
    # the residual panel shows every residual (autoscaled, no fixed limits)
    y = _ydata(ax3)
    lo, hi = ax3.get_ylim()
    assert lo <= y.min() and y.max() <= hi
    assert all("%" in s for s in _legend_texts(ax3))
    assert all(" N" in s for s in _legend_texts(ax4))
    # custom window; bad windows are rejected
    f = fig_force_reconstruction(study.sdp, study.idim, zoom=(2.0, 2.5))
    assert f.axes[1].get_xlim() == pytest.approx((2.0, 2.5))
    with pytest.raises(ValueError, match="zoom"):
        fig_force_reconstruction(study.sdp, zoom=(3.0, 2.0))


def test_fig5_symlog_keeps_outliers_visible(study):
    # a few large differences (the Coulomb step) switch the residual axis to
    # symlog: linear within the bulk, every point inside the limits
    st = study.sdp
    par = np.asarray(st.result.par_sorted).copy()
    n = par.shape[1]
    par[1, n // 2] += 500.0
    par[1, n // 2 + 1] -= 300.0
    st2 = eqx.tree_at(lambda s: s.result.par_sorted, st, par)
    ax = fig_friction_asym(st2, study.idim_sdp, idim=study.idim).axes[1]
    assert ax.get_yscale() == "symlog"
    y = _ydata(ax)
    lo, hi = ax.get_ylim()
    assert lo <= y.min() and y.max() <= hi and hi >= 500
    assert any("linear scale" in s for s in _legend_texts(ax))
    # without outliers the axis stays linear
    th = study.idim_sdp.theta
    v = np.asarray(st.result.x_sorted[1])
    par[1] = np.asarray(asym_friction([th["Fv_pos"], th["Fc_pos"], th["Fv_neg"], th["Fc_neg"]], v)) + np.sin(50 * v)
    st3 = eqx.tree_at(lambda s: s.result.par_sorted, st, par)
    ax = fig_friction_asym(st3, study.idim_sdp).axes[1]
    assert ax.get_yscale() == "linear"
    assert ax.get_ylim()[1] == pytest.approx(1.08 * np.abs(_ydata(ax)).max())


def test_fig3_state_dependent_mass(study):
    # a mass curve that varies with the acceleration, wild near ddq = 0:
    # the uninformative region is shaded and named in the legend
    st = study.sdp
    x = np.asarray(st.result.x_sorted[0])
    par = np.asarray(st.result.par_sorted).copy()
    par[0] = 95.0 + 5.0 * np.sin(3 * x) + np.where(np.abs(x) < 0.05 * np.abs(x).max(), 80.0, 0.0)
    st2 = eqx.tree_at(lambda s: (s.result.par_sorted, s.mass_constant), st, (par, False))
    ax = fig_sdp_mass(st2, study.idim).axes[0]
    texts = _legend_texts(ax)
    assert any("uninformative" in s and "m/s$^2$" in s for s in texts), texts
    assert "acceleration-dependent" in ax.get_title()
    lo, hi = ax.get_ylim()
    assert lo <= 90.0 and hi >= 100.0  # the informative curve is inside


@requires_emps
def test_real_data_state_dependent_mass(tmp_path, emps_real_study_dec5):
    real = emps_real_study_dec5
    assert not real.sdp.mass_constant
    figs = emps_figures(real)
    for fig in figs.values():
        assert all(ax.get_xlabel() for ax in fig.axes)
    ax = figs["fig5_friction_asym"].axes[1]
    y = _ydata(ax)
    lo, hi = ax.get_ylim()
    assert lo <= y.min() and y.max() <= hi
    paths = save_emps_figures(real, tmp_path, dpi=20)
    assert all(p.read_bytes().startswith(PNG_MAGIC) for p in paths.values())


def test_pdf_figures_are_links_in_the_report(study, tmp_path):
    """Markdown viewers do not display a PDF as an image: report.md links PDF figures, embeds PNG and SVG ones."""
    from jaxsdp.studies.emps import report

    for fmt in ("pdf", "svg"):
        (tmp_path / fmt).mkdir()
        paths = save_emps_figures(study, tmp_path / fmt, fmt=fmt, dpi=30)
        md = report(study, figures=paths)
        assert paths
        for name in paths:
            if fmt == "pdf":
                assert f"({name}.pdf)" in md and f"![{name}" not in md and "(PDF)" in md, name
            else:
                assert f"]({name}.svg)" in md and "(PDF)" not in md, name


def test_fig3_title_follows_the_findings(study, figs):
    """Fig. 3's title agrees with the findings: 'not established' when the mass flag changes with the decimation."""
    title = figs["fig3_sdp_mass"].axes[0].get_title()
    flags = {v["mass_constant"] for v in study.mass_check.values() if "mass_constant" in v}
    if len(flags) > 1:
        assert "not established" in title and any("NOT established" in f for f in study.findings), title
    else:
        assert ("constant" in title) and "not established" not in title, title
    fig = fig_sdp_mass(study.sdp, study.idim, verdict="constancy not established (test)")
    assert "constancy not established (test)" in fig.axes[0].get_title()
