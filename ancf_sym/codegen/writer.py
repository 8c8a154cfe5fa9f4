"""Write CasADi Functions as C sources into generated/, one file per kernel, plus the umbrella header."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import casadi as ca

CODEGEN_OPTIONS = {"with_header": True, "casadi_real": "double", "casadi_int": "long long int"}


def companions(kernel: ca.Function, energy: ca.Function, grad: ca.Function, third: bool = False,
               hvp: ca.Function | None = None) -> list[ca.Function]:
    """The kernel, its energy alone, that energy's reverse-mode companion adj1_<name>_energy, energy + gradient
    (<name>_grad); with third=True also <name>_hvp (Hessian-vector product and its Jacobian, for optimal control):
    `hvp` where given (a point-form companion, codegen.hvp_forms), else the kernel's own third derivative.

    casadi.external(<name>_energy) finds adj1_<name>_energy in the same library, so an MX objective built from it
    (e.g. an IPOPT problem) gets its gradient from compiled code; the Hessian comes from the kernel itself.
    """
    from ancf_sym.codegen.forms import hvp_function

    return [kernel, energy, energy.reverse(1), grad] + ([hvp or hvp_function(kernel)] if third else [])


def write_c(name: str, functions: list[ca.Function], out_dir: Path,
            batched: list[ca.Function] = ()) -> dict[str, str]:
    """Generate <name>.c and <name>.h in out_dir; returns {filename: text}. `batched`: functions (of `functions`)
    that also get a <fn>_x4 batch version (codegen.batch), appended to the same file."""
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            cg = ca.CodeGenerator(name + ".c", CODEGEN_OPTIONS)
            for f in functions:
                cg.add(f)
            cg.generate()
        finally:
            os.chdir(cwd)
        files = {fn: (Path(tmp) / fn).read_text() for fn in (name + ".c", name + ".h")}
    if batched:
        from ancf_sym.codegen import batch

        files[name + ".c"] += batch.PRELUDE + "\n".join(batch.batch_c(f) for f in batched)
        h = files[name + ".h"]
        decls = "".join(f"int {f.name()}{batch.SUFFIX}(const casadi_real** arg, casadi_real** res, casadi_int* iw, "
                        f"casadi_real* w, int mem);\n" for f in batched)
        at = h.rfind("#ifdef __cplusplus")
        files[name + ".h"] = h[:at] + decls + h[at:] if at > 0 else h + decls
    for fn, text in files.items():
        (out_dir / fn).write_text(text)
    return files
