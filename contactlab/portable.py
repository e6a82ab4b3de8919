"""The portable numerics environment: the same numbers on any x86-64 processor.

numba compiles its kernels for the host processor, numpy dispatches its loops to the
widest SIMD extension it finds, and OpenBLAS picks its kernels by processor.  Each
choice changes the last bits of a result (another summation order, a fused multiply-add,
another vector width), and the simulator's contact dynamics and the experiments'
decisions near a tie amplify those bits: the same code and seed gave constraint-degree
confusions that differed by one block in 400 on two machines.

:data:`ENV` pins all three to a baseline every x86-64 machine with AVX2 runs: numba
codegen for a generic processor, numpy's baseline loops only, OpenBLAS's Haswell
kernels.  The committed experiment pages under ``reports/`` are made in it (``make
reproduce``), and the check that they are fresh reruns them in it.  The variables must
be set before numpy and numba are loaded, so they are given to a new process
(:func:`environment`); ``python -m contactlab.portable`` prints them for a shell.
"""

from __future__ import annotations

import os

__all__ = ["ENV", "environment"]

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


if __name__ == "__main__":
    print(" ".join(f"{k}={v}" for k, v in ENV.items()))
