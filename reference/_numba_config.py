"""The numba setting every compiled loop of the harness is built with: its LLVM optimisation level.

numba optimises at ``NUMBA_OPT`` = 3 unless told otherwise. The harness builds its kernels, its
floors and its checks at :data:`KERNEL_OPT` = 2 instead, unless the environment sets ``NUMBA_OPT``
itself (then that level, recorded alike). Level 2 was chosen by measuring the standard suite's
timing loops at both levels (docs/performance.md): they compile in a little over half the CPU
time of level 3 and run as fast, within the machine's run-to-run spread.

Neither level lets LLVM reorder or contract floating-point operations (numba asks for no
fast-math), so a loop computes the same bits at either: the accuracy figures do not depend on
it, and the tests hold the compiled runs to the interpreted ones bit for bit. The level is part
of every kernel file's key (``reference._kernels``), because numba's own cache does not record
it, and each run records it (``harness.execution.environment``).
"""

from __future__ import annotations

import os
from functools import cache

KERNEL_OPT = 2


#: The values numba takes for ``$NUMBA_OPT``; on any other it warns and keeps its default, 3.
NUMBA_LEVELS = ("0", "1", "2", "3", "max")


def opt_level() -> str:
    """The level the harness's loops compile at in this process, as numba reads it: ``$NUMBA_OPT``
    where set (numba's default "3" where numba cannot read it), else :data:`KERNEL_OPT`."""
    if "NUMBA_OPT" not in os.environ:
        return str(KERNEL_OPT)
    return os.environ["NUMBA_OPT"] if os.environ["NUMBA_OPT"] in NUMBA_LEVELS else "3"


@cache
def configure() -> None:
    """Set numba's optimisation level to :data:`KERNEL_OPT` where ``$NUMBA_OPT`` does not set it;
    called before the harness's first compilation in a process (numba reads the level as each
    function compiles), once."""
    if "NUMBA_OPT" in os.environ:
        return
    from numba.core import config

    config.OPT = type(config.OPT)(KERNEL_OPT)
