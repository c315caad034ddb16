"""A study on the built-in data, computed once per process, for the examples in the docstrings."""

import functools

from ..._runtime import x64


@x64
@functools.lru_cache(maxsize=1)
def example_study():
    """`tx40_study` on the built-in "only link 2 moving" data (seed 0), cached.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study
        >>> example_study().joint
        2
    """
    import dataclasses

    from ...data._tx40_builtin import tx40_builtin_data
    from ._study import tx40_study

    logs, truth, _, _ = tx40_builtin_data()
    return tx40_study(dataclasses.replace(logs, source="built-in TX40 link-2 experiment"), truth=truth)
