"""The control study's outputs: summary.json's dict, report.md, and the console tables."""

import numpy as np

from ..._runtime import x64
from ...control._closed_loop import REAL_DRIVE
from .._contract import Study
from .._output import figure_markdown, finite_or_none, md_table
from ._shared import PAPER_MODEL

PAPER = dict(sdp_pd_settling_s=0.04, linear_pd_settling_factor=3.0, loop_gain=5.0)
#: The EMPS drive's force limit (N): a design whose simulated peak force exceeds it is infeasible on the machine.
DRIVE_LIMIT = float(REAL_DRIVE.force_limit)
DRIVE_COLUMN = f"EMPS drive (|F| <= {DRIVE_LIMIT:g} N)"


def _fmt(x, digits=3):
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return str(x)
    if not np.isfinite(x):
        return "not settled" if x > 0 else "-"
    return f"{x:.{digits}g}"


def _poly(coeffs, var):
    n = len(coeffs) - 1
    terms = []
    for i, c in enumerate(coeffs):
        p = n - i if var == "s" else i
        if c == 0 and len(coeffs) > 1:
            continue
        power = "" if p == 0 else (f" {var}" if p == 1 else f" {var}^{p}")
        if var == "z^-1":
            power = "" if p == 0 else f" z^-{p}"
        terms.append(f"{c:+.4g}{power}")
    return " ".join(terms).lstrip("+")


@x64
def control_summary(study: Study) -> dict:
    """summary.json's content: the sections the issue names, JSON-safe (inf and NaN as null).

    Sections: `sdp_pd`, `linear_pd` (paper's setting), `sdp_pd_real_drive`
    (delay, saturation, the largest wn with < 2 % overshoot under the delay),
    `srivc` (the loop's identification, by its `estimator`: "srivc", or "rivcbj"
    with its noise model c, d and `compare_srivc`), `pip`, `pip_paper_model`,
    `pip_sdp`, `gradients`, `friction`, `settings`, `warnings`, `timings`,
    `fast_loops`, `versions`.

    Example:
        >>> from jaxsdp.studies.control import control_summary
        >>> callable(control_summary)
        True
    """
    s = study.settings
    fric = {k: v for k, v in study.friction.items() if k != "curve"}
    out = dict(
        source=study.source,
        settings={k: v for k, v in vars(s).items() if k not in ("wn_grid", "lg_grid")},
        friction=fric,
        sdp_pd=study.sdp_pd,
        linear_pd=study.linear_pd,
        sdp_pd_real_drive=study.real_drive,
        srivc=study.srivc,
        pip=study.pip,
        pip_paper_model=dict(study.pip_paper_model, num=PAPER_MODEL["num"], den=PAPER_MODEL["den"]),
        pip_sdp=study.pip_sdp,
        gradients=study.gradients,
        warnings=list(study.warnings),
        timings={k: round(v, 3) for k, v in study.timings.items()},
        fast_loops=study.fast_loops,
        versions=dict(study.versions),
    )
    return finite_or_none(out)


def _step_rows(study):
    rd = study.real_drive
    rows = [
        ("SDP-PD, wn %g (paper's setting)" % study.sdp_pd["wn"], study.sdp_pd),
        ("linear PD (benchmark, paper's setting)", study.linear_pd),
        ("SDP-PD, wn %g, drive delay" % rd["delay"]["wn"], rd["delay"]),
        ("SDP-PD, wn %g, drive delay" % rd["delay_largest_wn"]["wn"], rd["delay_largest_wn"]),
        ("SDP-PD, wn %g, saturation only" % rd["saturation"]["wn"], rd["saturation"]),
        ("SDP-PD, wn %g, delay + saturation" % rd["delay_and_saturation"]["wn"], rd["delay_and_saturation"]),
    ]
    for form, m in study.sdp_pd["other_forms"].items():
        rows.append((f"SDP-PD, wn {study.sdp_pd['wn']:g}, {form} friction", m))
    return [
        (
            name,
            _fmt(m["settling_time_s"]),
            _fmt(m["overshoot_pct"]),
            _fmt(m["max_velocity"]),
            _fmt(m["max_force"], 4),
            _drive(m),
        )
        for name, m in rows
    ]


def _drive(m) -> str:
    """The drive verdict of a simulated design (`force_verdict`): "feasible", "at the limit" (peak force within
    5 % of the EMPS drive's limit), "INFEASIBLE" (above it), "-" (unstable)."""
    verdict = m.get("drive_verdict")
    return "-" if verdict is None else ("INFEASIBLE" if verdict == "infeasible" else verdict)


def _cascade_rows(study):
    p = study.pip_sdp
    rows = [
        (f"hand-tuned LG = {p['loop_gain']:.3g} (largest with peak |dq| <= {p['v_limit']:g} m/s)", p),
        (f"paper's LG = {p['paper_loop_gain']['loop_gain']:g}", p["paper_loop_gain"]),
        (f"LG = {p['loop_gain']:.3g}, real drive, wn {p['real_drive']['wn']:g}", p["real_drive"]),
    ]
    t = study.gradients.get("tuned")
    if t:
        rows.append((f"gradient-tuned, real drive (wn {t['wn']:.3g}, eta {t['eta']:.2g}, LG {t['loop_gain']:.3g})", t))
    return [
        (
            name,
            "yes" if m["stable"] else "UNSTABLE",
            _fmt(m["settling_time_s"]),
            _fmt(m["overshoot_pct"]),
            _fmt(m["max_velocity"]),
            _fmt(m["max_force"], 4),
            _drive(m),
        )
        for name, m in rows
    ]


def estimator_name(ident: dict) -> str:
    """The estimator of the study's identification (`ControlStudy.srivc`) as printed: "SRIVC" or "RIVCBJ"."""
    return str(ident.get("estimator", "srivc")).upper()


def _coeffs(values, errors):
    return " ".join(f"{v:.4g} (+-{e:.2g})" for v, e in zip(values, errors))


def _noise_words(sr) -> str:
    colour = sr.get("noise_colour")
    words = f"{sr['noise_pct']:g} % noise"
    if colour is None:
        return words
    c, d = (_poly(p, "z^-1") if len(p) == 1 else f"({_poly(p, 'z^-1')})" for p in (colour["c"], colour["d"]))
    return words + f" coloured by {c} / {d}"


def noise_gains(c, d) -> tuple[float, float]:
    """|C/D| of a noise model C(z^-1)/D(z^-1) at 0 Hz (z = 1) and at the Nyquist frequency (z = -1); 1, 1: white."""
    c1, d1 = float(np.sum(c)), float(np.sum(d))
    c2, d2 = (float(np.polyval(np.asarray(p, dtype=float)[::-1], -1.0)) for p in (c, d))
    return abs(c1 / d1), abs(c2 / d2)


def _parameters(sr):
    """(name, value, standard error) of B(s) = b0 s^m + ... + bm and A(s) = s^n + a1 s^(n-1) + ... + an."""
    rows = [(f"b{i}", v, e) for i, (v, e) in enumerate(zip(sr["num"], sr["num_se"]))]
    return rows + [(f"a{i}", v, e) for i, (v, e) in enumerate(zip(sr["den"], sr["den_se"])) if i > 0]


def _comparison(sr):
    """RIVCBJ against SRIVC on the same data: the standard errors' ratio range and the largest difference (in
    combined standard errors); None without a comparison."""
    ref = sr.get("compare_srivc")
    if ref is None:
        return None
    ours, theirs = _parameters(sr), _parameters(ref)
    ratios = [e / f for (_, _, e), (_, _, f) in zip(ours, theirs) if f > 0]
    z = [abs(v - w) / np.hypot(e, f) for (_, v, e), (_, w, f) in zip(ours, theirs) if np.hypot(e, f) > 0]
    return ref, ours, theirs, min(ratios), max(ratios), max(z)


def ratio_range(lo: float, hi: float) -> str:
    """A range of ratios as text: "0.42 to 0.45", or "1.1" when both ends round alike (2 digits)."""
    return f"{lo:.2g}" if f"{lo:.2g}" == f"{hi:.2g}" else f"{lo:.2g} to {hi:.2g}"


def _tf_lines(study):
    sr = study.srivc
    name = estimator_name(sr)
    lines = [
        f"- continuous time ({name}, n = {sr['n']}, m = {sr['m']}, {sr['iterations']} iterations, "
        f"converged: {_fmt(sr['converged'])}, fit {sr['fit_pct']:.2f} % with {_noise_words(sr)}): "
        f"num [{_coeffs(sr['num'], sr['num_se'])}], den [{_coeffs(sr['den'], sr['den_se'])}]",
    ]
    if "c" in sr:
        dc, nyquist = noise_gains(sr["c"], sr["d"])
        lines.append(
            f"- noise model C/D (nc = {sr['nc']}, nd = {sr['nd']}, in z^-1 at {study.settings.dt:g} s): "
            f"C [{_coeffs(sr['c'], sr['c_se'])}], D [{_coeffs(sr['d'], sr['d_se'])}]; |C/D| {dc:.3g} at 0 Hz, "
            f"{nyquist:.3g} at the Nyquist frequency (1 and 1: white); R_T^2 {sr['rt2']:.4f}, YIC {sr['yic']:.3g}"
        )
    cmp = _comparison(sr)
    if cmp is not None:
        ref, _, _, lo, hi, _ = cmp
        lines.append(
            f"- SRIVC on the same data: num [{_coeffs(ref['num'], ref['num_se'])}], "
            f"den [{_coeffs(ref['den'], ref['den_se'])}]; {name}'s standard errors are {ratio_range(lo, hi)} "
            "times SRIVC's"
        )
    return lines + [
        f"- discrete time, dt = {sr['discrete_dt']:g} s: "
        f"({_poly(sr['discrete_num'], 'z^-1')}) / ({_poly(sr['discrete_den'], 'z^-1')})",
        f"- the paper's (30): ({_poly(PAPER_MODEL['num'], 'z^-1')}) / ({_poly(PAPER_MODEL['den'], 'z^-1')})",
    ]


def _comparison_section(study) -> list[str]:
    """report.md's table of RIVCBJ against SRIVC on the same data, and what it shows; [] without a comparison."""
    sr = study.srivc
    cmp = _comparison(sr)
    if cmp is None:
        return []
    _, ours, theirs, lo, hi, z = cmp
    name = estimator_name(sr)
    rows = [
        (k, f"{w:.5g}", f"{f:.3g}", f"{v:.5g}", f"{e:.3g}", f"{e / f:.3g}" if f > 0 else "-")
        for (k, v, e), (_, w, f) in zip(ours, theirs)
    ]
    words = f"{name}'s standard errors are {ratio_range(lo, hi)} times SRIVC's on the same data ({_noise_words(sr)})."
    if sr.get("noise_colour") is None:
        words += (
            f" The measurement noise is white: {name}'s noise model should be near 1 and its estimate near SRIVC's, "
            "without smaller standard errors."
        )
    gains = noise_gains(sr["c"], sr["d"])
    if max(abs(np.log(g)) for g in gains) > np.log(1.25):
        words += (
            f" SRIVC's standard errors assume white noise, which {name}'s noise model contradicts (|C/D| "
            f"{gains[0]:.3g} at 0 Hz, {gains[1]:.3g} at the Nyquist frequency): they do not measure SRIVC's actual "
            "spread here."
        )
    if z > 3:
        words += (
            f" The two estimates differ by up to {z:.1f} combined standard errors, more than the noise explains: "
            f"the structure (n = {sr['n']}, m = {sr['m']}) does not capture the loop exactly, and the estimators "
            f"weight that mismatch differently ({name} through the inverse of its noise model, D/C); the standard "
            "errors assume the structure is right."
        )
    else:
        words += f" The two estimates agree within {z:.2g} combined standard errors."
    header = ["parameter", "SRIVC", "SRIVC s.e.", name, f"{name} s.e.", f"s.e. ratio {name}/SRIVC"]
    return [
        "",
        f"{name} against SRIVC on the same data (B(s) = b0 s^m + ... + bm, A(s) = s^n + a1 s^(n-1) + ... + an):",
        "",
        md_table(header, rows),
        "",
        words,
    ]


def _differences(study):
    sr = study.srivc
    poles = np.roots(sr["discrete_den"])
    ours = ", ".join(f"{abs(p):.3g}" for p in poles)
    paper = ", ".join(f"{abs(p):.3g}" for p in np.roots(PAPER_MODEL["den"]))
    gain = sum(sr["discrete_num"]) / sum(sr["discrete_den"])
    pgain = sum(PAPER_MODEL["num"]) / sum(PAPER_MODEL["den"])
    return (
        f"Our model's discrete poles have moduli {ours} (the SDP-PD loop with wn = {study.sdp_pd['wn']:g} rad/s "
        f"is settled within one 0.01 s outer sample), steady-state gain {gain:.3f}; the paper's (30) has poles of "
        f"modulus {paper} (time constant about 0.15 s) and gain {pgain:.3f}. A loop designed for wn = 250 rad/s "
        "cannot produce (30): (30) describes a much slower inner loop (a bandwidth near 7 rad/s, e.g. a lower wn, "
        "or the drive's saturation limiting a 0.05 m step to about 3.7 m/s^2), and its z^-3 term an extra sample "
        "of delay. Hence the paper's LG = 5 (tuned on its slow model) is far too high for ours; the loop gain is "
        "re-tuned the paper's way, as the largest one that keeps the step's velocity under the limit."
    )


def _tuning_lines(t: dict, hand: dict) -> list[str]:
    """report.md's account of the gradient tuning (`gradients.tuned`): method, bounds, test, runs, outcome."""
    names = dict(wn="wn", eta="eta", loop_gain="LG", ew="ew", xw="xw")
    bounds = ", ".join(f"{names[k]} {lo:.3g}..{hi:.3g}" for k, (lo, hi) in t["bounds"].items())
    rows = [
        (
            f"{r['start_wn']:.3g}",
            str(r["steps"]),
            str(r["restarts"]),
            "yes" if r["converged"] else f"no ({r['reason']})",
            f"{r['cost'] / t['hand_tuned_cost']:.4g}",
        )
        for r in t["runs"]
    ]
    active = ", ".join(f"{names[k]} at its {side} bound" for k, side in t["at_bounds"].items())
    rd = hand["real_drive"]
    return [
        "Gradient tuning on the real drive (delay, saturation): BFGS (optimistix) on (wn, eta, LG, ew, xw), each "
        f"parameter's logarithm mapped onto its bounds by a logistic function ({bounds}; wn rad/s) and the cost "
        f"divided by the hand-tuned design's, at most {t['max_steps']} steps per run. Convergence test: "
        f"{t['convergence_test']}; a run that stops where such a change still pays restarts from it. Runs (cost "
        "relative to the hand-tuned design's):",
        "",
        md_table(["start wn (rad/s)", "BFGS steps", "restarts", "converged", "cost"], rows),
        "",
        f"Best run, from wn {t['start_wn']:.3g} rad/s: converged: {_fmt(t['converged'])}, {t['steps']} steps, "
        f"{t['restarts']} restarts; largest |d cost / d log p| over the parameters off their bounds "
        f"{t['gradient_norm']:.2g} (the cost is only piecewise smooth: stick-slip of the Coulomb friction)"
        + (f"; {active}" if active else "")
        + f". Tuned: wn {t['wn']:.3g} rad/s, eta {t['eta']:.3g}, LG {t['loop_gain']:.3g}, ew {t['ew']:.3g}, "
        f"xw {t['xw']:.3g}: settling {_fmt(t['settling_time_s'])} s, overshoot {_fmt(t['overshoot_pct'])} %, peak "
        f"|dq| {_fmt(t['max_velocity'])} m/s, peak |F| {_fmt(t['max_force'], 4)} N ({_drive(t)}"
        + (f", commands up to {t['max_command']:.4g} N clipped by the drive" if t.get("saturated") else "")
        + f"), against {_fmt(rd['settling_time_s'])} s, {_fmt(rd['max_velocity'])} m/s and "
        f"{_fmt(rd['max_force'], 4)} N for the hand-tuned loop gain with the same drive.",
    ]


@x64
def report_markdown(study: Study, figures=()) -> str:
    """report.md of the control study: warnings, Fig. 14 table, real drive, SRIVC (or RIVCBJ, with SRIVC on the
    same data beside it) vs (30), PIP, cascade, gradients; `figures` (file names relative to the report) are
    embedded when given.

    Example:
        >>> from jaxsdp.studies.control import report_markdown
        >>> callable(report_markdown)
        True
    """
    s, pd, lin, rd = study.settings, study.sdp_pd, study.linear_pd, study.real_drive
    lines = [
        "# SDP control of the EMPS (paper section 4)",
        "",
        f"Source of the friction SDP: {study.source}. True plant: the asymmetric IDIM-LS model of the real EMPS. "
        f"Controllers at {1 / s.dt:g} Hz, step 0 -> {s.step} m.",
        "",
    ]
    if study.warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in study.warnings] + [""]
    c = study.friction["c"]
    lines += [
        "## SDP control model (eqs. 26-27)",
        "",
        f"c1 = {c[0]:.4f} 1/s, c2 = {c[1]:.4f} m/s^2, c3 = {c[2]:.4f} m/s^2, c4 = {c[3]:.5f} 1/kg "
        "(paper, Table 1: -2.1277, -0.2123, 0.0336, 0.0105). The controller compensates the hybrid "
        f"friction of Fig. 13 (SDP curve on {study.friction['velocity_range'][0]:.3g} .. "
        f"{study.friction['velocity_range'][1]:.3g} m/s, fitted lines beyond).",
        "",
        "## Step responses (Fig. 14 and the real drive)",
        "",
        md_table(
            ["controller / drive", "settling 2 % (s)", "overshoot (%)", "peak |dq| (m/s)", "peak |F| (N)"]
            + [DRIVE_COLUMN],
            _step_rows(study),
        ),
        "",
        f"In the paper's setting SDP-PD settles in {_fmt(pd['settling_time_s'])} s (paper: about 0.04 s), the "
        f"linear PD in {_fmt(lin['settling_time_s'])} s with {_fmt(lin['overshoot_pct'])} % overshoot "
        f"({lin['settling_time_s'] / pd['settling_time_s']:.1f} times slower; paper: about three times). "
        f"The force this needs ({_fmt(pd['max_force'], 3)} N) is far above the drive's "
        f"{_fmt(rd['saturation']['force_limit'], 4)} N. With the drive's one-sample delay, wn = {rd['delay']['wn']:g} "
        f"rings ({_fmt(rd['delay']['overshoot_pct'])} % overshoot); the largest wn of the grid keeping the "
        f"overshoot under {rd['max_overshoot_pct']:g} % is {_fmt(rd['largest_wn_delay'])} rad/s.",
        "",
        f"## {estimator_name(study.srivc)} model of the SDP-PD loop and the paper's (30)",
        "",
        *_tf_lines(study),
        *_comparison_section(study),
        "",
        _differences(study),
        "",
        "## PIP-LQ designs (ew %g, uw %g, xw %g)" % (s.ew, s.uw, s.xw),
        "",
    ]
    for label, p in (("our model", study.pip), ("the paper's (30)", study.pip_paper_model)):
        gains = ", ".join(f"{k} {v:.4g}" for k, v in p["gains"].items())
        poles = ", ".join(f"{re:.3g}{im:+.3g}j" for re, im in p["closed_loop_poles"])
        lines.append(f"- {label}: gains {gains}; closed-loop poles {poles}")
        for key, m in p.get("step", {}).items():
            if key.startswith("loop_gain_"):
                lg = key.removeprefix("loop_gain_")
                lines.append(
                    f"  - unit step on that model, LG = {lg}: "
                    + (
                        f"settling {_fmt(m['settling_time_s'])} s, overshoot {_fmt(m['overshoot_pct'])} %"
                        if m["stable"]
                        else "UNSTABLE"
                    )
                )
    g = study.gradients
    lines += [
        "",
        f"## PIP-SDP cascade (PIP at {1 / (s.ratio * s.dt):g} Hz over SDP-PD at {1 / s.dt:g} Hz, "
        f"velocity limit {s.v_limit} m/s)",
        "",
        md_table(
            ["design", "stable", "settling 2 % (s)", "overshoot (%)", "peak |dq| (m/s)", "peak |F| (N)", DRIVE_COLUMN],
            _cascade_rows(study),
        ),
        "",
        "The velocity limit is met the paper's way: the serial loop gain LG is the largest of a grid whose step "
        "response keeps |dq| under the limit.",
        "",
        "## Gradients through design and simulation",
        "",
        f"Cost: integrated absolute error of the {s.step} m step plus a penalty on |dq| above {s.v_limit} m/s. "
        f"Largest relative difference between jax.grad and central differences over (wn, eta, ew, uw, xw, LG): "
        f"{g['max_rel_diff']:.1e}.",
    ]
    t = g.get("tuned")
    if t:
        hand = study.pip_sdp
        lines += ["", *_tuning_lines(t, hand)]
    if figures:
        lines += ["", "## Figures", ""] + [figure_markdown(f) for f in figures]
    lines += [
        "",
        "## Timings (s)",
        "",
        md_table(["stage", "seconds"], [(k, f"{v:.2f}") for k, v in study.timings.items()]),
    ]
    return "\n".join(lines) + "\n"


@x64
def text_output(study: Study) -> str:
    """The console tables: step responses, SRIVC (or RIVCBJ) model, cascade (the warnings are printed once, on
    stderr, by the command; they head `report.md`).

    Example:
        >>> from jaxsdp.studies.control import text_output
        >>> callable(text_output)
        True
    """
    limit = f"peak |F| <= {DRIVE_LIMIT:g} N"
    lines = [f"Step responses (settling s, overshoot %, peak |dq| m/s, peak |F| N, drive: {limit}):"]
    lines += [f"  {r[0]:<44} {r[1]:>12} {r[2]:>8} {r[3]:>8} {r[4]:>10} {r[5]:>12}" for r in _step_rows(study)]
    name = estimator_name(study.srivc)
    lines += ["", f"{name} model of the SDP-PD loop:"] + ["  " + x[2:] for x in _tf_lines(study)]
    lines += ["", f"PIP-SDP cascade (stable, settling s, overshoot %, peak |dq| m/s, peak |F| N, drive: {limit}):"]
    lines += [
        f"  {r[0]:<62} {r[1]:>8} {r[2]:>8} {r[3]:>8} {r[4]:>8} {r[5]:>10} {r[6]:>12}" for r in _cascade_rows(study)
    ]
    return "\n".join(lines) + "\n"
