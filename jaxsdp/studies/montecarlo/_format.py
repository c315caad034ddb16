"""Percentages of the Monte Carlo reports that never round a failure away."""

import math

#: Most decimals `fraction_pct` adds to keep a fraction off 0 % and 100 %.
MAX_DECIMALS = 6


def fraction_pct(v, *, digits: int = 0) -> str:
    """A fraction (0-1) as a percentage with `digits` decimals, never rounded onto 0 % or 100 % unless exact.

    100 v is printed with `digits` decimals; when 0 < v < 1 and that would
    print 0 or 100, decimals are added (up to `digits + MAX_DECIMALS`) until
    it does not: 995 successes in 1,000 runs print "99.5 %", 9,999 in 10,000
    "99.99 %", 1 failure in 10,000 "0.01 %", where the plain format prints
    "100 %" and "0 %". Only v == 1 prints "100 %" and only v == 0 "0 %".
    None prints "n/a"; NaN "nan %".

    Example:

    >>> from jaxsdp.studies.montecarlo._format import fraction_pct
    >>> fraction_pct(0.995), fraction_pct(1.0), fraction_pct(1 / 10_000, digits=1), fraction_pct(0.5)
    ('99.5 %', '100 %', '0.01 %', '50 %')
    """
    if v is None:
        return "n/a"
    v = float(v)
    if not math.isfinite(v):
        return "nan %"
    if isinstance(digits, bool) or not isinstance(digits, int) or digits < 0:
        raise ValueError(f"`digits` must be an integer >= 0; got {digits!r}")
    pct = 100.0 * v
    d = digits
    if 0.0 < v < 1.0:
        while d < digits + MAX_DECIMALS and float(f"{pct:.{d}f}") in (0.0, 100.0):
            d += 1
    return f"{pct:.{d}f} %"
