"""A CasADi Function compiled for :class:`~optdesign.kinematics.mapped.MappedFunction` (its
``compile``): the model's layer hands this to the evaluations over many sweep values (the
analysis, its certification, the assembly check through the mechanism's ``compile_function``, the
design problem)."""
from __future__ import annotations

import casadi as ca


def compiled_function(func: ca.Function):
    """``func`` compiled (CasADi's C code of it, :func:`optdesign.model.compiled.external`): a
    ``ca.external`` with the same inputs and outputs, or None (no compiler, the cache turned off,
    compiling in the background, or a graph CasADi cannot write as C: :func:`writes_c`).  CasADi's
    code does the virtual machine's operations in the same order in IEEE arithmetic (no
    fast-math, no fused multiply-adds): the same numbers."""
    from . import compiled

    if not writes_c(func):
        return None

    def source(name):
        sym = func.sx_in() if func.is_a("SXFunction") else func.mx_in()
        named = ca.Function(name, sym, func.call(sym), func.name_in(), func.name_out())
        code = ca.CodeGenerator(name, {"with_header": False, "with_export": True})
        code.add(named)
        return code.dump()

    return compiled.external(func, "optdesign_mapped", source)


def writes_c(func: ca.Function) -> bool:
    """Whether CasADi can write ``func`` as C: an SX graph, or an MX graph whose calls all can.
    A loop's Newton solve (a ``Newton`` rootfinder in the graphs of a scene with loops) cannot;
    compiling it would only fail and say so."""
    if func.is_a("SXFunction"):
        return True
    return func.is_a("MXFunction") and all(
        writes_c(func.instruction_MX(k).which_function())
        for k in range(func.n_instructions()) if func.instruction_id(k) == ca.OP_CALL)
