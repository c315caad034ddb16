"""`--keep-freed-memory`: re-run a benchmark with glibc told to keep freed memory (no page faults per call).

XLA allocates every buffer afresh on each call; glibc serves large blocks
with mmap and returns them on free, so each call page-faults its buffers in
again (about 0.1 s per 200 MB on these machines). `MALLOC_MMAP_MAX_=0` and
`MALLOC_TRIM_THRESHOLD_` (read by glibc at process start) keep freed memory
in the heap for reuse instead. Buffers that XLA's worker threads allocate
come from those threads' own arenas, separate heaps of at most 64 MB, so a
larger block is still mapped and unmapped on every call: `MALLOC_ARENA_MAX=1`
(`ONE_ARENA`) puts them in the main heap too (the robot regressor's 125 MB
result: 50,000 page faults per call without it, none with it).

`--huge-pages` (`HUGE_PAGES`): glibc >= 2.35 asks the kernel for transparent
huge pages (2 MB) for the blocks it maps, so a call faults its buffers in
2 MB at a time (the regressor: under a thousand faults per call instead of 50,000) and
freed memory still goes back to the system; the kernel's transparent huge
pages must be `always` or `madvise` (`/sys/kernel/mm/transparent_hugepage/enabled`).
"""

import os
import sys

MALLOC_KEEP = {"MALLOC_MMAP_MAX_": "0", "MALLOC_TRIM_THRESHOLD_": "100000000000"}
ONE_ARENA = {**MALLOC_KEEP, "MALLOC_ARENA_MAX": "1"}
HUGE_PAGES = {"GLIBC_TUNABLES": "glibc.malloc.hugetlb=1"}


def rerun_with(argv, settings: dict = MALLOC_KEEP, flag: str = "--keep-freed-memory") -> bool:
    """With `flag` in `argv`, re-execute this script with `settings` in the environment (once: the re-run finds
    them set); returns whether they are in effect."""
    active = all(os.environ.get(k) == v for k, v in settings.items())
    if flag in argv and not active:
        os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, **settings})
    return active
