"""Code generators for the numerical model: a family of siblings.

``_python``         NumPy source from a straight-line program (``backend="numpy"``)
``_c``              C source of an extension module (``backend="c"``)
``_c_printer``      SymPy's C printer for the rare expressions ``_c`` does not print itself
``_c_build``        compiling (translation units in parallel) and caching the modules
``_c_quick``        a model's first module from TinyCC, the optimized one built meanwhile
``_c_runtime``      the C runtime every generated module carries
``_c_integrator``   the compiled integration loop (RK45, Rosenbrock23)
``_c_ensemble``     many trajectories of the loop's RK45 at once, on POSIX threads
``_c_events``       events given as expressions, compiled for the ensemble
``_c_hessians``     the exact Hessian's second derivatives, solves and contraction
``_c_contact``      compiled contact segments (modes fixed, events located)
``_c_export``       the standalone C file (no Python) the FMU export compiles
``_c_hybrid``       the standalone file's contact loop: modes, events, impacts
``_c_contact_general``  its solve of several active contacts with friction
``_c_impacts``      its impacts of several contacts at once
``_c_impact_slide`` its impacts whose slip turns (integrated over the impulse)
``_bem_kernel``     the compiled solve of ``modeling``'s blade-element momentum
                    (``BladeElementMomentum``: its steps in C, an annulus at a time)
"""

from ..._lazy import lazy_attributes as _lazy_attributes
from ._bem_kernel import kernel as bem_kernel
from ._c_build import (STATS, CompilerError, cache_dir, compiler_command, load_module,
                       missing_compiler_text, trusted_cache_dir)

#: names whose modules need SymPy: imported on first use
_LAZY = {"fingerprint": "._c", "generate_c": "._c", "CodegenError": "._python",
         "compile_python": "._python", "generate_python": "._python",
         "compiled_events": "._c_events"}

__all__ = ["compile_python", "generate_python", "CodegenError", "generate_c", "load_module",
           "bem_kernel",
           "fingerprint", "compiler_command", "CompilerError", "STATS", "cache_dir",
           "trusted_cache_dir", "missing_compiler_text", "compiled_events"]

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
