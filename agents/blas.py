"""numpy's BLAS kernels, pinned so that a CMA-ES search finds the same drives on every x86-64 CPU.

CMA-ES (the ``cma`` package) samples through numpy's linear algebra, and OpenBLAS picks its kernels
by the CPU it runs on: kernels for different CPUs round differently in the last bits (one search
point's drive at k = 0.3 came out 5e-15 apart with the 'SkylakeX' and the 'Haswell' kernels on one
machine). Over a teacher's thousands of searches such bits grow into other drives: on an AVX-512
machine the recipe's teacher differed from the shipped one at 196 of 600 nodes, and with the Haswell
kernels it was the shipped one bit for bit.

So the agents package asks OpenBLAS for its Haswell kernels (they need AVX2 and FMA, which x86-64
CPUs have had since 2013-2015) before numpy loads it, in this process and the ones it starts: on
import where numpy is not loaded yet, and, for the ``mdr-drive`` commands that run CMA-ES searches
(which load numpy first), by starting the command again with the kernels set (``pin_command``). It
leaves the choice alone where ``OPENBLAS_CORETYPE`` is set and on other machines: ``blas_core``
says which kernels a process got.
"""

from __future__ import annotations

import os
import platform
import sys

#: The OpenBLAS kernels the shipped teacher was searched with.
PINNED_CORE = "Haswell"


def _cpu_has_avx2_and_fma() -> bool:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    flags = line.split()
                    return "avx2" in flags and "fma" in flags
    except OSError:
        pass
    return False


def pin_blas_kernels() -> bool:
    """Set ``OPENBLAS_CORETYPE`` to :data:`PINNED_CORE` for this process and its children, unless it
    is set already, numpy is loaded, or the machine is not an x86-64 Linux with AVX2 and FMA.
    Returns whether it set it."""
    if "OPENBLAS_CORETYPE" in os.environ or "numpy" in sys.modules:
        return False
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64") or not _cpu_has_avx2_and_fma():
        return False
    os.environ["OPENBLAS_CORETYPE"] = PINNED_CORE
    return True


def pin_command() -> None:
    """Run this ``mdr-drive`` command again with :data:`PINNED_CORE` kernels, if numpy's OpenBLAS was
    loaded with other kernels that the pin would change (the command line, its environment and its
    process id stay; nothing has run yet). A process that is not the ``mdr-drive`` command, or where
    the kernels cannot or need not change, is left alone."""
    if "OPENBLAS_CORETYPE" in os.environ or os.path.basename(sys.argv[0]) != "mdr-drive":
        return
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64") or not _cpu_has_avx2_and_fma():
        return
    if blas_core() in (None, PINNED_CORE):
        return
    os.environ["OPENBLAS_CORETYPE"] = PINNED_CORE
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, *sys.orig_argv[1:]])


def blas_core() -> str | None:
    """The kernels numpy's OpenBLAS uses in this process (``'Haswell'``, ``'SkylakeX'``, ...), or
    None where numpy's BLAS is not an OpenBLAS that says."""
    import ctypes
    import glob

    import numpy as np

    folder = os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs")
    for path in glob.glob(os.path.join(folder, "*openblas*")):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename64_",
                     "openblas_get_corename"):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                core = fn()
                return core.decode() if core else None
    return None


__all__ = ["PINNED_CORE", "blas_core", "pin_blas_kernels", "pin_command"]
