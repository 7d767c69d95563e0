"""Which of proxsuite's compiled builds solves the passivity QP: the portable one by default, so that a
controller's ticks are bitwise reproducible.

proxsuite ships three builds of its solver (SSE2, AVX2, AVX-512) and loads the widest the CPU runs. In the
AVX2 and AVX-512 builds a solve of the same problem from the same start gives results that differ in the
last bits from one call to the next (about 1e-11 at the first tick of a walk, 1e-9 after a hundred ticks,
measured by replaying one walk's QPs through fresh solvers; docs/design.md, "Known limits"): Eigen's
32- and 64-byte vector loops split their sums by where the allocator put each vector, and the allocator
aligns to 16 bytes only. A walker then diverges over an episode (a held climb drifted 12.8-21.2 deg from
one run to the next, same seed), so evaluation figures near a threshold flip from run to run. The SSE2
build's 16-byte vectors are always aligned that way, and it gave one outcome over 60 replays where the
others gave two; at this QP's size (30-42 variables) it solves as fast (`benchmarks/bench_tick_parts.py`, which
prints the build: 36.4-36.9 us against AVX-512's 36.1-36.2 on an idle machine).

    MBC_QP_SOLVER_BUILD=portable   # default: SSE2, reproducible
    MBC_QP_SOLVER_BUILD=simd       # proxsuite's own choice (AVX-512 or AVX2 where the CPU has them)

The build is chosen once per process, when proxsuite is first imported (its builds cannot be loaded side
by side); worker processes inherit the variable.
"""

from __future__ import annotations

import os
import sys
import types
import warnings

from mbc.errors import ConfigError

BUILD_VARIABLE = "MBC_QP_SOLVER_BUILD"
BUILDS = ("portable", "simd")


def requested_build() -> str:
    """The build asked for by `MBC_QP_SOLVER_BUILD` ('portable' when unset)."""
    build = os.environ.get(BUILD_VARIABLE, "portable")
    if build not in BUILDS:
        raise ConfigError(f"{BUILD_VARIABLE}={build!r}; valid: {', '.join(BUILDS)}")
    return build


def import_proxsuite() -> types.ModuleType:
    """proxsuite, loaded in the requested build; warns where an earlier import already chose a wide one."""
    portable = requested_build() == "portable"
    if portable and "proxsuite" not in sys.modules:
        # proxsuite's loader asks its `instructionset` module which vector extensions the CPU has
        no_wide_vectors = types.ModuleType("proxsuite.instructionset")
        no_wide_vectors.has_AVX512F = no_wide_vectors.has_AVX2 = lambda: False
        sys.modules["proxsuite.instructionset"] = no_wide_vectors
        try:
            import proxsuite
        finally:
            del sys.modules["proxsuite.instructionset"]
    import proxsuite

    if portable and _build_name(proxsuite) != "proxsuite_pywrap":
        warnings.warn(f"proxsuite runs its build {_build_name(proxsuite)}, not the portable one (imported before mbc, "
                      f"or a proxsuite whose loader differs): the passivity QP's results are not bitwise reproducible "
                      f"(mbc.qp_solver_build); import mbc first, or set {BUILD_VARIABLE}=simd to accept that",
                      stacklevel=2)
    return proxsuite


def _build_name(proxsuite: types.ModuleType) -> str:
    """The compiled module proxsuite forwards to (proxsuite itself where it ships one build)."""
    return getattr(proxsuite, "_submodule", proxsuite).__name__.rsplit(".", 1)[-1]


def loaded_build() -> str:
    """The name of the proxsuite build this process runs ('proxsuite_pywrap' is the portable one)."""
    return _build_name(import_proxsuite())
