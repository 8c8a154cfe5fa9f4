"""Build: compile every kernel in generated/ (committed C from `python -m ancf_sym.codegen`) into a shared library
inside the installed package, ancf_sym/_kernels/, and the hand-written C of csrc/ next to them. Nothing is generated
or compiled at run time."""
import json
import os
import shutil
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
GENERATED = HERE / "generated"
MANIFEST = json.loads((GENERATED / "manifest.json").read_text())


class ParallelBuildExt(build_ext):
    """Compile kernels on every core; they are independent translation units."""

    def finalize_options(self):
        super().finalize_options()
        if not self.parallel:
            self.parallel = os.cpu_count() or 1

    def get_export_symbols(self, ext):
        return []  # plain C libraries, not Python modules: no PyInit_ symbol to export


class BuildPyWithManifest(build_py):
    def run(self):
        # modules removed or turned into packages since the last build must not ship from a reused build/ folder
        built = Path(self.build_lib) / "ancf_sym"
        for old in built.rglob("*.py") if built.is_dir() else ():
            if not (HERE / old.relative_to(self.build_lib)).exists():
                old.unlink()
        super().run()
        dst = Path(self.build_lib) / "ancf_sym" / "_kernels"
        dst.mkdir(parents=True, exist_ok=True)
        shutil.copy(GENERATED / "manifest.json", dst / "manifest.json")
        shutil.copy(GENERATED / "ancf_kernels.h", dst / "ancf_kernels.h")
        for lib in LIBRARIES:
            shutil.copy(GENERATED / f"{lib}.h", dst)


# one shared library per generated C file (all quadrature orders of an (element, effect) share one); the largest
# files first, so that the parallel build does not end on one long compile (longest-first scheduling)
LIBRARIES = {k["library"]: k for k in MANIFEST["kernels"]}
extensions = [
    Extension(f"ancf_sym._kernels.{lib}", sources=[f"generated/{k['c_file']}"],
              extra_compile_args=k["cflags"], libraries=["m"])
    for lib, k in sorted(LIBRARIES.items(), key=lambda lk: -(GENERATED / lk[1]["c_file"]).stat().st_size)
]
# hand-written C (csrc/): the statics Newton loop, calling the kernels and LAPACK by pointer (ancf_sym.statics.newton_loop);
# no floating-point contraction, so that it rounds as the numpy loop it mirrors
extensions.append(Extension("ancf_sym._kernels.newton_loop", sources=["csrc/newton_loop.c"],
                            extra_compile_args=["-O2", "-g0", "-ffp-contract=off"], libraries=["m"]))

setup(ext_modules=extensions, cmdclass={"build_ext": ParallelBuildExt, "build_py": BuildPyWithManifest})
