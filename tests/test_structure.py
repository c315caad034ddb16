"""Order and delay identification (`structure_search`): picks the true structure, ranks consistently, bad input."""

import numpy as np
import pytest
import scipy.signal as sig

from helpers import check_quoted, prbs, zoh_simulate
from jaxsdp.tfest import rivcbj, structure_search

NUM, DEN, DT, DELAY = [4.0, 20.0], [1.0, 3.0, 20.0], 0.02, 3
ORDERS = [(1, 0), (1, 1), (2, 0), (2, 1), (3, 1), (3, 2)]  # x 4 delays = 24 candidates


def _data(seed, n=2000):
    rng = np.random.default_rng(100 + seed)
    u = prbs(n, 5, seed=1000 + seed)
    x = zoh_simulate(NUM, DEN, u, DT, delay=DELAY)
    return x + sig.lfilter([1.0, 0.3], [1.0, -0.9], 0.1 * np.std(x) * rng.standard_normal(n)), u


def _pick(table, criterion):
    """(n, m, delay) of the best usable row of a search's table by `criterion` (the rule of `structure_search`)."""
    usable = [r for r in table if r["converged"] and r["stable"] and np.isfinite(r[criterion])]
    best = (max if criterion == "rt2" else min)(usable, key=lambda r: r[criterion])
    return best["n"], best["m"], best["delay"]


def test_structure_search_finds_the_true_orders_and_delay():
    """10 noise and input realisations, 24 candidates each, BIC: the true (2, 1, 3) at least 9 times.

    The transfer-function guide quotes how often each criterion picks it here (R_T^2 does not penalise parameters).
    """
    runs, hits = 10, {c: 0 for c in ("bic", "yic", "aic", "rt2")}
    for seed in range(runs):
        y, u = _data(seed)
        s = structure_search(y, u, DT, orders=ORDERS, delays=range(4), nc=1, nd=1)
        assert _pick(s.table, "bic") == (s.chosen["n"], s.chosen["m"], s.chosen["delay"])
        for c in hits:
            hits[c] += _pick(s.table, c) == (2, 1, DELAY)
        if seed == 0:
            first = s
    assert hits["bic"] >= 9, hits
    check_quoted(
        "docs/guides/tfest.md",
        "on {} Monte Carlo data sets (a second-order system with a 3-sample delay, coloured noise, {} candidates) "
        "it chose the true structure {} times, YIC {}, AIC {}, $R_T^2$ {}",
        (runs, len(first.table), hits["bic"], hits["yic"], hits["aic"], hits["rt2"]),
        "d",
    )
    s = first
    assert len(s.table) == 24 and s.criterion == "bic"
    usable = [r for r in s.table if r["converged"] and r["stable"]]
    assert [r["bic"] for r in usable] == sorted(r["bic"] for r in usable)
    assert s.table[: len(usable)] == usable  # usable candidates first
    # the chosen result is the direct fit of that structure
    y, u = _data(0)
    direct = rivcbj(y, u, DT, n=2, m=1, nc=1, nd=1, delay=DELAY)
    np.testing.assert_allclose(s.result.theta, direct.theta, rtol=1e-9)
    assert np.isclose(s.chosen["bic"], float(direct.bic)) and int(s.result.delay[0]) == DELAY
    assert "rank" in s.text() and len(s.text(rows=5).splitlines()) == 6


def test_discrete_search_and_other_criteria():
    rng = np.random.default_rng(7)
    u = rng.standard_normal(2000)
    y = sig.lfilter([0.0, 0.0, 0.5], [1.0, -0.8], u) + 0.05 * rng.standard_normal(2000)
    for crit in ("bic", "aic", "yic"):
        s = structure_search(y, u, None, orders=[(1, 0), (2, 1)], delays=[1, 2, 3], kind="discrete", criterion=crit)
        assert (s.chosen["n"], s.chosen["m"], s.chosen["delay"]) == (1, 0, 2), crit
    s = structure_search(y, u, None, orders=[(1, 0), (2, 1)], delays=[1, 2, 3], kind="discrete", criterion="rt2")
    rt2 = [r["rt2"] for r in s.table if r["converged"] and r["stable"]]
    assert rt2 == sorted(rt2, reverse=True)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(orders=[(2, 3)]), "valid"),
        (dict(orders=[(11, 0)]), "valid"),
        (dict(orders=[(2.5, 1)]), "whole numbers"),
        (dict(orders=[(2, 1)], delays=[1.5]), "delays"),
        (dict(orders=[]), "non-empty"),
        (dict(orders=[(2, 1)], delays=[-1]), "delays"),
        (dict(orders=[(2, 1)], criterion="fpe"), "criterion"),
        (dict(orders=[(2, 1)], kind="hybrid"), "kind"),
        (dict(orders=[(2, 1)], delays=[5000]), "beyond the record"),
    ],
)
def test_bad_input(kwargs, match):
    y, u = _data(0, n=600)
    with pytest.raises(ValueError, match=match):
        structure_search(y, u, DT, **kwargs)
