"""The compilation of forms: the C compiler flags (the CPU's vector instructions, the
environment's flags instead) and the JIT's options."""

from __future__ import annotations

import os

import dolfinx
import dolfinx.fem
import ufl


def _keyword(function, new: str, old: str) -> str:
    """The name ``function`` uses for an argument renamed between versions."""
    import inspect

    return new if new in inspect.signature(function).parameters else old


def vector_flags(cpuinfo: str = "/proc/cpuinfo", machine: str | None = None) -> tuple[str, ...]:
    """``-mavx2 -mfma`` where this x86-64 CPU has both (read from ``cpuinfo``),
    else nothing.  The flags are part of the JIT cache's key, so a machine without
    them never loads code compiled with them: it compiles its own."""
    import platform

    if (machine or platform.machine()).lower() not in ("x86_64", "amd64"):
        return ()
    try:
        with open(cpuinfo, encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    have = set(line.split(":", 1)[1].split())
                    return ("-mavx2", "-mfma") if {"avx2", "fma"} <= have else ()
    except OSError:
        pass
    return ()


#: C compiler flags of every form rftfem compiles (benchmarks/form_cost.py):
#: ``-O3`` with the CPU's vector instructions (AVX2 and fused multiply-adds, where it
#: has them) and reassociation, which lets the compiler vectorise the kernels'
#: sums; NaN and infinity keep their meaning (no ``-ffinite-math-only``: a NaN
#: residual must still stop Newton).  ``-fno-math-errno`` emits ``sqrt`` as one
#: instruction.  Results change in the last bits only.  The shell's Jacobian kernel
#: costs about half as much as with the JIT's own ``-O2`` (docs/performance.md).
#: ``RFTFEM_COMPILE_FLAGS`` in the environment replaces them (e.g. "-O2 -g0").
FLAGS_FROM_ENVIRONMENT = bool(os.environ.get("RFTFEM_COMPILE_FLAGS"))
COMPILE_FLAGS = (
    tuple(os.environ["RFTFEM_COMPILE_FLAGS"].split())
    if FLAGS_FROM_ENVIRONMENT
    else (
        "-O3",
        "-g0",
        "-fno-math-errno",
        "-fno-trapping-math",
        "-fno-signed-zeros",
        "-fassociative-math",
        "-freciprocal-math",
    )
    + vector_flags()
)
#: seconds a process waits for another one compiling the same form into the shared
#: JIT cache (runs of a study side by side); the JIT's own 10 s failed them, the
#: shell's Jacobian takes 20-90 s to compile
COMPILE_WAIT = 300


def form(
    ufl_form: ufl.Form | list[ufl.Form], jit_options: dict | None = None
) -> dolfinx.fem.Form | list[dolfinx.fem.Form]:
    """Compile a UFL form (list of forms allowed) to a dolfinx Form, with
    ``COMPILE_FLAGS`` and ``COMPILE_WAIT`` unless ``jit_options`` gives its own."""
    options = {
        "cffi_extra_compile_args": list(COMPILE_FLAGS),
        "timeout": COMPILE_WAIT,
        **(jit_options or {}),
    }
    try:
        return dolfinx.fem.form(ufl_form, **{_JIT_KEY: options})
    except Exception as error:
        # the C compiler refused a user's flags: a bad option, not a traceback
        if FLAGS_FROM_ENVIRONMENT and "CompileError" in str(error):
            from rftfem.errors import SceneError

            raise SceneError(
                "RFTFEM_COMPILE_FLAGS: the C compiler failed with the flags "
                f"'{' '.join(COMPILE_FLAGS)}' (unset it, or give flags it "
                "accepts)"
            ) from error
        raise


# an argument renamed between dolfinx versions, detected once: jit_params → jit_options
_JIT_KEY = _keyword(dolfinx.fem.form, "jit_options", "jit_params")
