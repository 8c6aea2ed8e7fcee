"""The compiled backend: C from a straight-line program, built into an extension.

Code generation
    Every intermediate is one C statement.  Large programs are split into
    functions of at most ``CHUNK`` statements (compilers slow down
    superlinearly on huge functions); values crossing a split go through a
    work array.

Build and cache
    The module is compiled with the system C compiler on first use and cached
    on disk under a name derived from the SHA-256 of its source and build
    settings (``$KANEDYN_CACHE_DIR``, else ``$XDG_CACHE_HOME/kanedyn`` or
    ``~/.cache/kanedyn``).  Builds happen in a private temporary directory and
    are published with an atomic rename, so several processes may build the
    same module at once; every entry carries a checksum and an entry that
    fails it (or fails to load) is rebuilt.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np
import sympy as sm
from sympy.printing.c import C99CodePrinter

from . import _c_contact, _c_integrator, _c_lanes, _c_runtime
from ._python import CodegenError
from ..._errors import KanedynError

__all__ = ["CompilerError", "generate_c", "fingerprint", "load_module", "compiler_command",
           "missing_compiler_text", "CHUNK", "elimination_tree", "solver_source", "STATS",
           "cache_dir", "speed_tree_outputs", "TREE_MIN_SPEEDS"]

CHUNK = 2500  # statements per generated C function
NAME_TOKEN = "KDMODULENAME"  # stands for the module name in generated templates
_LOADED = {}  # hash -> module, per process
_LOCK = threading.Lock()


class CompilerError(KanedynError, RuntimeError):
    """No usable C compiler, or compilation failed."""


# ------------------------------------------------------------------ printing
class _CPrinter(C99CodePrinter):
    def __init__(self, names):
        super().__init__({"strict": True, "order": "none"})
        self._names = names

    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise CodegenError(f"symbol {expr} has no value in the generated code") \
                from None

    _print_Dummy = _print_Symbol

    def _print_Pow(self, expr):
        base, exp = expr.args
        b = self.parenthesize(base, 60)  # tighter than multiplication
        if exp.is_Integer:
            n = int(exp)
            if n == 2:
                return f"({b}*{b})"
            if n == 3:
                return f"({b}*{b}*{b})"
            if n == -1:
                return f"(1.0/{b})"
            if n == -2:
                return f"(1.0/({b}*{b}))"
            return f"kd_powi({self._print(base)}, {n})"
        if exp == sm.S.Half:
            return f"sqrt({self._print(base)})"
        if exp == -sm.S.Half:
            return f"(1.0/sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self._print(exp)})"

    def _print_sign(self, expr):
        return f"kd_sign({self._print(expr.args[0])})"


def _print_c(printer, expr, what, describe=str):
    try:
        return printer.doprint(sm.sympify(expr))
    except CodegenError:
        raise
    except Exception as exc:  # noqa: BLE001  (the printer raises several kinds)
        raise CodegenError(
            f"the C backend cannot generate code for {describe(expr)} ({what}): {exc}; "
            "the numpy backend (backend='numpy') can evaluate it") from None


# ---------------------------------------------------------------- functions
def _function_source(program, name, arguments, outputs, describe, cse, listing=None):
    """C source of ``kd_eval_<name>`` and the number of work slots it needs.

    ``listing``: the result of ``program.listing`` of the flattened outputs,
    when already computed (it is then not computed again).
    """
    base = {program.t: "t"}
    for arg, symbols in arguments.items():
        for i, s in enumerate(symbols):
            base[s] = f"{arg}[{i}]"
    flat = [sm.sympify(e) for _, exprs in outputs for e in exprs]
    assignments, flat = listing if listing is not None else program.listing(flat, cse=cse)
    needed = [s for s, _ in assignments]
    definition = dict(assignments)
    index = {s: k for k, s in enumerate(needed)}
    chunks = [needed[i:i + CHUNK] for i in range(0, len(needed), CHUNK)] or [[]]
    chunk_of = {s: c for c, members in enumerate(chunks) for s in members}
    # the last chunk (len(chunks) = the output part) using each intermediate
    last_use = {}
    for s in needed:
        for parent in definition[s].free_symbols:
            if parent in index:
                last_use[parent] = max(last_use.get(parent, -1), chunk_of[s])
    for e in flat:
        for s in e.free_symbols:
            if s in index:
                last_use[s] = len(chunks)
    split = len(chunks) > 1  # decided before any statement is emitted
    params = ("double t, const double *restrict y, const double *restrict p, "
              "const double *restrict r, double *restrict w")
    lines = []
    stored = set()
    for c, members in enumerate(chunks):
        names = dict(base)
        for s in needed:
            if s in stored and chunk_of[s] < c:
                names[s] = f"w[{index[s]}]"
        body = []
        for s in members:
            names[s] = f"z{index[s]}"
            code = _print_c(_CPrinter(names), definition[s],
                            f"in the intermediate {s.name}", describe)
            body.append(f"    const double z{index[s]} = {code};")
            if split and last_use.get(s, c) > c:
                body.append(f"    w[{index[s]}] = z{index[s]};")
                stored.add(s)
        if split:
            lines.append(f"static void kd_{name}_part{c}({params}) {{")
            lines.extend(body or ["    (void)w;"])
            lines.append("}")
        else:
            chunk_body = body
    out_params = ", ".join(f"double *restrict o{k}" for k in range(len(outputs)))
    lines.append(f"static void kd_eval_{name}({params}{', ' if outputs else ''}{out_params}) {{")
    names = dict(base)
    if split:
        for c in range(len(chunks)):
            lines.append(f"    kd_{name}_part{c}(t, y, p, r, w);")
        for s in stored:
            names[s] = f"w[{index[s]}]"
    else:
        lines.extend(chunk_body)
        for s in needed:
            names[s] = f"z{index[s]}"
    printer = _CPrinter(names)
    position = 0
    for k, (_, exprs) in enumerate(outputs):
        for j in range(len(exprs)):
            code = _print_c(printer, flat[position], f"output {j} of {name}", describe)
            position += 1
            lines.append(f"    o{k}[{j}] = {code};")
    lines.append("    (void)t; (void)y; (void)p; (void)r; (void)w;")
    lines.append("}")
    work = len(needed) if split else 0
    return "\n".join(lines), work


def _wrapper_source(name, outputs, nr):
    """Module-level Python function ``name(t, y, p, r)`` returning a tuple of arrays."""
    lines = [f"static PyObject *kd_py_{name}(PyObject *self, PyObject *const *args, "
             "Py_ssize_t nargs) {",
             "    KdArgs a;",
             f"    if (kd_parse(args, nargs, {nr}, &a) != 0) {{ kd_release(&a); return NULL; }}",
             f"    PyObject *result = PyTuple_New({len(outputs)});",
             "    if (result == NULL) { kd_release(&a); return NULL; }"]
    ptrs = []
    for k, (shape, _) in enumerate(outputs):
        lines.append(f"    double *d{k} = NULL, s{k}[1];")
        if shape == ():
            lines.append(f"    d{k} = s{k};")
            ptrs.append(f"d{k}")
            continue
        if len(shape) == 1:
            make = f"kd_new_vector({shape[0]}, &d{k})"
        else:
            make = f"kd_new_matrix({shape[0]}, {shape[1]}, &d{k})"
        lines.append(f"    PyObject *a{k} = {make};")
        lines.append(f"    if (a{k} == NULL) {{ Py_DECREF(result); kd_release(&a); return NULL; }}")
        lines.append(f"    PyTuple_SET_ITEM(result, {k}, a{k});")
        ptrs.append(f"d{k}")
    call_args = ", ".join(["a.t", "a.y", "a.p", "a.r", "a.work"] + ptrs)
    lines.append(f"    kd_eval_{name}({call_args});")
    for k, (shape, _) in enumerate(outputs):
        if shape == ():
            lines.append(f"    PyTuple_SET_ITEM(result, {k}, PyFloat_FromDouble(s{k}[0]));")
    lines += ["    kd_release(&a);", "    return result;", "}"]
    return "\n".join(lines)


def elimination_tree(nonzero):
    """Elimination tree of the ``L^T D L`` factorization (last index first).

    Parameters
    ----------
    nonzero : numpy.ndarray of bool, shape (n, n)
        Symmetric structure of the matrix (``True`` where an entry may be
        nonzero).

    Returns
    -------
    list of int
        ``parent[k]`` (``-1`` for a root), with ``parent[k] < k``: after the
        factorization, ``L[k, i]`` can be nonzero only for ``i`` an ancestor of
        ``k``.  For a kinematic tree whose coordinates are numbered parents
        first, the tree of the coordinates itself (no fill-in).
    """
    n = len(nonzero)
    lower = [{j for j in range(k) if nonzero[k, j] or nonzero[j, k]} for k in range(n)]
    parent = [-1] * n
    for k in range(n - 1, -1, -1):
        if lower[k]:
            parent[k] = top = max(lower[k])
            lower[top] |= lower[k] - {top}  # the fill-in of eliminating k
    return parent


def solver_source(functions, sizes):
    """C definitions choosing the solve of ``M u' = f`` (``KD_SOLVE``).

    The structural zeros of the mass matrix (entries of the ``dynamics``
    output that are exactly zero) give its elimination tree: when that tree
    is a single path (a dense factor), ``KD_SOLVE 1`` (dense ``L^T D L``);
    otherwise ``KD_SOLVE 2`` and the parent array ``kd_parent`` (tree
    ``L^T D L``, no work on the structural zeros).  With a ``tree`` function
    (:func:`speed_tree_outputs`), ``KD_SOLVE 3``: the mass matrix is never
    formed; an articulated-body pass over the tree of speeds solves for u'.
    """
    n = sizes["n_u"]
    if "tree" in functions and not sizes["n_u_dep"]:  # see speed_tree_outputs
        parent, order = sizes["speed_tree"]
        return ["#define KD_SOLVE 3",
                f"static const int kd_tparent[{n}] = {{{', '.join(map(str, parent))}}};",
                f"static const int kd_torder[{n}] = {{{', '.join(map(str, order))}}};"]
    if sizes["n_u_dep"] or n < 3:
        return ["#define KD_SOLVE 1"]
    _, outputs = functions["dynamics"]
    shape, entries = outputs[1]
    nonzero = np.array([not (sm.sympify(e) == 0) for e in entries], dtype=bool)
    parent = elimination_tree(nonzero.reshape(n, n))
    if all(parent[k] == k - 1 for k in range(n)):
        return ["#define KD_SOLVE 1"]
    return ["#define KD_SOLVE 2",
            f"static const int kd_parent[{n}] = {{{', '.join(map(str, parent))}}};"]


#: speeds from which a tree-structured model is solved by the articulated-body
#: pass (``KD_SOLVE 3``) instead of evaluating and factoring M: below, the
#: straight-line M (o^2 entries) costs less than the twists and inertias of the
#: pass (16 o values) and its set-up (measured on chain3d: the pass is 1.3x slower
#: at o = 2, 1.07x at 10, 0.91x at 15, 0.83x at 30)
TREE_MIN_SPEEDS = 12


def speed_tree_outputs(tree, qdot, force, sub):
    """Outputs of the ``tree`` function, or ``None`` below :data:`TREE_MIN_SPEEDS`.

    Parameters
    ----------
    tree : dict or None
        The mass matrix as a tree of speeds (``EquationsOfMotion._speed_tree``).
    qdot, force : sequence of expressions
        q' (n) and the forcing f (o) of the dynamics.
    sub : callable
        Substitution of the specified inputs into an expression.

    Returns
    -------
    (outputs, (parent, order)) or None
        ``outputs``: q' (n), f (o), the partial twists S (6 o) and the attached
        spatial inertias (10 o).
    """
    o = len(force)
    if tree is None or o < TREE_MIN_SPEEDS or len(tree["parent"]) != o:
        return None
    outputs = [((len(qdot),), [sub(e) for e in qdot]), ((o,), [sub(e) for e in force]),
               ((6 * o,), [sub(e) for twist in tree["S"] for e in twist]),
               ((10 * o,), [sub(e) for inertia in tree["inertia"] for e in inertia])]
    return outputs, (tuple(tree["parent"]), tuple(tree["order"]))


CODEGEN_VERSION = "kanedyn-c-3"  # change when generated code changes meaning
# the runtime and integrator templates are part of every module: part of its key
_TEMPLATES_DIGEST = hashlib.sha256("".join(
    (_c_runtime.HEADER, _c_runtime.RUNTIME, _c_integrator.INTEGRATOR, _c_runtime.FOOTER,
     _c_contact.CONTACT, _c_runtime.LANE_RUNTIME)
).encode()).hexdigest()[:16]


def fingerprint(program, functions, sizes, cse=True):
    """Deterministic text identifying what a module computes (its cache key).

    The C source itself is not deterministic across processes (SymPy's common
    subexpression elimination iterates over hash-ordered sets), so the key is
    the program before elimination, written with positional names by
    :func:`_structure` (a walk of the expression trees: no expression is
    rebuilt or printed by SymPy, which for large programs took seconds).
    """
    parts = [CODEGEN_VERSION, _TEMPLATES_DIGEST, repr(sorted(sizes.items())), f"cse={cse}",
             f"lanes={_c_lanes.LANES}"]
    for name, (arguments, outputs) in functions.items():
        names = {program.t: "t"}
        for arg, symbols in arguments.items():
            parts.append(f"{arg}:{len(symbols)}")
            names.update((s, f"{arg}{i}") for i, s in enumerate(symbols))
        flat = [sm.sympify(e) for _, exprs in outputs for e in exprs]
        needed = program.needed(flat)
        names.update((s, f"z{k}") for k, s in enumerate(needed))
        memo = {}
        parts.append(f"function {name}")
        parts.extend(_structure(program.definition(s), names, memo) for s in needed)
        for shape, exprs in outputs:
            parts.append(repr(shape))
            parts.extend(_structure(sm.sympify(e), names, memo) for e in exprs)
    return "\n".join(parts)


_ORDERLESS = (sm.Add, sm.Mul)


def _structure(expr, names, memo):
    """Text of an expression tree with the symbols in ``names`` renamed.

    Independent of the original symbols' names: the arguments of sums and
    products are listed in the order of their texts.  Numbers are exact
    (a Float's binary mantissa and exponent).
    """
    text = memo.get(expr)
    if text is not None:
        return text
    if expr in names:
        text = names[expr]
    elif isinstance(expr, sm.Float):
        text = f"F{expr._mpf_!r}"
    elif isinstance(expr, sm.Rational):
        text = f"Q{expr.p}/{expr.q}"
    elif not expr.args:
        text = f"{type(expr).__name__}:{expr}"
    else:
        args = [_structure(a, names, memo) for a in expr.args]
        if isinstance(expr, _ORDERLESS):
            args.sort()
        text = f"{type(expr).__name__}({','.join(args)})"
    memo[expr] = text
    return text


def generate_c(program, functions, sizes, describe=str, cse=True):
    """C source template of an extension module (see :func:`load_module`).

    Parameters
    ----------
    program : Program
    functions : dict
        ``{name: (arguments, outputs)}`` as for
        :func:`kanedyn.numerics.backends.generate_python`; must contain
        ``"dynamics"`` with the six outputs of the right-hand side.
    sizes : dict
        ``n_q, n_u, n_q_dep, n_u_dep, n_p, n_r`` (inputs of the dynamics).
    describe : callable, optional
        ``describe(expr)``: text of an expression for error messages (in the
        model's own symbols).
    cse : bool
        Eliminate common subexpressions jointly first (:meth:`Program.listing`).
    """
    parts, work = [], 0
    lanes = _lanes_wanted(functions, sizes)
    for name, (arguments, outputs) in functions.items():
        listing = None
        if lanes and name == "dynamics":  # one listing for both versions
            flat = [sm.sympify(e) for _, exprs in outputs for e in exprs]
            listing = program.listing(flat, cse=cse)
            src, w = _c_lanes.lanes_source(program, arguments, outputs, listing, describe,
                                           CHUNK)
            lanes = [f"#define KD_LANES {_c_lanes.LANES}", f"#define KD_NWL {w}",
                     _c_runtime.LANE_RUNTIME, src]
        src, w = _function_source(program, name, arguments, outputs, describe, cse, listing)
        parts.append(src)
        work = max(work, w)
    parts.extend(lanes or [])
    defines = [f"#define KD_NQ {sizes['n_q']}", f"#define KD_NU {sizes['n_u']}",
               f"#define KD_NQDEP {sizes['n_q_dep']}",
               f"#define KD_NUDEP {sizes['n_u_dep']}", f"#define KD_NP {sizes['n_p']}",
               f"#define KD_NR {sizes['n_r']}", f"#define KD_NW {work}",
               f"#define KD_MODULE_NAME_STR \"{NAME_TOKEN}\"",
               f"#define KD_INIT_FUNCTION PyInit_{NAME_TOKEN}",
               *solver_source(functions, sizes)]
    wrappers = []
    table = []
    for name, (arguments, outputs) in functions.items():
        wrappers.append(_wrapper_source(name, outputs, len(arguments.get("r", ()))))
        table.append(f'    {{"{name}", (PyCFunction)(void (*)(void))kd_py_{name}, '
                     'METH_FASTCALL, NULL},')
    contact = []
    if "contacts" in functions:  # the compiled contact segments (_c_contact)
        defines.append(f"#define KD_NC {len(functions['contacts'][1][0][1])}")
        contact.append(_c_contact.CONTACT)
        table.append('    {"contact_segment", (PyCFunction)kd_py_contact_segment, '
                     'METH_VARARGS, NULL},')
    defines.append("#define KD_FUNCTION_TABLE \\\n" + " \\\n".join(table))
    return "\n".join([_c_runtime.HEADER, *defines, *parts, _c_runtime.RUNTIME,
                      _c_integrator.INTEGRATOR, *contact, *wrappers, _c_runtime.FOOTER])


def _lanes_wanted(functions, sizes):
    """Whether the module gets the lane-wise dynamics of ``rhs_batch`` (``_c_lanes``).

    Not for dependent speeds (their reduced system is solved by LU; such
    batches go one row at a time) nor with :data:`_c_lanes.LANES` = 0.
    """
    if _c_lanes.LANES <= 0 or sizes.get("n_u_dep", 0) or "dynamics" not in functions:
        return False
    arguments, outputs = functions["dynamics"]
    return set(arguments) <= {"y", "p", "r"} and len(outputs) >= 3


# ------------------------------------------------------------ build, cache
def cache_dir():
    """Directory of compiled modules."""
    env = os.environ.get("KANEDYN_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "kanedyn"


def _cache_origin():
    if os.environ.get("KANEDYN_CACHE_DIR"):
        return "$KANEDYN_CACHE_DIR"
    return "$XDG_CACHE_HOME/kanedyn" if os.environ.get("XDG_CACHE_HOME") else "~/.cache/kanedyn"


def compiler_command():
    """The C compiler command as a list, or ``None`` when none is available."""
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    parts = shlex.split(cc)
    if not parts or shutil.which(parts[0]) is None:
        return None
    return parts


def missing_compiler_text():
    """Why no compiler is available (names ``$CC`` when it is set)."""
    cc = os.environ.get("CC")
    if cc:
        return f"$CC is {cc!r}, which is not a program on this machine"
    return "no C compiler found (set $CC or install gcc or clang)"


_FLAGS = ["-O2", "-fPIC", "-shared", "-std=gnu11", "-fno-math-errno", "-w"]
_STALE_BUILD = 3600.0  # s: a build-* folder this old was left by a killed build
_PRIVATE = []  # this process's private cache directory, when the shared one is unusable


def _build_key(source, command):
    digest = hashlib.sha256()
    for part in (source, " ".join(command + _FLAGS), sys.version, np.__version__,
                 sysconfig.get_config_var("EXT_SUFFIX") or ""):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:24]


def _checksum(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _load(name, path):
    loader = importlib.machinery.ExtensionFileLoader(name, str(path))
    spec = importlib.util.spec_from_file_location(name, str(path), loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def load_module(key_text, make_template, timeout=600):
    """Compile (or fetch from the cache) and import a generated module.

    Parameters
    ----------
    key_text : str
        What the module computes (:func:`fingerprint`); its hash names the
        module and its cache entry.
    make_template : callable
        ``make_template() -> str``: the C source, in which :data:`NAME_TOKEN`
        stands for the module name; called only when the module is not cached.

    A cache directory that cannot be written (read-only, or a path that is a
    file) is used read-only where it holds a valid entry; otherwise the
    module is built in a private directory of this process, with a warning.

    Raises
    ------
    CompilerError
        No compiler, or compilation failed (with the compiler's message).
    """
    command = compiler_command()
    if command is None:
        raise CompilerError(missing_compiler_text())
    key = _build_key(key_text, command)
    name = f"_kd_{key}"
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    with _LOCK:
        module = _LOADED.get(key)
        if module is not None:
            return module
        directory = cache_dir()
        problem = _unwritable(directory)
        if problem is not None:
            module = _try_cached(name, directory / f"{name}{suffix}",
                                 directory / f"{name}.json", repair=False)
            if module is None:
                directory = _private_cache(f"the cache directory {directory} "
                                           f"({_cache_origin()}) {problem}")
        if module is None:
            _remove_stale_builds(directory, timeout)
            so_path = directory / f"{name}{suffix}"
            manifest = directory / f"{name}.json"
            with _FileLock(directory / f"{name}.lock"):
                module = _try_cached(name, so_path, manifest)
                if module is None:
                    _build(make_template().replace(NAME_TOKEN, name), command, so_path,
                           manifest, directory, timeout)
                    module = _load(name, so_path)
        _LOADED[key] = module
        return module


def _unwritable(directory):
    """Why modules cannot be written to ``directory`` (``None`` when they can)."""
    if directory.exists() and not directory.is_dir():
        return "is a file, not a directory"
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".probe-"):
            pass
    except OSError as exc:
        return f"cannot be written ({exc.strerror or exc})"
    return None


def _private_cache(reason):
    """This process's private cache directory (created and announced once)."""
    if not _PRIVATE:
        import atexit
        path = Path(tempfile.mkdtemp(prefix="kanedyn-cache-"))
        atexit.register(shutil.rmtree, path, True)
        _PRIVATE.append(path)
        warnings.warn(f"{reason}; compiled modules are built in {path} for this process "
                      "only (set KANEDYN_CACHE_DIR to a writable directory to keep them)",
                      RuntimeWarning, stacklevel=4)
    return _PRIVATE[0]


def _remove_stale_builds(directory, timeout):
    """Remove the ``build-*`` folders that killed builds left behind."""
    import time
    limit = time.time() - max(_STALE_BUILD, 2 * timeout)
    for path in directory.glob("build-*"):
        try:
            if path.is_dir() and path.stat().st_mtime < limit:
                shutil.rmtree(path, ignore_errors=True)
        except OSError:
            pass


class _FileLock:
    """Exclusive advisory lock on a file (POSIX ``flock``; a no-op elsewhere)."""

    def __init__(self, path):
        self.path = path
        self.handle = None

    def __enter__(self):
        self.handle = open(self.path, "a+")  # noqa: SIM115
        try:
            import fcntl
            fcntl.flock(self.handle, fcntl.LOCK_EX)
        except ImportError:  # pragma: no cover  (non-POSIX)
            pass
        return self

    def __exit__(self, *exc):
        self.handle.close()  # closing releases the lock


def _try_cached(name, so_path, manifest, repair=True):
    """The cached module, if its entry is complete and passes its checksum.

    A corrupt or stale entry is removed (``repair``) so that it is rebuilt.
    """
    if not (so_path.exists() and manifest.exists()):
        return None
    try:
        recorded = json.loads(manifest.read_text())["sha256"]
        if recorded != _checksum(so_path):
            raise ValueError("checksum mismatch")
        return _load(name, so_path)
    except Exception:  # noqa: BLE001  corrupt or stale entry: rebuild it
        for path in (so_path, manifest) if repair else ():
            try:
                path.unlink()
            except OSError:
                pass
        return None


#: what this process did (read by tests): ``compiles``, compiler runs
STATS = {"compiles": 0}


def _build(source, command, so_path, manifest, directory, timeout):
    STATS["compiles"] += 1
    includes = [sysconfig.get_paths()["include"], np.get_include()]
    with tempfile.TemporaryDirectory(dir=directory, prefix="build-") as tmp:
        c_path = Path(tmp) / "module.c"
        c_path.write_text(source)
        out_path = Path(tmp) / so_path.name
        cmd = (command + _FLAGS + [f"-I{d}" for d in includes]
               + [str(c_path), "-o", str(out_path), "-lm"])
        origin = " ($CC)" if os.environ.get("CC") else ""
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise CompilerError(f"the C compiler {command[0]}{origin} did not finish in "
                                f"{timeout} s") from None
        except OSError as exc:
            raise CompilerError(f"could not run the C compiler {command[0]}{origin}: "
                                f"{exc}") from None
        if proc.returncode != 0 or not out_path.exists():
            said = (proc.stderr or proc.stdout).strip()
            raise CompilerError(
                f"the C compiler {' '.join(command)}{origin} failed (exit status "
                f"{proc.returncode})" + (":\n" + said[-4000:] if said else
                                         " and printed nothing: it does not look like a "
                                         "working C compiler; set $CC to gcc or clang, or "
                                         "use backend='numpy'"))
        checksum = _checksum(out_path)
        os.replace(out_path, so_path)
        tmp_manifest = Path(tmp) / "manifest.json"
        tmp_manifest.write_text(json.dumps({"sha256": checksum, "source_bytes": len(source)}))
        os.replace(tmp_manifest, manifest)
