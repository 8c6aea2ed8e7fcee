r"""Large arrays mapped for the solve: resident memory that follows the
arrays alive.

glibc serves a freed array of a few MB again from its heap once its mmap
threshold has risen past that size (it rises to the largest block freed,
up to 32 MiB), and a heap shrinks only from its top: arrays still alive
above freed ones keep those resident.  On the swing-up between 1 and 2
million nodes the resident memory grew by 29–61 bytes a node more with
NumPy's allocator than with this module (`docs/benchmarks.md`).  So, while
the interior point runs, NumPy's arrays of :data:`MAPPED_BYTES` or more are
given a memory handler of their own
(NumPy's ``PyDataMem_SetHandler``, scoped to the calling context; each array
keeps the handler it was made with, and frees through it when it goes):
each such array its own anonymous mapping, handed back to the system when
the array goes; smaller ones from the handler that was in force.

A mapping made afresh is faulted in page by page (the kernel zeroes each
page): the interior point makes and frees arrays of the same sizes every
iteration, so freed mappings are kept (up to :data:`CACHED_BLOCKS`) and a
new array of the same mapped length takes one; a new array that finds none
first hands back kept mappings, the oldest first, until as many bytes as
its own are (or none is left), then maps its own.  So the resident memory
(the arrays alive and the mappings kept) does not grow at a new mapping
unless the arrays alive need it: its peak is theirs, while most arrays
take a mapping already faulted in.  Mappings are advised as huge pages
where NumPy advises its own (``_get_madvise_hugepage`` of NumPy's core).

:func:`mapped_large_arrays` is the context; it does nothing without a C
compiler or on a NumPy without the handler API (before 1.22), or off
POSIX.  The C source is fixed and compiled once like the KKT kernel's.
"""

from __future__ import annotations

import contextlib
import os

__all__ = ["mapped_large_arrays", "MAPPED_BYTES", "CACHED_BLOCKS", "HANDLER_NAME", "SOURCE"]

#: arrays of this many bytes or more get their own mapping (NumPy's own size
#: for advising huge pages)
MAPPED_BYTES = 1 << 22

#: freed mappings kept for arrays of the same mapped length
CACHED_BLOCKS = 8

#: the handler's name (NumPy's ``get_handler_name``)
HANDLER_NAME = "kanedyn_mapped_large_arrays"

#: changes whenever the source's meaning changes (part of the cache key)
_GENERATION = "kanedyn mapped arrays 2"

SOURCE = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#define KD_MAPPED ((size_t)@MAPPED@)
#define KD_CACHED @CACHED@
#define KD_HEADER ((size_t)64)   /* a mapping's length before its array */
#define KD_REGISTRY 4096         /* places for the mappings alive (a power of 2) */

/* NumPy's memory handler (NEP 49; numpy/ndarraytypes.h, version 1) */
typedef struct {
    void *ctx;
    void *(*malloc)(void *ctx, size_t size);
    void *(*calloc)(void *ctx, size_t nelem, size_t elsize);
    void *(*realloc)(void *ctx, void *ptr, size_t new_size);
    void (*free)(void *ctx, void *ptr, size_t size);
} kd_allocator;

typedef struct {
    char name[127];
    uint8_t version;
    kd_allocator allocator;
} kd_handler;

/* one handler: NumPy's struct, the handler in force before it (its capsule
   held: the smaller arrays' allocator) and whether mappings are advised as
   huge pages */
typedef struct {
    kd_handler handler;
    PyObject *base_capsule;
    kd_allocator base;
    int huge;
} kd_context;

/* the process's mappings alive (by their arrays' addresses) and those kept
   for reuse (their mapping's start and length), under one lock */
static pthread_mutex_t kd_lock = PTHREAD_MUTEX_INITIALIZER;
static void *kd_alive[KD_REGISTRY];
static Py_ssize_t kd_n_alive = 0;
static char *kd_kept[KD_CACHED];
static size_t kd_kept_length[KD_CACHED];
static int kd_n_kept = 0;
static int kd_open = 0;  /* contexts open (begin, end): none, none kept */

static size_t kd_slot(void *p) {
    return (size_t)(((uintptr_t)p >> 6) * 0x9E3779B97F4A7C15ull) & (KD_REGISTRY - 1);
}

/* the registry (open addressing, deletion by moving back): under kd_lock */
static int kd_register(void *p) {
    if (kd_n_alive >= KD_REGISTRY / 2) return 0;
    size_t i = kd_slot(p);
    while (kd_alive[i] != NULL) i = (i + 1) & (KD_REGISTRY - 1);
    kd_alive[i] = p;
    kd_n_alive++;
    return 1;
}

/* the place of p in the registry, or of the empty one where its probe ends */
static size_t kd_find(void *p) {
    size_t i = kd_slot(p);
    while (kd_alive[i] != NULL && kd_alive[i] != p) i = (i + 1) & (KD_REGISTRY - 1);
    return i;
}

static int kd_unregister(void *p) {
    size_t i = kd_find(p);
    if (kd_alive[i] == NULL) return 0;
    kd_alive[i] = NULL;
    kd_n_alive--;
    for (size_t j = (i + 1) & (KD_REGISTRY - 1); kd_alive[j] != NULL;
         j = (j + 1) & (KD_REGISTRY - 1)) {
        void *q = kd_alive[j];
        kd_alive[j] = NULL;
        size_t k = kd_slot(q);
        while (kd_alive[k] != NULL) k = (k + 1) & (KD_REGISTRY - 1);
        kd_alive[k] = q;
    }
    return 1;
}

static size_t kd_length(size_t size) {
    size_t page = (size_t)sysconf(_SC_PAGESIZE);
    return (size + KD_HEADER + page - 1) / page * page;
}

/* kept mapping k taken out of the list (the others keep their order, the
   oldest first): under kd_lock */
static void kd_take_kept(int k) {
    for (int j = k + 1; j < kd_n_kept; j++) {
        kd_kept[j - 1] = kd_kept[j];
        kd_kept_length[j - 1] = kd_kept_length[j];
    }
    kd_n_kept--;
}

/* the oldest kept mappings handed back until `need` bytes are (or none is
   left): under kd_lock */
static void kd_release_kept(size_t need) {
    size_t released = 0;
    while (kd_n_kept > 0 && released < need) {
        munmap(kd_kept[0], kd_kept_length[0]);
        released += kd_kept_length[0];
        kd_take_kept(0);
    }
}

/* an array of `size` bytes in a mapping of its own: a kept one of the same
   length, else a new one after kept ones of as many bytes (the oldest) are
   handed back, so that the resident memory does not grow unless the arrays
   alive need it; *fresh: 1 if new (its pages zero).  NULL if none could be
   made or registered. */
static void *kd_map(kd_context *c, size_t size, int *fresh) {
    size_t length = kd_length(size);
    char *start = NULL;
    pthread_mutex_lock(&kd_lock);
    for (int k = 0; k < kd_n_kept; k++) {
        if (kd_kept_length[k] == length) {
            start = kd_kept[k];
            kd_take_kept(k);
            *fresh = 0;
            break;
        }
    }
    if (start == NULL) {
        kd_release_kept(length);
        void *m = mmap(NULL, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
                       -1, 0);
        if (m != MAP_FAILED) {
            start = m;
            *fresh = 1;
#ifdef MADV_HUGEPAGE
            if (c->huge) madvise(start, length, MADV_HUGEPAGE);
#endif
            *(size_t *)start = length;
        }
    }
    if (start != NULL && !kd_register(start + KD_HEADER)) {
        munmap(start, length);
        start = NULL;
    }
    pthread_mutex_unlock(&kd_lock);
    return start == NULL ? NULL : start + KD_HEADER;
}

/* whether p is a mapped array's (then let go: kept, or handed back when
   CACHED are kept) */
static int kd_unmap(void *p) {
    if (p == NULL) return 0;
    pthread_mutex_lock(&kd_lock);
    int mine = kd_unregister(p);
    if (mine) {
        char *start = (char *)p - KD_HEADER;
        size_t length = *(size_t *)start;
        if (kd_open == 0) {  /* an array that outlived its context: handed back */
            munmap(start, length);
            pthread_mutex_unlock(&kd_lock);
            return 1;
        }
        if (kd_n_kept == KD_CACHED) kd_release_kept(1);  /* the oldest */
        kd_kept[kd_n_kept] = start;
        kd_kept_length[kd_n_kept++] = length;
    }
    pthread_mutex_unlock(&kd_lock);
    return mine;
}

static void *kd_malloc(void *ctx, size_t size) {
    kd_context *c = ctx;
    int fresh;
    void *p = size >= KD_MAPPED ? kd_map(c, size, &fresh) : NULL;
    return p != NULL ? p : c->base.malloc(c->base.ctx, size);
}

static void *kd_calloc(void *ctx, size_t nelem, size_t elsize) {
    kd_context *c = ctx;
    if (elsize != 0 && nelem > (size_t)-1 / elsize) return NULL;
    size_t size = nelem * elsize;
    int fresh;
    void *p = size >= KD_MAPPED ? kd_map(c, size, &fresh) : NULL;
    if (p == NULL) return c->base.calloc(c->base.ctx, nelem, elsize);
    if (!fresh) memset(p, 0, size);
    return p;
}

static void kd_free(void *ctx, void *p, size_t size) {
    kd_context *c = ctx;
    if (size >= KD_MAPPED && kd_unmap(p)) return;
    c->base.free(c->base.ctx, p, size);
}

static void *kd_realloc(void *ctx, void *p, size_t new_size) {
    kd_context *c = ctx;
    if (p == NULL) return kd_malloc(ctx, new_size);
    pthread_mutex_lock(&kd_lock);
    size_t held = kd_alive[kd_find(p)] == NULL ? 0
                  : *(size_t *)((char *)p - KD_HEADER) - KD_HEADER;
    pthread_mutex_unlock(&kd_lock);
    if (held == 0) return c->base.realloc(c->base.ctx, p, new_size);
    if (new_size <= held && new_size >= KD_MAPPED) return p;
    void *q = kd_malloc(ctx, new_size ? new_size : 1);
    if (q == NULL) return NULL;
    memcpy(q, p, new_size < held ? new_size : held);
    kd_unmap(p);
    return q;
}

static void kd_destroy(PyObject *capsule) {
    kd_context *c = PyCapsule_GetPointer(capsule, "mem_handler");
    if (c == NULL) {
        PyErr_Clear();
        return;
    }
    Py_XDECREF(c->base_capsule);
    free(c);
}

/* NumPy's C API table from its capsule (checked by the caller's version) */
static void **kd_api(PyObject *capsule) {
    return (void **)PyCapsule_GetPointer(capsule, NULL);
}

/* handler(api, huge): a new handler (a "mem_handler" capsule) whose smaller
   arrays go to the handler in force now */
static PyObject *kd_new_handler(PyObject *self, PyObject *args) {
    PyObject *api_capsule;
    int huge;
    if (!PyArg_ParseTuple(args, "Op", &api_capsule, &huge)) return NULL;
    void **api = kd_api(api_capsule);
    if (api == NULL) return NULL;
    PyObject *(*get_handler)(void) = (PyObject *(*)(void))api[305];
    PyObject *base = get_handler();
    if (base == NULL) return NULL;
    kd_handler *b = PyCapsule_GetPointer(base, "mem_handler");
    if (b == NULL) {
        Py_DECREF(base);
        return NULL;
    }
    kd_context *c = calloc(1, sizeof(kd_context));
    if (c == NULL) {
        Py_DECREF(base);
        return PyErr_NoMemory();
    }
    strcpy(c->handler.name, "@HANDLER@");
    c->handler.version = 1;
    c->handler.allocator = (kd_allocator){c, kd_malloc, kd_calloc, kd_realloc, kd_free};
    c->base_capsule = base;
    c->base = b->allocator;
    c->huge = huge;
    PyObject *capsule = PyCapsule_New(c, "mem_handler", kd_destroy);
    if (capsule == NULL) {
        Py_DECREF(base);
        free(c);
    }
    return capsule;
}

/* set_handler(api, handler): NumPy's handler for this context set to
   `handler` (None: NumPy's default); returns the one in force before */
static PyObject *kd_set_handler(PyObject *self, PyObject *args) {
    PyObject *api_capsule, *handler;
    if (!PyArg_ParseTuple(args, "OO", &api_capsule, &handler)) return NULL;
    void **api = kd_api(api_capsule);
    if (api == NULL) return NULL;
    PyObject *(*set_handler)(PyObject *) = (PyObject *(*)(PyObject *))api[304];
    return set_handler(handler == Py_None ? NULL : handler);
}

/* begin(): a context opens (freed mappings are kept while one is) */
static PyObject *kd_begin(PyObject *self, PyObject *args) {
    pthread_mutex_lock(&kd_lock);
    kd_open++;
    pthread_mutex_unlock(&kd_lock);
    Py_RETURN_NONE;
}

/* end(): a context closes; with none open, the kept mappings handed back */
static PyObject *kd_end(PyObject *self, PyObject *args) {
    pthread_mutex_lock(&kd_lock);
    if (kd_open > 0) kd_open--;
    if (kd_open == 0) kd_release_kept((size_t)-1);
    pthread_mutex_unlock(&kd_lock);
    Py_RETURN_NONE;
}

/* counts(): (mappings alive, mappings kept) */
static PyObject *kd_counts(PyObject *self, PyObject *args) {
    pthread_mutex_lock(&kd_lock);
    Py_ssize_t alive = kd_n_alive;
    int kept = kd_n_kept;
    pthread_mutex_unlock(&kd_lock);
    return Py_BuildValue("ni", alive, kept);
}

static PyMethodDef kd_methods[] = {
    {"handler", kd_new_handler, METH_VARARGS, "a new handler"},
    {"set_handler", kd_set_handler, METH_VARARGS, "set NumPy's handler; the one before"},
    {"begin", kd_begin, METH_NOARGS, "a context opens"},
    {"end", kd_end, METH_NOARGS, "a context closes"},
    {"counts", kd_counts, METH_NOARGS, "(mappings alive, kept)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef kd_module = {PyModuleDef_HEAD_INIT, "@NAME@", NULL, -1,
                                       kd_methods};

PyMODINIT_FUNC PyInit_@NAME@(void) { return PyModule_Create(&kd_module); }
""".replace("@MAPPED@", str(MAPPED_BYTES)).replace("@CACHED@", str(CACHED_BLOCKS)).replace(
    "@HANDLER@", HANDLER_NAME)


def _core():
    """NumPy's compiled core module (``numpy._core``'s, ``numpy.core``'s in 1.x)."""
    try:
        from numpy._core import _multiarray_umath as core
    except ImportError:  # NumPy 1.x
        from numpy.core import _multiarray_umath as core
    return core


def _numpy_api():
    """NumPy's C API capsule, or ``None`` before NumPy 1.22 (no handlers)."""
    import numpy as np
    if np.lib.NumpyVersion(np.__version__) < "1.22.0":
        return None
    return getattr(_core(), "_ARRAY_API", None)


def _current_handler():
    """The name of NumPy's memory handler in force in this context."""
    return _core().get_handler_name()


def _huge_pages():
    """Whether NumPy advises huge pages for its own large arrays."""
    get = getattr(_core(), "_get_madvise_hugepage", None)
    return bool(get()) if get is not None else False


def module():
    """The compiled module, or ``None`` where it cannot be (no C compiler,
    not POSIX, no handler API)."""
    if os.name != "posix" or _numpy_api() is None:
        return None
    from ...numerics import CompilerError, load_fixed_module
    try:
        return load_fixed_module(_GENERATION, SOURCE)
    except CompilerError:
        return None


@contextlib.contextmanager
def mapped_large_arrays(enabled=True):
    """NumPy's arrays of :data:`MAPPED_BYTES` or more made in this context
    each in a mapping of its own (the module's docstring); on leaving, the
    handler in force before is restored and, with no other such context
    open, the kept mappings are handed back (an array that outlives the
    context hands its mapping back when it goes).  Does nothing when
    ``enabled`` is false, :func:`module` is ``None``, or inside another such
    context (its handler in force)."""
    compiled = module() if enabled else None
    if compiled is None or _current_handler() == HANDLER_NAME:
        yield
        return
    api = _numpy_api()
    previous = compiled.set_handler(api, compiled.handler(api, _huge_pages()))
    compiled.begin()
    try:
        yield
    finally:
        compiled.set_handler(api, previous)
        compiled.end()
