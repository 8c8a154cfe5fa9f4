"""Code generation pipeline: symbolic element (elements/) -> CasADi Functions (definitions) -> C (writer).

`python -m ancf_sym.codegen` rewrites generated/; `--check` regenerates into a scratch folder and names every
kernel whose committed C differs. The manifest records a hash of the symbolic sources, the CasADi version and
the compiler flags the build uses per file.
"""
from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path

import casadi as ca

from ancf_sym import registry

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "generated"
MANIFEST = "manifest.json"
HEADER = "ancf_kernels.h"

# gcc flags per generated file: -O2 unless a kernel's size makes that slow to compile (measured, see README).
DEFAULT_CFLAGS = ["-O2", "-g0"]  # -g0: setuptools adds Python's -g; debug info cost beam3d_continuum 58 s vs 44 s
CFLAGS: dict[str, list[str]] = {}  # beam3d_continuum: 28 s at -O2, 22 s at -O1 (gcc 12): -O2 kept


def source_hash() -> str:
    """Hash of everything that defines the generated C: symbolic elements, forms, registry, CasADi version, flags."""
    pkg = Path(__file__).resolve().parents[1]
    files = sorted([*(pkg / "elements").glob("*.py"), *(pkg / "codegen").glob("*.py"), pkg / "registry.py"])
    h = hashlib.sha256()
    for f in files:
        h.update(f.relative_to(pkg).as_posix().encode())
        h.update(f.read_bytes())
    h.update(ca.__version__.encode())
    h.update(json.dumps([DEFAULT_CFLAGS, CFLAGS], sort_keys=True).encode())
    return h.hexdigest()


def generate(out_dir: Path = GENERATED, verbose: bool = False) -> dict:
    from ancf_sym.codegen import definitions, writer

    out_dir.mkdir(parents=True, exist_ok=True)
    entries, groups, batched = [], {}, {}
    for element, effect, gauss in registry.all_kernels():
        k = definitions.kernel(element, effect, gauss)
        name = k.name()
        third = registry.has_third_derivatives(element, effect, gauss)
        energy, grad = definitions.lower_orders(element, effect, gauss, k)
        lib = registry.library_name(element, effect)
        rows = definitions.rates_rows(element, effect, gauss, k)
        hvp = definitions.hvp(element, effect, gauss) if third else None
        groups.setdefault(lib, []).extend(writer.companions(k, energy, grad, third, hvp) + ([rows] if rows else []))
        batch = registry.batched(element, effect, gauss)
        if batch:
            by_suffix = {"": k, "_grad": grad, "_energy": energy}
            batched.setdefault(lib, []).extend(by_suffix[s] for s in batch)
        entries.append({
            "name": name, "element": element, "effect": effect, "gauss": gauss,
            "params": list(registry.EFFECTS[(element, effect)].params),
            "library": lib, "c_file": lib + ".c", "cflags": CFLAGS.get(lib, DEFAULT_CFLAGS),
            "functions": [name, name + "_energy", "adj1_" + name + "_energy", name + "_grad"]
            + ([name + "_hvp"] if third else []) + ([rows.name()] if rows else [])
            + [name + s + registry.BATCH_SUFFIX for s in batch],
        })
    digests = {}
    for lib, functions in groups.items():
        files = writer.write_c(lib, functions, out_dir, batched.get(lib, []))
        digests[lib] = hashlib.sha256(files[lib + ".c"].encode()).hexdigest()
        if verbose:
            print(f"  {lib}: {len(functions)} functions, {len(files[lib + '.c'].splitlines())} lines")
    for e in entries:
        e["sha256"] = digests[e["library"]]
    mass = [definitions.mass(el) for el in registry.ELEMENTS]
    files = writer.write_c("ancf_mass", mass, out_dir)
    entries.append({"name": "ancf_mass", "element": None, "effect": "mass", "gauss": None, "params": None,
                     "library": "ancf_mass", "c_file": "ancf_mass.c", "cflags": DEFAULT_CFLAGS, "functions": [m.name() for m in mass],
                     "sha256": hashlib.sha256(files["ancf_mass.c"].encode()).hexdigest()})
    from ancf_sym.codegen import band

    fns = band.functions()
    files = writer.write_c(registry.BAND_LIBRARY, fns, out_dir)
    entries.append({"name": registry.BAND_LIBRARY, "element": None, "effect": "band_ldl", "gauss": None, "params": None,
                    "library": registry.BAND_LIBRARY, "c_file": registry.BAND_LIBRARY + ".c", "cflags": DEFAULT_CFLAGS,
                    "functions": [f.name() for f in fns],
                    "sha256": hashlib.sha256(files[registry.BAND_LIBRARY + ".c"].encode()).hexdigest()})
    header = ["/* ancf_sym generated kernels: include this to call any of them from C. Do not edit. */",
              "#ifndef ANCF_KERNELS_H", "#define ANCF_KERNELS_H"]
    header += [f'#include "{lib}.h"' for lib in dict.fromkeys(e["library"] for e in entries)] + ["#endif", ""]
    (out_dir / HEADER).write_text("\n".join(header))
    manifest = {"casadi_version": ca.__version__, "source_hash": source_hash(), "codegen_options": writer.CODEGEN_OPTIONS,
                "kernels": entries}
    (out_dir / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def check(committed: Path = GENERATED) -> list[str]:
    """Names of the generated files that differ from what the current symbolic code generates (empty = in sync)."""
    with tempfile.TemporaryDirectory() as tmp:
        generate(Path(tmp))
        fresh = {p.name: p.read_text() for p in Path(tmp).iterdir()}
    old = {p.name: p.read_text() for p in committed.iterdir() if p.is_file()} if committed.is_dir() else {}
    return sorted(n for n in set(fresh) | set(old) if fresh.get(n) != old.get(n))
