"""The portable numerics environment: the same numbers on x86-64 processors of any make.

numba compiles its kernels for the host processor, numpy dispatches its loops to the
widest SIMD extension it finds, and OpenBLAS picks its kernels by processor.  Each
choice changes the last bits of a result (another summation order, a fused multiply-add,
another vector width), and the simulator's contact dynamics and the experiments'
decisions near a tie amplify those bits: the same code and seed gave constraint-degree
confusions that differed by one block in 400 on two machines (an Intel and an AMD
processor with AVX-512), and the apparatus page's corner run went off the table on one.

:data:`ENV` pins all three: numba codegen for a generic x86-64 processor, numpy's
baseline loops only (numpy >= 2.4 names its dispatch targets X86_V3 ...; older numpy
would ignore these names, which :func:`check` catches), OpenBLAS's Haswell kernels.
What it covers: x86-64 Linux machines with AVX2 and FMA (Haswell's kernels need them;
glibc then takes the same maths routines) and the same library versions.  The committed
experiment pages under ``reports/`` are made in it (``make reproduce``), and ``make
test`` and ``make fresh`` run in it.

The variables must be set before numpy and numba are loaded, so they go to a new process:
``python -m contactlab.portable COMMAND [ARGS...]`` checks in a child process that each
took effect (:func:`check`) and then runs COMMAND with them; ``python -m
contactlab.portable`` alone prints them for a shell; ``--check`` checks the running
process.
"""

from __future__ import annotations

import os
import subprocess
import sys

__all__ = ["ENV", "check", "environment"]

#: environment variables of the portable numerics environment
ENV = {
    "NUMBA_CPU_NAME": "generic",                            # numba: no host-specific codegen
    "NPY_DISABLE_CPU_FEATURES": "X86_V3,X86_V4,AVX512_ICL,AVX512_SPR",  # numpy: baseline loops
    "OPENBLAS_CORETYPE": "Haswell",                         # OpenBLAS (numpy's and scipy's)
}


def environment(base: dict | None = None) -> dict:
    """``base`` (default: this process's environment) with :data:`ENV` set."""
    env = dict(os.environ if base is None else base)
    env.update(ENV)
    return env


def check() -> list[str]:
    """What of :data:`ENV` did not take effect in this process (empty: all did): numpy
    dispatching to a disabled extension, numba compiling for another processor, an
    OpenBLAS on other kernels.  Loads numpy, numba and scipy's linear algebra."""
    import numba
    import numpy as np
    import scipy.linalg  # noqa: F401  (its OpenBLAS, for threadpoolctl to see)
    from numpy._core import _multiarray_umath as um
    from threadpoolctl import threadpool_info

    problems = []
    off = set(ENV["NPY_DISABLE_CPU_FEATURES"].split(","))
    if not set(um.__cpu_dispatch__) & off:
        problems.append(f"numpy {np.__version__} knows none of {', '.join(sorted(off))} "
                        "(numpy >= 2.4 names its dispatch targets so)")
    live = sorted(f for f in um.__cpu_dispatch__ if f in off and um.__cpu_features__.get(f))
    if live:
        problems.append(f"numpy still dispatches to {', '.join(live)}")
    if numba.config.CPU_NAME != ENV["NUMBA_CPU_NAME"]:
        problems.append(f"numba compiles for {numba.config.CPU_NAME or 'the host'}")
    for lib in threadpool_info():
        if lib.get("internal_api") == "openblas" and \
                lib.get("architecture") != ENV["OPENBLAS_CORETYPE"]:
            problems.append(f"OpenBLAS {lib.get('filepath')} runs "
                            f"{lib.get('architecture')} kernels")
    return problems


def _main(argv: list[str]) -> int:
    if not argv:
        print(" ".join(f"{k}={v}" for k, v in ENV.items()))
        return 0
    if argv == ["--check"]:
        problems = check()
        for p in problems:
            print(f"contactlab.portable: {p}", file=sys.stderr)
        return 1 if problems else 0
    env = environment()
    probe = subprocess.run([sys.executable, "-m", "contactlab.portable", "--check"], env=env)
    if probe.returncode:
        print("contactlab.portable: the portable numerics environment did not take effect; "
              f"not running {argv[0]}", file=sys.stderr)
        return 2
    try:
        os.execvpe(argv[0], argv, env)
    except OSError as exc:
        print(f"contactlab.portable: cannot run {argv[0]}: {exc.strerror}", file=sys.stderr)
        return 127


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
