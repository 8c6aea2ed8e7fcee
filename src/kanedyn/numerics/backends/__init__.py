"""Code generators for the numerical model: a family of siblings.

``_python``         NumPy source from a straight-line program (``backend="numpy"``)
``_c``              C source of an extension module (``backend="c"``)
``_c_build``        compiling (translation units in parallel) and caching the modules
``_c_runtime``      the C runtime every generated module carries
``_c_integrator``   the compiled integration loop (RK45, Rosenbrock23)
"""

from ._c import (STATS, CompilerError, cache_dir, compiler_command, fingerprint, generate_c,
                 load_module)
from ._python import CodegenError, compile_python, generate_python

__all__ = ["compile_python", "generate_python", "CodegenError", "generate_c", "load_module",
           "fingerprint", "compiler_command", "CompilerError", "STATS", "cache_dir"]
