"""Batched kernels: one C function evaluating a straight-line SX kernel on LANES elements at once, in SIMD lanes.

A mapped kernel calls the scalar C function once per element; gcc compiles that code to scalar instructions. The
batch function runs the same instruction sequence on LANES elements side by side with GCC vector extensions
(`double __attribute__((vector_size(8 * LANES)))`): each scalar operation of the kernel becomes one vector
operation. It is derived from CasADi's own C for the scalar kernel by a checked, line-by-line rewrite (every line
of the body must be one of the forms CasADi emits for straight-line SX code: declarations, literal constants,
input reads, + - * /, casadi_sq, sqrt, output writes; anything else is an error at generation time), and wrapped
in CasADi's external-function interface, so `casadi.external("<name>_x4", lib)` loads it:

    <name>_x4: (q[nd x LANES], p[np x LANES]) -> (outputs of <name>, each with LANES columns)

i.e. exactly `<name>.map(LANES)`. The arithmetic is the scalar kernel's, operation for operation; on x86-64 with
glibc the body is also compiled for x86-64-v3 (AVX2, FMA) and chosen at load time (target_clones), where FMA
contraction changes results in the last bits only.
"""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import casadi as ca

from ancf_sym import registry

LANES = registry.BATCH_LANES
SUFFIX = registry.BATCH_SUFFIX

_DECL = re.compile(r"^\s*casadi_real ([a-z0-9_, ]+);$")
_CONST = re.compile(r"^\s*(a\d+)=([-+0-9.eE]+);$")
_INPUT = re.compile(r"^\s*(a\d+)=arg\[(\d+)\]\? arg\[\2\]\[(\d+)\] : 0;$")
_NUM = r"[0-9][0-9.]*(?:[eE][-+]?[0-9]+)?"  # a literal operand CasADi inlines, e.g. (2.*a031)
_OPD = rf"(a\d+|{_NUM})"
_BINARY = re.compile(rf"^\s*(a\d+)=\({_OPD}([-+*/]){_OPD}\);$")
_UNARY = re.compile(rf"^\s*(a\d+)=(casadi_sq|sqrt)\({_OPD}\);$")
_NEG = re.compile(rf"^\s*(a\d+)=\(-{_OPD}\);$")
_ASSIGN = re.compile(r"^\s*(a\d+)=(a\d+);$")
_OUTPUT = re.compile(r"^\s*if \(res\[(\d+)\]!=0\) res\[\1\]\[(\d+)\]=(a\d+);$")


def _scalar_body(f: ca.Function) -> list[str]:
    """The body lines of CasADi's C for f alone (its casadi_f0)."""
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            cg = ca.CodeGenerator("scalar.c", {"with_header": False, "casadi_real": "double",
                                               "casadi_int": "long long int"})
            cg.add(f)
            cg.generate()
            text = (Path(tmp) / "scalar.c").read_text()
        finally:
            os.chdir(cwd)
    m = re.search(r"static int casadi_f0\(const casadi_real\*\* arg, casadi_real\*\* res, casadi_int\* iw, "
                  r"casadi_real\* w, int mem\) \{\n(.*?)\n  return 0;\n\}", text, re.S)
    if m is None or "casadi_f1(" in text:
        raise ValueError(f"{f.name()}: not a single straight-line function in CasADi's C")
    return m.group(1).splitlines()


def _opd(x: str) -> str:
    return x if x.startswith("a") else f"ANCF_SPLAT({x})"


def _vector_body(f: ca.Function) -> list[str]:
    out = []
    for line in _scalar_body(f):
        if (m := _DECL.match(line)):
            out.append(f"  ancf_vec {m.group(1)};")
        elif (m := _CONST.match(line)):
            c = m.group(2)
            out.append(f"  {m.group(1)}=ANCF_SPLAT({c});")
        elif (m := _INPUT.match(line)):
            out.append(f"  {m.group(1)}=x{m.group(2)}[{m.group(3)}];")
        elif (m := _BINARY.match(line)):
            out.append(f"  {m.group(1)}=({_opd(m.group(2))}{m.group(3)}{_opd(m.group(4))});")
        elif (m := _UNARY.match(line)):
            fn = "ANCF_SQ" if m.group(2) == "casadi_sq" else "ancf_vsqrt"
            out.append(f"  {m.group(1)}={fn}({_opd(m.group(3))});")
        elif (m := _NEG.match(line)):
            out.append(f"  {m.group(1)}=(-{_opd(m.group(2))});")
        elif (m := _ASSIGN.match(line)):
            out.append(f"  {m.group(1)}={m.group(2)};")
        elif (m := _OUTPUT.match(line)):
            out.append(f"  y{m.group(1)}[{m.group(2)}]={m.group(3)};")
        else:
            raise ValueError(f"{f.name()}: cannot batch the C line {line.strip()!r}")
    return out


PRELUDE = f"""
/* ---- batched kernels (ancf_sym.codegen.batch): {LANES} elements per call in vector lanes ---- */
typedef double ancf_vec __attribute__((vector_size({8 * LANES})));
#define ANCF_SPLAT(c) ((ancf_vec){{{", ".join(["(c)"] * LANES)}}})
#define ANCF_SQ(x) ((x)*(x))
#define ancf_vsqrt(x) ({{ ancf_vec ancf_r_ = (x); int ancf_k_; \\
  for (ancf_k_=0; ancf_k_<{LANES}; ++ancf_k_) {{ ancf_r_[ancf_k_] = sqrt(ancf_r_[ancf_k_]); }} ancf_r_; }})
#if !defined(ANCF_NO_CLONES) && defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__GLIBC__) && __GNUC__ >= 12
#define ANCF_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ANCF_CLONES
#endif
"""


def _sparsity_c(sp: ca.Sparsity) -> str:
    if not sp.is_dense():
        raise ValueError("batched kernels need dense inputs and outputs")
    return f"{sp.size1()}, {sp.size2() * LANES}, 1"


def batch_c(f: ca.Function) -> str:
    """C source (to append to a file holding PRELUDE once) of <f>_x4 with CasADi's external interface."""
    name = f.name() + SUFFIX
    n_in, n_out = f.n_in(), f.n_out()
    size_in = [f.nnz_in(i) for i in range(n_in)]
    size_out = [f.nnz_out(i) for i in range(n_out)]
    body = _vector_body(f)
    lines = [f"/* {name}: {f.name()} on {LANES} elements (columns) per call */",
             f"ANCF_CLONES static void {name}_body(" +
             ", ".join([f"const ancf_vec* x{i}" for i in range(n_in)] + [f"ancf_vec* y{i}" for i in range(n_out)]) + ") {"]
    lines += body
    lines += ["}", "",
              f"CASADI_SYMBOL_EXPORT int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, "
              f"casadi_real* w, int mem) {{"]
    lines += [f"  ancf_vec x{i}[{max(n, 1)}];" for i, n in enumerate(size_in)]
    lines += [f"  ancf_vec y{i}[{max(n, 1)}];" for i, n in enumerate(size_out)]
    lines += ["  casadi_int i, k;"]
    for i, n in enumerate(size_in):
        lines.append(f"  for (k=0; k<{LANES}; ++k) for (i=0; i<{n}; ++i) x{i}[i][k] = arg[{i}] ? arg[{i}][k*{n}+i] : 0;")
    lines.append(f"  {name}_body(" + ", ".join([f"x{i}" for i in range(n_in)] + [f"y{i}" for i in range(n_out)]) + ");")
    for i, n in enumerate(size_out):
        lines.append(f"  if (res[{i}]) for (k=0; k<{LANES}; ++k) for (i=0; i<{n}; ++i) res[{i}][k*{n}+i] = y{i}[i][k];")
    lines += ["  return 0;", "}", ""]
    sp_in = [_sparsity_c(f.sparsity_in(i)) for i in range(n_in)]
    sp_out = [_sparsity_c(f.sparsity_out(i)) for i in range(n_out)]
    for kind, sps in (("in", sp_in), ("out", sp_out)):
        lines += [f"static const casadi_int {name}_s{kind}[{len(sps)}][3] = {{" + ", ".join("{" + s + "}" for s in sps) + "};"]
    names_in = ", ".join(f'"{f.name_in(i)}"' for i in range(n_in))
    names_out = ", ".join(f'"{f.name_out(i)}"' for i in range(n_out))
    lines += [
        f"CASADI_SYMBOL_EXPORT casadi_int {name}_n_in(void) {{ return {n_in}; }}",
        f"CASADI_SYMBOL_EXPORT casadi_int {name}_n_out(void) {{ return {n_out}; }}",
        f"CASADI_SYMBOL_EXPORT const char* {name}_name_in(casadi_int i) {{ static const char* n[] = {{{names_in}}}; "
        f"return i >= 0 && i < {n_in} ? n[i] : 0; }}",
        f"CASADI_SYMBOL_EXPORT const char* {name}_name_out(casadi_int i) {{ static const char* n[] = {{{names_out}}}; "
        f"return i >= 0 && i < {n_out} ? n[i] : 0; }}",
        f"CASADI_SYMBOL_EXPORT const casadi_int* {name}_sparsity_in(casadi_int i) {{ "
        f"return i >= 0 && i < {n_in} ? {name}_sin[i] : 0; }}",
        f"CASADI_SYMBOL_EXPORT const casadi_int* {name}_sparsity_out(casadi_int i) {{ "
        f"return i >= 0 && i < {n_out} ? {name}_sout[i] : 0; }}",
        f"CASADI_SYMBOL_EXPORT int {name}_work(casadi_int *sz_arg, casadi_int* sz_res, casadi_int *sz_iw, "
        f"casadi_int *sz_w) {{",
        f"  if (sz_arg) *sz_arg = {n_in};", f"  if (sz_res) *sz_res = {n_out};", "  if (sz_iw) *sz_iw = 0;",
        "  if (sz_w) *sz_w = 0;", "  return 0;", "}", ""]
    return "\n".join(lines)
