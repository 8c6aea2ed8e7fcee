"""C source of the ensemble integrator (part of every generated module).

``Model.integrate_many`` integrates N trajectories of one model, each with its
own initial state, constants and input record, with the compiled loop's RK45
(the same attempt, initial step, step-size control, quartic continuous
extension at the output times and projection of constraint drift: a
trajectory's numbers are those of ``integrate`` with the same options), on
POSIX threads without Python: the trajectories are taken one at a time by the
threads, Python's lock released.  The inputs of a trajectory are constants or a
record on a time grid shared by all, interpolated linearly (NumPy's ``interp``
formula).

Events come compiled, in a module of their own (:mod:`._c_events`: the capsule of an
:data:`EVENT_TABLE`, one function evaluating all of them with the trajectory's
constants and inputs), with a direction and a terminal flag each; a trajectory locates
them as the compiled loop does (``kd_brent`` on the step's continuous extension, the
roots in time order up to the first terminal one, which ends it there) and keeps
those it met in a buffer of its own, returned trajectory by trajectory.

While the threads work, the calling thread waits for them, waking at least
every ``KD_ENS_POLL`` seconds to take Python's signals: a Ctrl-C (or the run's stop flag) stops every
trajectory at its next step, and what was computed is returned, as a time
limit does.  Memory: the outputs asked for, and per thread one work array.
"""

#: the compiled events' table (the capsule "kanedyn.events" of a module of events,
#: :func:`kanedyn.numerics.backends._c_events.compiled_events`): the sizes of the model
#: it was made for, and the function evaluating every event at once
EVENT_TABLE = r"""
typedef void (*KdEventFn)(double t, const double *y, const double *p, const double *r,
                          double *g);
typedef struct { int nx, np, nr, count; KdEventFn fn; } KdEventTable;
"""

ENSEMBLE = r"""
/* ------------------------------------------------------------------------
   Ensembles: many trajectories of the compiled RK45 at once, in threads
   ------------------------------------------------------------------------ */
#define KD_ENS_POLL 0.02  /* seconds between the calling thread's looks at signals */

enum { KD_ENS_DONE = 0, KD_ENS_SMALL_STEP = 1, KD_ENS_PROJECTION = 2, KD_ENS_STOPPED = 3,
       KD_ENS_TIMED_OUT = 4, KD_ENS_TERMINAL = 5, KD_ENS_NO_MEMORY = 6 };

@EVENT_TABLE@

/* one trajectory's right-hand side: its constants, inputs and work */
typedef struct {
    const double *p;         /* constants (KD_NP) */
    const double *r_times;   /* the input record's times (r_count); NULL: constant inputs */
    const double *r_values;  /* (r_count, KD_NR), or (KD_NR) for constant inputs */
    npy_intp r_count;
    double *work;
    long nfev;
    int singular;            /* the derivative failed (singular, not finite) at t_singular */
    double t_singular;
} KdEnsRhs;

/* the inputs at t: linear between the record's samples (np.interp's formula) */
static void kd_ens_inputs(const KdEnsRhs *c, double t, double *r) {
#if KD_HAS_R
    const double *T = c->r_times, *R = c->r_values;
    npy_intp k = c->r_count;
    if (T == NULL || k == 1 || t <= T[0]) { memcpy(r, R, sizeof(double) * KD_NR); return; }
    if (t >= T[k - 1]) { memcpy(r, R + (k - 1) * KD_NR, sizeof(double) * KD_NR); return; }
    npy_intp lo = 0, hi = k - 1;  /* T[lo] <= t < T[hi] */
    while (hi - lo > 1) {
        npy_intp mid = lo + (hi - lo) / 2;
        if (T[mid] <= t) lo = mid; else hi = mid;
    }
    for (int i = 0; i < KD_NR; ++i) {
        const double a = R[lo * KD_NR + i], b = R[hi * KD_NR + i];
        r[i] = t == T[lo] ? a : (b - a) / (T[hi] - T[lo]) * (t - T[lo]) + a;
    }
#else
    (void)c; (void)t; (void)r;
#endif
}

/* the trajectory's derivative (a KdRhsFn): non-finite values reject the step */
static int kd_ens_f(void *ctx, double t, const double *y, double *out) {
    KdEnsRhs *c = (KdEnsRhs *)ctx;
    double r[KD_SZ_R];
    c->nfev++;
    kd_ens_inputs(c, t, r);
    int bad = KD_RHS_CORE(t, y, c->p, r, c->work, out) != 0;
    for (int i = 0; i < KD_NX && !bad; ++i) bad = !isfinite(out[i]);
    if (bad) {
        for (int i = 0; i < KD_NX; ++i) out[i] = NAN;
        if (!c->singular) { c->singular = 1; c->t_singular = t; }
    }
    return 0;
}

/* what every trajectory shares */
typedef struct {
    double t0, t1, rtol, max_step, first_step, project_tol, deadline;
    const double *atol;           /* KD_NX */
    const double *t_eval;         /* n_eval output times, within [t0, t1], in order */
    npy_intp n_eval;
    const volatile int *stop;     /* raised: every trajectory ends at its next step */
    const KdEventTable *events;   /* the event functions, or NULL */
    const double *ev_dir, *ev_term;  /* per event: direction; terminal if nonzero */
} KdEnsSpec;

/* the events a trajectory met, in the order met: times, states (KD_NX each), which */
typedef struct { double *t, *y; long *which; npy_intp n, cap; } KdEnsFound;

/* one more event met: -1 when there is no memory for it */
static int kd_ens_found_push(KdEnsFound *f, double t, const double *y, int k) {
    if (f->n == f->cap) {
        npy_intp cap = f->cap ? 2 * f->cap : 16;
        double *tt = (double *)PyMem_RawRealloc(f->t, sizeof(double) * cap);
        if (tt == NULL) return -1;
        f->t = tt;
        double *yy = (double *)PyMem_RawRealloc(f->y, sizeof(double) * cap * KD_NX);
        if (yy == NULL) return -1;
        f->y = yy;
        long *ww = (long *)PyMem_RawRealloc(f->which, sizeof(long) * cap);
        if (ww == NULL) return -1;
        f->which = ww;
        f->cap = cap;
    }
    f->t[f->n] = t;
    memcpy(f->y + KD_NX * f->n, y, sizeof(double) * KD_NX);
    f->which[f->n++] = k;
    return 0;
}

/* the values of the events at (t, y) into g, the trajectory's inputs at t */
static void kd_ens_events_at(const KdEnsSpec *s, const KdEnsRhs *c, double t, const double *y,
                             double *g) {
    double r[KD_SZ_R];
    kd_ens_inputs(c, t, r);
    s->events->fn(t, y, c->p, r, g);
}

/* event k along a step's continuous extension (a KdRootFn of t): all of them evaluated
   into g */
typedef struct {
    const KdEnsSpec *s;
    const KdEnsRhs *c;
    const double *y_old, *Q;
    double t_old, h;
    int k;
    double *g;
} KdEnsAlong;
static int kd_ens_event_along(void *along, double t, double *g) {
    const KdEnsAlong *a = (const KdEnsAlong *)along;
    double y[KD_NX];
    kd_dopri_dense(a->y_old, a->t_old, a->h, a->Q, t, y);
    kd_ens_events_at(a->s, a->c, t, y, a->g);
    *g = a->g[a->k];
    return 0;
}

/* what one trajectory did */
typedef struct {
    int outcome;                  /* KD_ENS_... */
    npy_intp n_out;               /* output rows written */
    long steps, projections;
    double t_end;                 /* the last state accepted: its time */
} KdEnsOutcome;

/* one trajectory from y0: the output rows reached into out (n_eval x KD_NX), the
   state accepted last into y_end (the state before a projection that failed), the
   events met into found (located as the compiled loop locates them: the roots of
   the active events within a step by Brent's method on its continuous extension, in
   time order up to the first terminal one, which ends the trajectory there) */
static void kd_ens_run(const KdEnsSpec *s, KdEnsRhs *c, const double *y0, double *out,
                       double *y_end, KdEnsFound *found, KdEnsOutcome *o) {
    const double dir = s->t1 >= s->t0 ? 1.0 : -1.0;
    double t = s->t0, y[KD_NX], f[KD_NX], y_new[KD_NX], K[7 * KD_NX], Q[KD_NX * 4];
    double B[KD_SZ(KD_NUDEP * KD_NU)], r[KD_SZ_R], before[KD_NX];
    npy_intp next = 0;
    unsigned long count = 0;
    const int n_ev = s->events != NULL ? s->events->count : 0;
    double *g_old = NULL, *g_new = NULL, *g_work = NULL;
    memset(o, 0, sizeof(*o));
    memcpy(y, y0, sizeof(y));
    if (n_ev > 0) {
        g_old = (double *)PyMem_RawMalloc(sizeof(double) * 3 * (size_t)n_ev);
        if (g_old == NULL) {
            o->outcome = KD_ENS_NO_MEMORY;
            o->t_end = t;
            memcpy(y_end, y, sizeof(y));
            return;
        }
        g_new = g_old + n_ev;
        g_work = g_new + n_ev;
    }
    kd_ens_f(c, t, y, f);
    if (n_ev > 0) kd_ens_events_at(s, c, t, y, g_old);
    while (next < s->n_eval && s->t_eval[next] == t) memcpy(out + KD_NX * next++, y, sizeof(y));
    double interval = fabs(s->t1 - s->t0), h_abs = 0.0;
    if (s->first_step > 0) h_abs = s->first_step;
    else if (interval > 0)
        kd_first_step(kd_ens_f, c, t, y, f, dir, interval, s->rtol, s->atol, s->max_step, 4,
                      &h_abs);
    while (dir * (s->t1 - t) > 0) {
        if (*s->stop) { o->outcome = KD_ENS_STOPPED; break; }
        if ((count++ & 15) == 0 && s->deadline > 0 && kd_clock() >= s->deadline) {
            o->outcome = KD_ENS_TIMED_OUT;
            break;
        }
        double min_step = 10 * fabs(nextafter(t, dir * INFINITY) - t);
        if (h_abs > s->max_step) h_abs = s->max_step;
        else if (h_abs < min_step) h_abs = min_step;
        int rejected = 0;
        double h = 0.0, t_new = t, err_norm;
        for (;;) {  /* attempts of one step: the compiled loop's control */
            if (h_abs < min_step) { o->outcome = KD_ENS_SMALL_STEP; break; }
            h = h_abs * dir;
            t_new = t + h;
            if (dir * (t_new - s->t1) > 0) t_new = s->t1;
            h = t_new - t;
            h_abs = fabs(h);
            kd_dopri_attempt(kd_ens_f, c, t, y, f, h, s->rtol, s->atol, K, y_new, &err_norm);
            if (err_norm < 1) {
                double factor = err_norm == 0 ? 10.0 : fmin(10.0, 0.9 * pow(err_norm, -0.2));
                if (rejected) factor = fmin(1.0, factor);
                h_abs *= factor;
                break;
            }
            double factor = 0.9 * pow(err_norm, -0.2);
            if (!(factor > 0.2)) factor = 0.2;  /* also for nan */
            h_abs *= factor;
            rejected = 1;
        }
        if (o->outcome != KD_ENS_DONE) break;
        kd_dopri_extension(K, Q);
        double t_stop = t_new;
        int terminate = 0;
        if (n_ev > 0) {  /* the compiled loop's search, step by step the same */
            kd_ens_events_at(s, c, t_new, y_new, g_new);
            double roots[64];
            int which[64], n_roots = 0;
            for (int k = 0; k < n_ev && n_roots < 64; ++k) {
                if (!kd_event_active(g_old[k], g_new[k], s->ev_dir[k])) continue;
                KdEnsAlong along = {s, c, y, Q, t, h, k, g_work};
                kd_brent(kd_ens_event_along, &along, t, t_new, g_old[k], g_new[k],
                         &roots[n_roots]);
                which[n_roots++] = k;
            }
            kd_sort_roots(roots, which, n_roots, dir);
            for (int a = 0; a < n_roots; ++a) {
                double ye[KD_NX];
                kd_dopri_dense(y, t, h, Q, roots[a], ye);
                if (kd_ens_found_push(found, roots[a], ye, which[a]) != 0) {
                    o->outcome = KD_ENS_NO_MEMORY;
                    break;
                }
                if (s->ev_term[which[a]] != 0) { terminate = 1; t_stop = roots[a]; break; }
            }
            if (o->outcome != KD_ENS_DONE) break;
        }
        for (; next < s->n_eval && dir * (s->t_eval[next] - t_stop) <= 0; ++next)
            kd_dopri_dense(y, t, h, Q, s->t_eval[next], out + KD_NX * next);
        if (terminate) {
            kd_dopri_dense(y, t, h, Q, t_stop, y_new);
            t_new = t_stop;
        }
        int finite = 1;
        for (int i = 0; i < KD_NX; ++i) if (!isfinite(y_new[i])) finite = 0;
        t = t_new;
        kd_copy(y, y_new, KD_NX);
        kd_copy(f, K + 6 * KD_NX, KD_NX);
        if (n_ev > 0) memcpy(g_old, g_new, sizeof(double) * (size_t)n_ev);
        o->steps++;
        if (finite && s->project_tol > 0 && KD_NQDEP + KD_NUDEP > 0) {
            kd_ens_inputs(c, t, r);
            if (kd_residual_at(t, y, c->p, r, c->work, B) > s->project_tol) {
                memcpy(before, y, sizeof(y));
                if (kd_project_at(t, y, c->p, r, c->work) != 0) {
                    memcpy(y, before, sizeof(y));
                    o->outcome = KD_ENS_PROJECTION;
                    break;
                }
                o->projections++;
                kd_ens_f(c, t, y, f);
                if (n_ev > 0) kd_ens_events_at(s, c, t, y, g_old);
            }
        }
        if (terminate) { o->outcome = KD_ENS_TERMINAL; break; }
    }
    PyMem_RawFree(g_old);
    o->n_out = next;
    o->t_end = t;
    memcpy(y_end, y, sizeof(y));
}

/* the trajectories' data, shared by the threads */
typedef struct {
    const KdEnsSpec *spec;
    const double *Y0, *P, *p_default, *r_times, *R;
    npy_intp r_count;             /* samples per trajectory's record (1: constants) */
    double *out, *y_end, *t_singular;
    KdEnsFound *found;            /* per trajectory */
    KdEnsOutcome *outcomes;
    long *nfev;
    npy_intp n;
    npy_intp *next;               /* the first trajectory not yet taken */
    double *work;                 /* this thread's */
    int *finished;                /* threads done (the calling thread waits for all) */
#if KD_HAVE_THREADS
    pthread_mutex_t *lock;        /* of next and finished */
    pthread_cond_t *done;         /* signalled as a thread finishes */
#endif
} KdEnsJob;

/* the next trajectory to integrate (n: none left); taken under the lock */
static npy_intp kd_ens_take(KdEnsJob *job) {
#if KD_HAVE_THREADS
    pthread_mutex_lock(job->lock);
#endif
    npy_intp i = (*job->next)++;
#if KD_HAVE_THREADS
    pthread_mutex_unlock(job->lock);
#endif
    return i;
}

static void kd_ens_rows(KdEnsJob *job) {
    for (;;) {
        npy_intp i = kd_ens_take(job);
        if (i >= job->n) break;
        KdEnsRhs c;
        memset(&c, 0, sizeof(c));
        c.p = job->P ? job->P + i * KD_NP : job->p_default;
        c.r_times = job->r_count > 1 ? job->r_times : NULL;
        c.r_values = KD_NR > 0 ? job->R + i * job->r_count * KD_NR : NULL;
        c.r_count = job->r_count;
        c.work = job->work;
        kd_ens_run(job->spec, &c, job->Y0 + i * KD_NX,
                   job->out + i * job->spec->n_eval * KD_NX, job->y_end + i * KD_NX,
                   &job->found[i], &job->outcomes[i]);
        job->nfev[i] = c.nfev;
        job->t_singular[i] = c.singular ? c.t_singular : NAN;
    }
#if KD_HAVE_THREADS
    pthread_mutex_lock(job->lock);
#endif
    ++*job->finished;
#if KD_HAVE_THREADS
    pthread_cond_signal(job->done);
    pthread_mutex_unlock(job->lock);
#endif
}

#if KD_HAVE_THREADS
/* whether all `running` threads are done, waiting up to KD_ENS_POLL s for it */
static int kd_ens_wait(KdEnsJob *job, int running) {
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_nsec += (long)(KD_ENS_POLL * 1e9);
    if (until.tv_nsec >= 1000000000L) { until.tv_sec += 1; until.tv_nsec -= 1000000000L; }
    pthread_mutex_lock(job->lock);
    if (*job->finished < running) pthread_cond_timedwait(job->done, job->lock, &until);
    int all = *job->finished >= running;
    pthread_mutex_unlock(job->lock);
    return all;
}
#endif

#if KD_HAVE_THREADS
static void *kd_ens_thread(void *job) {
    kd_ens_rows((KdEnsJob *)job);
    return NULL;
}
#endif

/* the events met by the n trajectories into result: "event_run", "event_which" (long),
   "event_t" (total,) and "event_y" (total, KD_NX), trajectory by trajectory in the order
   met; nonzero on an error (set) */
static int kd_ens_events_out(PyObject *result, const KdEnsFound *found, npy_intp n) {
    npy_intp total = 0;
    for (npy_intp i = 0; i < n; ++i) total += found[i].n;
    npy_intp dims1[1] = {total}, dims2[2] = {total, KD_NX};
    PyObject *run = PyArray_SimpleNew(1, dims1, NPY_LONG);
    PyObject *which = PyArray_SimpleNew(1, dims1, NPY_LONG);
    PyObject *t = PyArray_SimpleNew(1, dims1, NPY_DOUBLE);
    PyObject *y = PyArray_SimpleNew(2, dims2, NPY_DOUBLE);
    int bad = run == NULL || which == NULL || t == NULL || y == NULL;
    if (!bad) {
        long *rr = (long *)PyArray_DATA((PyArrayObject *)run);
        long *ww = (long *)PyArray_DATA((PyArrayObject *)which);
        double *tt = (double *)PyArray_DATA((PyArrayObject *)t);
        double *yy = (double *)PyArray_DATA((PyArrayObject *)y);
        for (npy_intp i = 0, at = 0; i < n; ++i) {
            for (npy_intp e = 0; e < found[i].n; ++e, ++at) {
                rr[at] = (long)i;
                ww[at] = found[i].which[e];
                tt[at] = found[i].t[e];
            }
            if (found[i].n)
                memcpy(yy + KD_NX * (at - found[i].n), found[i].y,
                       sizeof(double) * KD_NX * found[i].n);
        }
        bad = PyDict_SetItemString(result, "event_run", run) < 0
              || PyDict_SetItemString(result, "event_which", which) < 0
              || PyDict_SetItemString(result, "event_t", t) < 0
              || PyDict_SetItemString(result, "event_y", y) < 0;
    }
    Py_XDECREF(run); Py_XDECREF(which); Py_XDECREF(t); Py_XDECREF(y);
    return bad;
}

/* a C array of doubles as a new NumPy array of the given shape (copied) */
static PyObject *kd_ens_array(const void *data, int nd, npy_intp *dims, int type) {
    PyObject *a = PyArray_SimpleNew(nd, dims, type);
    if (a != NULL)
        memcpy(PyArray_DATA((PyArrayObject *)a), data, PyArray_NBYTES((PyArrayObject *)a));
    return a;
}

/* the events of integrate_many from its arguments: the table in the capsule of the
   compiled events (None: no events; NULL with an exception set when it is another
   model's), and their directions and terminal flags (each one double per event) */
static const KdEventTable *kd_ens_event_table(PyObject *capsule, PyObject *dirobj,
                                              PyObject *termobj, PyArrayObject **dirs,
                                              PyArrayObject **terms, int *none) {
    *none = capsule == Py_None;
    if (*none) return NULL;
    const KdEventTable *table = (const KdEventTable *)PyCapsule_GetPointer(capsule,
                                                                            "kanedyn.events");
    if (table == NULL) return NULL;
    if (table->nx != KD_NX || table->np != KD_NP || table->nr != KD_NR || table->count < 1) {
        PyErr_SetString(PyExc_ValueError, "the events were compiled for another model");
        return NULL;
    }
    *dirs = (PyArrayObject *)PyArray_FROMANY(dirobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
    *terms = (PyArrayObject *)PyArray_FROMANY(termobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
    if (*dirs == NULL || *terms == NULL) return NULL;
    if (PyArray_SIZE(*dirs) != table->count || PyArray_SIZE(*terms) != table->count) {
        PyErr_SetString(PyExc_ValueError, "one direction and one terminal flag per event");
        return NULL;
    }
    return table;
}

/* integrate_many(t0, t1, Y0, P, r_times, R, t_eval, rtol, atol, max_step, first_step,
                  project_tol, threads, stop, timeout[, events, directions, terminal])
                  -> dict
   Y0 (N, nx); P (N, np) or None (the model's constants); R (N, k, nr) inputs sampled at
   r_times (k,), or (N, 1, nr) constants with r_times None; t_eval (m,); atol (nx,);
   threads >= 1; stop: see kd_stop_flag; timeout: seconds, 0: none; events: the capsule
   of the compiled events or None (the default), directions and terminal (one double
   each per event) */
static PyObject *KdModel_integrate_many(KdModel *self, PyObject *args) {
    double t0, t1, rtol, max_step, first_step, project_tol, timeout;
    PyObject *y0obj, *pobj, *rtobj, *robj, *tevalobj, *atolobj, *stopobj;
    PyObject *evobj = Py_None, *dirobj = Py_None, *termobj = Py_None;
    int threads, no_events = 1;
    if (!PyArg_ParseTuple(args, "ddOOOOOdOdddiOd|OOO", &t0, &t1, &y0obj, &pobj, &rtobj,
                          &robj, &tevalobj, &rtol, &atolobj, &max_step, &first_step,
                          &project_tol, &threads, &stopobj, &timeout, &evobj, &dirobj,
                          &termobj))
        return NULL;
    const volatile npy_int32 *guard_stop = kd_stop_flag(stopobj);
    if (guard_stop == NULL) return NULL;
    PyArrayObject *Y0 = NULL, *P = NULL, *RT = NULL, *R = NULL, *TE = NULL, *AT = NULL;
    PyArrayObject *DIR = NULL, *TERM = NULL;
    PyObject *result = NULL;
    double *out = NULL, *y_end = NULL, *t_singular = NULL, *work = NULL;
    KdEnsOutcome *outcomes = NULL;
    KdEnsFound *found = NULL;
    long *nfev = NULL;
    npy_intp n = 0;
    const KdEventTable *events = kd_ens_event_table(evobj, dirobj, termobj, &DIR, &TERM,
                                                    &no_events);
    if (events == NULL && !no_events) goto done;
    Y0 = (PyArrayObject *)PyArray_FROMANY(y0obj, NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    TE = (PyArrayObject *)PyArray_FROMANY(tevalobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
    AT = (PyArrayObject *)PyArray_FROMANY(atolobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
    if (Y0 == NULL || TE == NULL || AT == NULL) goto done;
    n = PyArray_DIM(Y0, 0);
    npy_intp m = PyArray_SIZE(TE), k = 1;
    if (PyArray_DIM(Y0, 1) != KD_NX || PyArray_SIZE(AT) != KD_NX) {
        PyErr_SetString(PyExc_ValueError, "Y0 must have one state per row, atol one entry "
                        "per state");
        goto done;
    }
    if (pobj != Py_None) {
        P = (PyArrayObject *)PyArray_FROMANY(pobj, NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
        if (P == NULL) goto done;
        if (PyArray_DIM(P, 0) != n || PyArray_DIM(P, 1) != KD_NP) {
            PyErr_SetString(PyExc_ValueError, "P must have one row of constants per state");
            goto done;
        }
    }
    if (rtobj != Py_None) {
        RT = (PyArrayObject *)PyArray_FROMANY(rtobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
        if (RT == NULL) goto done;
        k = PyArray_SIZE(RT);
    }
    if (KD_NR > 0) {
        R = (PyArrayObject *)PyArray_FROMANY(robj, NPY_DOUBLE, 3, 3, NPY_ARRAY_IN_ARRAY);
        if (R == NULL) goto done;
        if (PyArray_DIM(R, 0) != n || PyArray_DIM(R, 1) != k || PyArray_DIM(R, 2) != KD_NR) {
            PyErr_SetString(PyExc_ValueError, "R must have shape (N, samples, inputs)");
            goto done;
        }
    }
    out = (double *)PyMem_RawMalloc(sizeof(double) * KD_SZ(n * m * KD_NX));
    y_end = (double *)PyMem_RawMalloc(sizeof(double) * KD_SZ(n * KD_NX));
    t_singular = (double *)PyMem_RawMalloc(sizeof(double) * KD_SZ(n));
    outcomes = (KdEnsOutcome *)PyMem_RawCalloc(KD_SZ(n), sizeof(KdEnsOutcome));
    nfev = (long *)PyMem_RawCalloc(KD_SZ(n), sizeof(long));
    found = (KdEnsFound *)PyMem_RawCalloc(KD_SZ(n), sizeof(KdEnsFound));
    if (threads < 1) threads = 1;
    if (threads > KD_MAX_THREADS) threads = KD_MAX_THREADS;
    if (threads > n) threads = n > 0 ? (int)n : 1;
    work = (double *)PyMem_RawMalloc(sizeof(double) * KD_SZ(KD_NW) * (size_t)threads);
    if (!out || !y_end || !t_singular || !outcomes || !nfev || !found || !work) {
        PyErr_NoMemory();
        goto done;
    }
    for (npy_intp i = 0; i < n * m * KD_NX; ++i) out[i] = NAN;
    volatile int stop = *guard_stop != 0;
    int interrupted = 0, finished = 0;
    KdEnsSpec spec = {t0, t1, rtol, max_step, first_step, project_tol,
                      timeout > 0 ? kd_clock() + timeout : 0.0,
                      (const double *)PyArray_DATA(AT), (const double *)PyArray_DATA(TE), m,
                      &stop, events, DIR ? (const double *)PyArray_DATA(DIR) : NULL,
                      TERM ? (const double *)PyArray_DATA(TERM) : NULL};
    npy_intp next = 0;
    KdEnsJob jobs[KD_MAX_THREADS];
#if KD_HAVE_THREADS
    pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
    pthread_cond_t done_cond = PTHREAD_COND_INITIALIZER;
#endif
    for (int j = 0; j < threads; ++j) {
        KdEnsJob job = {&spec, (const double *)PyArray_DATA(Y0),
                        P ? (const double *)PyArray_DATA(P) : NULL, self->p,
                        RT ? (const double *)PyArray_DATA(RT) : NULL,
                        R ? (const double *)PyArray_DATA(R) : NULL, k, out, y_end, t_singular,
                        found, outcomes, nfev, n, &next, work + (size_t)j * KD_SZ(KD_NW),
                        &finished
#if KD_HAVE_THREADS
                        , &lock, &done_cond
#endif
                        };
        jobs[j] = job;
    }
#if KD_HAVE_THREADS
    pthread_t ids[KD_MAX_THREADS];
    int started[KD_MAX_THREADS] = {0}, running = 0;
    Py_BEGIN_ALLOW_THREADS
    for (int j = 0; j < threads; ++j) {
        started[j] = pthread_create(&ids[j], NULL, kd_ens_thread, &jobs[j]) == 0;
        running += started[j];
    }
    Py_END_ALLOW_THREADS
    if (running == 0) {  /* no thread could start: this one does the work */
        Py_BEGIN_ALLOW_THREADS
        kd_ens_rows(&jobs[0]);
        Py_END_ALLOW_THREADS
    }
    /* wait, looking at Python's signals (a Ctrl-C stops the trajectories) */
    while (running > 0) {
        int all;
        Py_BEGIN_ALLOW_THREADS
        all = kd_ens_wait(&jobs[0], running);
        Py_END_ALLOW_THREADS
        if (all) break;
        if (*guard_stop) stop = 1;
        if (!stop && PyErr_CheckSignals() != 0) { stop = 1; interrupted = 1; }
    }
    Py_BEGIN_ALLOW_THREADS
    for (int j = 0; j < threads; ++j) if (started[j]) pthread_join(ids[j], NULL);
    Py_END_ALLOW_THREADS
#else
    Py_BEGIN_ALLOW_THREADS
    kd_ens_rows(&jobs[0]);
    Py_END_ALLOW_THREADS
#endif
    if (interrupted) {  /* a Ctrl-C: what was computed is returned, as the loop does */
        if (!PyErr_ExceptionMatches(PyExc_KeyboardInterrupt)) goto done;
        PyErr_Clear();
    }
    result = PyDict_New();
    if (result == NULL) goto done;
    {
        npy_intp dims3[3] = {n, m, KD_NX}, dims2[2] = {n, KD_NX}, dims1[1] = {n};
        long *codes = (long *)PyMem_RawMalloc(sizeof(long) * KD_SZ(n) * 5);
        double *ends = (double *)PyMem_RawMalloc(sizeof(double) * KD_SZ(n));
        if (codes == NULL || ends == NULL) {
            PyMem_RawFree(codes); PyMem_RawFree(ends);
            Py_CLEAR(result); PyErr_NoMemory(); goto done;
        }
        for (npy_intp i = 0; i < n; ++i) {
            codes[i] = outcomes[i].outcome;
            codes[n + i] = (long)outcomes[i].n_out;
            codes[2 * n + i] = outcomes[i].steps;
            codes[3 * n + i] = outcomes[i].projections;
            codes[4 * n + i] = nfev[i];
            ends[i] = outcomes[i].t_end;
        }
        const char *keys[] = {"outcome", "n_out", "steps", "projections", "nfev"};
        PyObject *item;
        int bad = 0;
#define KD_ENS_SET(key, value) do { item = (value); \
        if (item == NULL || PyDict_SetItemString(result, key, item) < 0) bad = 1; \
        Py_XDECREF(item); } while (0)
        for (int q = 0; q < 5 && !bad; ++q)
            KD_ENS_SET(keys[q], kd_ens_array(codes + q * n, 1, dims1, NPY_LONG));
        if (!bad) KD_ENS_SET("y", kd_ens_array(out, 3, dims3, NPY_DOUBLE));
        if (!bad) KD_ENS_SET("y_end", kd_ens_array(y_end, 2, dims2, NPY_DOUBLE));
        if (!bad) KD_ENS_SET("t_end", kd_ens_array(ends, 1, dims1, NPY_DOUBLE));
        if (!bad) KD_ENS_SET("t_singular", kd_ens_array(t_singular, 1, dims1, NPY_DOUBLE));
        if (!bad) KD_ENS_SET("interrupted", PyBool_FromLong(interrupted));
        if (!bad) bad = kd_ens_events_out(result, found, n);
#undef KD_ENS_SET
        PyMem_RawFree(codes);
        PyMem_RawFree(ends);
        if (bad) Py_CLEAR(result);
    }
done:
    Py_XDECREF(Y0); Py_XDECREF(P); Py_XDECREF(RT); Py_XDECREF(R); Py_XDECREF(TE);
    Py_XDECREF(AT); Py_XDECREF(DIR); Py_XDECREF(TERM);
    for (npy_intp i = 0; found != NULL && i < n; ++i) {
        PyMem_RawFree(found[i].t); PyMem_RawFree(found[i].y); PyMem_RawFree(found[i].which);
    }
    PyMem_RawFree(out); PyMem_RawFree(y_end); PyMem_RawFree(t_singular);
    PyMem_RawFree(outcomes); PyMem_RawFree(nfev); PyMem_RawFree(found); PyMem_RawFree(work);
    return result;
}
""".replace("@EVENT_TABLE@", EVENT_TABLE)
