"""Events compiled for the ensemble: a small module of their own, one per set of events.

:func:`compiled_events` turns event expressions (SymPy, in symbols that stand for
the time, entries of the state, the constants and the inputs) into one C function
that evaluates all of them, ``g = events(t, y, p, r)``, common subexpressions
eliminated, printed as the model's generated code is.  It is built into an extension
module of its own (cached as the models' modules are, by the hash of its source)
whose ``events`` is a capsule (``"kanedyn.events"``) of the table
:data:`~._c_ensemble.EVENT_TABLE`: the model's sizes and the function.  A model's
``integrate_many`` takes that capsule and calls the function from its threads, with
each trajectory's constants and inputs: no Python between the steps.  The model's
own module is not built again for a new set of events.
"""

from __future__ import annotations

import sympy as sm

from ._c import _CPrinter, _print_c
from ._c_build import NAME_TOKEN, load_module
from ._c_ensemble import EVENT_TABLE
from ._c_runtime import PRELUDE

__all__ = ["compiled_events"]

_MODULE = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
%(prelude)s
%(table)s
/* the values of the %(count)d event(s) at (t, y), constants p, inputs r */
static void kd_events(double t, const double *y, const double *p, const double *r,
                      double *g) {
%(body)s
    (void)t; (void)y; (void)p; (void)r;
}

static const KdEventTable kd_event_table = {%(nx)d, %(np)d, %(nr)d, %(count)d, kd_events};

static struct PyModuleDef kd_events_module = {PyModuleDef_HEAD_INIT, "%(name)s", NULL, -1,
                                              NULL};

PyMODINIT_FUNC PyInit_%(name)s(void) {
    PyObject *module = PyModule_Create(&kd_events_module);
    if (module == NULL) return NULL;
    PyObject *table = PyCapsule_New((void *)&kd_event_table, "kanedyn.events", NULL);
    if (table == NULL || PyModule_AddObject(module, "events", table) < 0) {
        Py_XDECREF(table);
        Py_DECREF(module);
        return NULL;
    }
    return module;
}
"""


def _body(expressions, names, labels):
    """C statements setting ``g[k]`` to ``expressions[k]`` (``names``: C text of each
    symbol; ``labels``: how the errors name each event)."""
    names = dict(names)
    helpers = sm.numbered_symbols("kd_event_x", cls=sm.Dummy)
    shared, reduced = sm.cse(list(expressions), symbols=helpers, order="none")
    printer = _CPrinter(names)  # reads ``names`` as it grows
    lines = []
    for k, (symbol, value) in enumerate(shared):
        code = _print_c(printer, value, "a subexpression of the events")
        lines.append(f"    const double x{k} = {code};")
        names[symbol] = f"x{k}"
    for k, (expression, label) in enumerate(zip(reduced, labels)):
        lines.append(f"    g[{k}] = {_print_c(printer, expression, f'event {label}')};")
    return "\n".join(lines)


def compiled_events(expressions, names, sizes, labels):
    """The capsule of the compiled events.

    Parameters
    ----------
    expressions : sequence of sympy.Expr
        One per event, in symbols of ``names`` only.
    names : dict
        ``{symbol: C text}``: ``"t"``, ``"y[i]"``, ``"p[k]"`` or ``"r[j]"``.
    sizes : (int, int, int)
        The model's states, constants and inputs (``integrate_many`` refuses
        events made for other sizes).
    labels : sequence of str
        The events' names, for errors.

    Returns
    -------
    PyCapsule
        ``"kanedyn.events"``: for the model's ``integrate_many``.

    Raises
    ------
    CodegenError
        An expression C cannot evaluate (naming the event).
    CompilerError
        No C compiler, or the compilation failed.
    """
    nx, n_p, nr = sizes
    source = _MODULE % dict(prelude=PRELUDE, table=EVENT_TABLE, count=len(expressions),
                            body=_body(expressions, names, labels), nx=nx, np=n_p, nr=nr,
                            name=NAME_TOKEN)
    return load_module("kanedyn events\n" + source, lambda: source).events
