"""The C core shared by the FMI 2.0 and FMI 3.0 interfaces (``fmi2.c``, ``fmi3.c``).

It holds an instance's state and does the work of every FMI function that both
standards have: start values and parameters, getting and setting values by value
reference, derivatives and energies, the constraint projection at initialization
and at step events (model exchange), and the co-simulation step (``kanedyn_advance``
of the standalone export, ``model.c``).  An interface (``_c_fmi2``, ``_c_fmi3``)
defines its types, a ``Callbacks`` struct and three functions the core calls
(``emit``: a log message; ``allocate``, ``release``: memory), then its exported
functions as thin calls of the core's.

Statuses are the numbers both standards give them (OK 0, Warning 1, Discard 2,
Error 3, Fatal 4).  The text is a ``%``-template (``%%`` for ``%``), filled by
:func:`kanedyn.io.fmu._wrapper.wrapper_source`.
"""

from __future__ import annotations

__all__ = ["CORE"]

CORE = r"""
/* ----------------------------------------------------- the model (model.c) */
int kanedyn_rhs(double t, const double *y, const double *p, const double *r, double *ydot);
int kanedyn_constraints(double t, const double *y, const double *p, const double *r,
                        double *residual);
int kanedyn_energy(double t, const double *y, const double *p, const double *r,
                   double *energy);
int kanedyn_project(double t, double *y, const double *p, const double *r);
int kanedyn_advance(double t0, double t1, double *y, const double *p, const double *r,
                    const double *r_rate, double rtol, double atol, double project_tol,
                    double *step, long *steps);
extern const double kanedyn_default_parameters[];
#define NC %(nc)d           /* contacts */
#if NC > 0
size_t kanedyn_contact_state_size(void);
int kanedyn_contact_start(double t, double *z, const double *p, void *state, double atol);
int kanedyn_contact_advance(double t0, double t1, double *z, const double *p, void *state,
                            double rtol, double atol, long *steps);
const char *kanedyn_contact_message(const void *state);
int kanedyn_contact_mode(const void *state, int contact);
int kanedyn_contact_derivatives(double t, const double *y, const double *p, void *state,
                                double *ydot);
int kanedyn_contact_indicators(double t, const double *y, const double *p, void *state,
                               double *g);
int kanedyn_contact_update(double t, double *y, const double *p, void *state, int *changed);
#endif
#define NI (2 * NC)         /* event indicators: 2 per contact */

#define NX %(nx)d           /* states */
#define NP %(np)d           /* parameters */
#define NR %(nr)d           /* specified inputs */
#define NE %(ne)d           /* energy outputs */
#define NCON %(ncon)d       /* constraint residuals */
#define SZ(n) ((n) > 0 ? (n) : 1)
#define VR_Y 0
#define VR_DER (VR_Y + NX)
#define VR_P (VR_DER + NX)
#define VR_R (VR_P + NP)
#define VR_E (VR_R + NR)
#define VR_SET (VR_E + NE)
#define NSET 3
#define NIV %(niv)d          /* event-indicator variables (FMI 3.0 declares them) */
#define VR_MODE (VR_SET + NSET) /* the contacts' modes (0 separated, 1 slip, 2 stick) */
#define VR_IND (VR_MODE + NC)
#define VR_END (VR_IND + NIV)
#define VR_TIME VR_END      /* the independent variable (declared by FMI 3.0 only) */
#define TOKEN "%(guid)s"

enum { S_OK = 0, S_WARNING = 1, S_DISCARD = 2, S_ERROR = 3, S_FATAL = 4 };

static const double y_start[NX] = {%(y_start)s};
static const double y_nominal[NX] = {%(y_nominal)s};
static const double r_start[SZ(NR)] = {%(r_start)s};
static const double set_start[NSET] = {%(settings)s};  /* rtol, atol, projection_tol */
static const char *const variable_names[VR_END + 1] = {%(names)s, "time"};

enum { INSTANTIATED, INITIALIZATION, EVENT, CONTINUOUS, STEP, TERMINATED };

typedef struct {
    Callbacks cb;
    char *name;
    int cosimulation;
    int mode, logging, fresh;          /* fresh: ydot and energy are up to date */
    double t, step;
    long steps;
    double y[NX], ydot[NX], p[SZ(NP)], r[SZ(NR)], r_rate[SZ(NR)], energy[2];
    double set[NSET];
    double work[2];                    /* contacts: work of friction, of all contact forces */
    void *contacts;                    /* contacts: the modes and references of model.c */
} Instance;

/* defined by the interface: */
static void emit(const Instance *c, int status, const char *category, const char *text);
static void *allocate(const Callbacks *cb, size_t size);
static void release(const Callbacks *cb, void *memory);

static void say(Instance *c, int status, const char *category, const char *format, ...) {
    char text[512];
    va_list args;
    if (c == NULL) return;
    if (status == S_OK && !c->logging) return;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    emit(c, status, category, text);
}

static int failed(Instance *c, const char *format, const char *what) {
    say(c, S_ERROR, "logStatusError", format, what);
    return S_ERROR;
}

static const char *code_text(int code) {
    switch (code) {
    case 1: return "singular mass matrix or constraint Jacobian";
    case 2: return "out of memory";
    case 3: return "a state derivative is not finite";
    case 4: return "step size too small";
    case 5: return "contact handling";
    default: return "unknown failure";
    }
}

/* derivatives and energies at the current time and state */
static int refresh(Instance *c) {
    if (c->fresh) return 0;
#if NC > 0  /* in the contacts' current modes */
    int code = kanedyn_contact_derivatives(c->t, c->y, c->p, c->contacts, c->ydot);
    if (code == 5) {
        say(c, S_ERROR, "logStatusError", "the derivatives at t = %%.17g: %%s", c->t,
            kanedyn_contact_message(c->contacts));
        return code;
    }
#else
    int code = kanedyn_rhs(c->t, c->y, c->p, c->r, c->ydot);
#endif
    if (code != 0) {
        say(c, S_ERROR, "logStatusError", "the right-hand side failed at t = %%.17g: %%s",
            c->t, code_text(code));
        return code;
    }
    if (kanedyn_energy(c->t, c->y, c->p, c->r, c->energy) != 0) return 2;
    c->fresh = 1;
    return 0;
}

static double residual(Instance *c) {
    double res[SZ(NCON)], worst = 0.0;
    if (NCON == 0 || kanedyn_constraints(c->t, c->y, c->p, c->r, res) != 0) return 0.0;
    for (int i = 0; i < NCON; ++i) worst = fmax(worst, fabs(res[i]));
    return worst;
}

static int project(Instance *c) {
    if (NCON == 0) return 0;
    int code = kanedyn_project(c->t, c->y, c->p, c->r);
    c->fresh = 0;
    if (code != 0)
        say(c, S_ERROR, "logStatusError", "the state cannot be projected onto the "
            "constraints at t = %%.17g: %%s", c->t, code_text(code));
    return code;
}

static void core_reset(Instance *c) {
    c->mode = INSTANTIATED;
    c->fresh = 0;
    c->t = 0.0;
    c->step = 0.0;
    c->steps = 0;
    memcpy(c->y, y_start, sizeof c->y);
    for (int i = 0; i < NP; ++i) c->p[i] = kanedyn_default_parameters[i];
    memcpy(c->r, r_start, sizeof c->r);
    memset(c->r_rate, 0, sizeof c->r_rate);
    memcpy(c->set, set_start, sizeof c->set);
}

static Instance *core_new(const char *name, int cosimulation, int logging,
                          const Callbacks *cb) {
    Instance *c = (Instance *)allocate(cb, sizeof(Instance));
    if (c == NULL) return NULL;
    c->contacts = NULL;
#if NC > 0
    c->contacts = allocate(cb, kanedyn_contact_state_size());
    if (c->contacts == NULL) { release(cb, c); return NULL; }
#endif
    if (name == NULL) name = "";
    c->name = (char *)allocate(cb, strlen(name) + 1);
    if (c->name == NULL) {
        if (c->contacts != NULL) release(cb, c->contacts);
        release(cb, c);
        return NULL;
    }
    strcpy(c->name, name);
    c->cb = *cb;
    c->cosimulation = cosimulation;
    c->logging = logging;
    core_reset(c);
    return c;
}

static void core_free(Instance *c) {
    if (c == NULL) return;
    Callbacks cb = c->cb;
    release(&cb, c->name);
    if (c->contacts != NULL) release(&cb, c->contacts);
    release(&cb, c);
}

static void core_setup(Instance *c, int tolerance_defined, double tolerance, double start) {
    if (tolerance_defined && tolerance > 0) c->set[0] = tolerance;
    c->t = start;
    c->fresh = 0;
}

static int core_exit_initialization(Instance *c) {
    if (!(c->set[0] > 0 && c->set[1] > 0 && c->set[2] >= 0))
        return failed(c, "%%s must be > 0 (projection_tol >= 0)",
                      "kanedyn.rtol and kanedyn.atol");
    if (project(c) != 0) return S_ERROR;  /* a consistent initial state, as kd.simulate */
#if NC > 0
    {  /* the contacts' modes at the start: impacts, forces within their limits */
        double z[NX + 2];
        memcpy(z, c->y, sizeof c->y);
        int code = kanedyn_contact_start(c->t, z, c->p, c->contacts, c->set[1]);
        if (code != 0) {
            say(c, S_ERROR, "logStatusError", "the contacts at the start: %%s",
                code == 5 ? kanedyn_contact_message(c->contacts) : code_text(code));
            return S_ERROR;
        }
        memcpy(c->y, z, sizeof c->y);
        c->work[0] = z[NX];
        c->work[1] = z[NX + 1];
        c->fresh = 0;
    }
#endif
    c->mode = c->cosimulation ? STEP : EVENT;
    return refresh(c) == 0 ? S_OK : S_ERROR;
}

/* model exchange: the event indicators (2 per contact, see kanedyn_contact_indicators) */
static int core_indicators(Instance *c, double g[], size_t ni, const char *function) {
    if (ni != NI) return failed(c, "%%s: wrong number of event indicators", function);
#if NC > 0
    if (NI > 0 && kanedyn_contact_indicators(c->t, c->y, c->p, c->contacts, g) != 0) {
        say(c, S_ERROR, "logStatusError", "%%s", kanedyn_contact_message(c->contacts));
        return S_ERROR;
    }
#else
    (void)g;
#endif
    return S_OK;
}

static int core_get(Instance *c, const unsigned vr[], size_t nvr, double value[]) {
    for (size_t k = 0; k < nvr; ++k) {
        unsigned v = vr[k];
        if ((v >= VR_DER && v < VR_P) || (v >= VR_E && v < VR_SET))
            if (c->mode != INSTANTIATED && refresh(c) != 0) return S_ERROR;
        if (v < VR_DER) value[k] = c->y[v - VR_Y];
        else if (v < VR_P) value[k] = c->mode == INSTANTIATED ? 0.0 : c->ydot[v - VR_DER];
        else if (v < VR_R) value[k] = c->p[v - VR_P];
        else if (v < VR_E) value[k] = c->r[v - VR_R];
        else if (v < VR_SET) value[k] = c->mode == INSTANTIATED ? 0.0 : c->energy[v - VR_E];
        else if (v < VR_MODE) value[k] = c->set[v - VR_SET];
#if NC > 0
        else if (v < VR_IND)
            value[k] = c->mode == INSTANTIATED ? 0.0
                       : (double)kanedyn_contact_mode(c->contacts, (int)(v - VR_MODE));
#endif
        else if (v < VR_END) {  /* an event indicator: all computed, one kept */
            double g[SZ(NIV)];
            if (c->mode == INSTANTIATED) g[v - VR_IND] = 0.0;
            else if (core_indicators(c, g, NIV, "getting an event indicator") != S_OK)
                return S_ERROR;
            value[k] = g[v - VR_IND];
        }
        else if (v == VR_TIME && TIME_VARIABLE) value[k] = c->t;
        else {
            say(c, S_ERROR, "logStatusError", "no %%s variable has value reference %%u",
                FLOAT_NAME, v);
            return S_ERROR;
        }
    }
    return S_OK;
}

static int core_set(Instance *c, const unsigned vr[], size_t nvr, const double value[]) {
    int before = c->mode == INSTANTIATED || c->mode == INITIALIZATION;
    for (size_t k = 0; k < nvr; ++k) {
        unsigned v = vr[k];
        if (v == VR_TIME && TIME_VARIABLE)
            return failed(c, "%%s is the independent variable: it cannot be set", "time");
        if (v >= VR_END) {
            say(c, S_ERROR, "logStatusError", "no %%s variable has value reference %%u",
                FLOAT_NAME, v);
            return S_ERROR;
        }
        if ((v >= VR_DER && v < VR_P) || (v >= VR_E && v < VR_SET) || v >= VR_MODE)
            return failed(c, "%%s is computed by the FMU: it cannot be set", variable_names[v]);
        if (!before && !(v >= VR_R && v < VR_E))
            return failed(c, "%%s can only be set before the end of initialization",
                          variable_names[v]);
        if (v < VR_DER) c->y[v - VR_Y] = value[k];
        else if (v < VR_R) c->p[v - VR_P] = value[k];
        else if (v < VR_E) { c->r[v - VR_R] = value[k]; c->r_rate[v - VR_R] = 0.0; }
        else c->set[v - VR_SET] = value[k];  /* v < VR_MODE */
        c->fresh = 0;
    }
    return S_OK;
}

/* model exchange: a step event when the constraint residual exceeds projection_tol */
static int core_step_event(Instance *c) {
    return NCON > 0 && c->set[2] > 0 && residual(c) > c->set[2];
}

/* model exchange, event mode: project when needed; *changed: the states were moved */
static int core_update_discrete_states(Instance *c, int *changed) {
    *changed = 0;
#if NC > 0  /* contact events: impacts and mode changes */
    int code = kanedyn_contact_update(c->t, c->y, c->p, c->contacts, changed);
    c->fresh = 0;
    if (code != 0) {
        say(c, S_ERROR, "logStatusError", "the contact event at t = %%.17g: %%s", c->t,
            code == 5 ? kanedyn_contact_message(c->contacts) : code_text(code));
        return S_ERROR;
    }
    if (*changed) say(c, S_OK, "logEvents", "t = %%.17g: a contact event", c->t);
#endif
    if (core_step_event(c)) {
        say(c, S_OK, "logEvents", "t = %%.17g: state projected onto the constraints", c->t);
        if (project(c) != 0) return S_ERROR;
        *changed = 1;
    }
    return S_OK;
}

static int core_set_time(Instance *c, double t) {
    c->t = t;
    c->fresh = 0;
    return S_OK;
}

static int core_states(Instance *c, double x[], size_t nx, int get, const char *function) {
    if (nx != NX) return failed(c, "%%s: wrong number of states", function);
    if (get) memcpy(x, c->y, sizeof c->y);
    else { memcpy(c->y, x, sizeof c->y); c->fresh = 0; }
    return S_OK;
}

static int core_derivatives(Instance *c, double dx[], size_t nx, const char *function) {
    if (nx != NX) return failed(c, "%%s: wrong number of states", function);
    if (refresh(c) != 0) return S_ERROR;
    memcpy(dx, c->ydot, sizeof c->ydot);
    return S_OK;
}

static int core_nominals(Instance *c, double nominal[], size_t nx, const char *function) {
    if (nx != NX) return failed(c, "%%s: wrong number of states", function);
    memcpy(nominal, y_nominal, sizeof y_nominal);
    return S_OK;
}

#if INPUT_DERIVATIVES
/* co-simulation: inputs' first derivatives (FMI 2.0 only) */
static int core_set_input_rate(Instance *c, unsigned vr, int order, double value,
                               const char *function) {
    if (vr < VR_R || vr >= VR_E || order != 1)
        return failed(c, "%%s: only first derivatives of inputs", function);
    c->r_rate[vr - VR_R] = value;
    return S_OK;
}
#endif

/* co-simulation: integrate from t0 to t0 + h with kanedyn_advance */
static int core_do_step(Instance *c, double t0, double h, const char *function) {
    if (c->mode != STEP) return failed(c, "%%s: not in step mode", function);
    if (!(h > 0)) return failed(c, "%%s: the step size must be > 0", function);
    double t1 = t0 + h, y[NX + 2];
    memcpy(y, c->y, sizeof c->y);
#if NC > 0  /* through the contact events (no inputs, no constraints: see io.fmu) */
    y[NX] = c->work[0];
    y[NX + 1] = c->work[1];
    int code = kanedyn_contact_advance(t0, t1, y, c->p, c->contacts, c->set[0], c->set[1],
                                       &c->steps);
    if (code == 5) {
        say(c, S_ERROR, "logStatusError", "the step from t = %%.17g to %%.17g failed: %%s",
            t0, t1, kanedyn_contact_message(c->contacts));
        c->fresh = 0;
        return S_ERROR;
    }
    c->work[0] = y[NX];
    c->work[1] = y[NX + 1];
#else
    int code = kanedyn_advance(t0, t1, y, c->p, c->r, c->r_rate, c->set[0], c->set[1],
                               c->set[2], &c->step, &c->steps);
#endif
    for (int k = 0; k < NR; ++k) {  /* the inputs at t1, their derivatives used up */
        c->r[k] += h * c->r_rate[k];
        c->r_rate[k] = 0.0;
    }
    c->fresh = 0;
    if (code != 0) {
        say(c, S_ERROR, "logStatusError", "the step from t = %%.17g to %%.17g failed: %%s",
            t0, t1, code_text(code));
        return S_ERROR;
    }
    memcpy(c->y, y, sizeof c->y);
    c->t = t1;
    return S_OK;
}
"""
