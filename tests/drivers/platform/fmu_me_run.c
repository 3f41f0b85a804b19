/* Runs an FMI 2.0 Model Exchange binary from C, the same code on Linux (dlopen) and Windows
 * (LoadLibrary; cross-compiled with mingw-w64 and run under Wine), so the platform binaries of
 * one FMU can be compared with each other through the Model Exchange interface.
 *
 * usage: fmu_me_run LIBRARY GUID NZ STOP STEP INPUT_VR INPUT_VALUE STATE_VRS DERIVATIVE_VRS
 *                   [+BOOLEAN_VR...] OUTPUT_VR...
 * STATE_VRS and DERIVATIVE_VRS: the value references of the states and of their derivatives
 * (<ModelStructure><Derivatives>), comma-separated, in the order of the state vector.
 * Instantiates for Model Exchange, initialises with default parameters (and the Boolean
 * parameters +VR true), holds the input at INPUT_VALUE and integrates the states with the
 * linearly implicit Euler method, (I - h J) dx = h f(x), J from fmi2GetDirectionalDerivative
 * column by column (stable on stiff plants at a fixed step): steps end at STEP multiples and at
 * time events; after each step fmi2CompletedIntegratorStep, a sign change of one of the NZ event
 * indicators or a time event reached is handled in Event Mode (fmi2NewDiscreteStates until
 * settled). Prints "time,out1,out2,..." with %.17g at every STEP multiple. Exit 0 on success,
 * 1 on an FMI error. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#define LOAD(p) (void *)LoadLibraryA(p)
#define SYM(h, n) (void *)GetProcAddress((HMODULE)(h), n)
#else
#include <dlfcn.h>
#define LOAD(p) dlopen(p, RTLD_NOW | RTLD_LOCAL)
#define SYM(h, n) dlsym(h, n)
#endif

typedef void *comp_t;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocate)(size_t, size_t);
    void (*free)(void *);
    void *step_finished;
    void *env;
} callbacks_t;
typedef struct {
    int new_discrete_states_needed, terminate_simulation, nominals_changed, values_changed,
        next_event_time_defined;
    double next_event_time;
} event_info_t;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", name, status, cat);
    va_start(ap, msg);
    vfprintf(stderr, msg, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static comp_t (*instantiate)(const char *, int, const char *, const char *, const callbacks_t *, int, int);
static int (*setup)(comp_t, int, double, double, int, double);
static int (*enter_init)(comp_t), (*exit_init)(comp_t), (*terminate)(comp_t);
static void (*free_instance)(comp_t);
static int (*set_real)(comp_t, const unsigned *, size_t, const double *);
static int (*get_real)(comp_t, const unsigned *, size_t, double *);
static int (*set_boolean)(comp_t, const unsigned *, size_t, const int *);
static int (*enter_event_mode)(comp_t), (*enter_ct_mode)(comp_t);
static int (*new_discrete_states)(comp_t, event_info_t *);
static int (*completed_step)(comp_t, int, int *, int *);
static int (*set_time)(comp_t, double);
static int (*set_states)(comp_t, const double *, size_t);
static int (*get_states)(comp_t, double *, size_t);
static int (*get_derivatives)(comp_t, double *, size_t);
static int (*get_indicators)(comp_t, double *, size_t);
static int (*directional)(comp_t, const unsigned *, size_t, const unsigned *, size_t, const double *, double *);

#define NEED(var, name)                                                    \
    *(void **)&var = SYM(lib, name);                                       \
    if (!var) { fprintf(stderr, "missing %s\n", name); return 1; }
#define CHECK(call)                                                        \
    if ((call) > 1) { fprintf(stderr, "%s failed at t = %g\n", #call, t); return 1; }

/* Solve A x = b in place (A n x n row-major, b -> x) by Gaussian elimination with partial
 * pivoting; 1 when A is singular. */
static int solve(double *a, double *b, size_t n) {
    for (size_t k = 0; k < n; k++) {
        size_t p = k;
        for (size_t i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
        if (a[p * n + k] == 0.0) return 1;
        if (p != k) {
            for (size_t j = 0; j < n; j++) {
                double s = a[k * n + j]; a[k * n + j] = a[p * n + j]; a[p * n + j] = s;
            }
            double s = b[k]; b[k] = b[p]; b[p] = s;
        }
        for (size_t i = k + 1; i < n; i++) {
            double f = a[i * n + k] / a[k * n + k];
            for (size_t j = k; j < n; j++) a[i * n + j] -= f * a[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (size_t k = n; k-- > 0;) {
        for (size_t j = k + 1; j < n; j++) b[k] -= a[k * n + j] * b[j];
        b[k] /= a[k * n + k];
    }
    return 0;
}

/* Event Mode at the current time until the discrete states settle; the next time event. */
static int event_iteration(comp_t c, double t, double *next) {
    event_info_t info;
    CHECK(enter_event_mode(c));
    do {
        memset(&info, 0, sizeof info);
        CHECK(new_discrete_states(c, &info));
        if (info.terminate_simulation) { fprintf(stderr, "terminated at t = %g\n", t); return 1; }
    } while (info.new_discrete_states_needed);
    *next = info.next_event_time_defined ? info.next_event_time : INFINITY;
    CHECK(enter_ct_mode(c));
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 10) {
        fprintf(stderr, "usage: %s LIBRARY GUID NZ STOP STEP INPUT_VR INPUT_VALUE STATE_VRS "
                        "DERIVATIVE_VRS [+BOOLEAN_VR...] OUTPUT_VR...\n", argv[0]);
        return 2;
    }
    void *lib = LOAD(argv[1]);
    if (!lib) { fprintf(stderr, "cannot load %s\n", argv[1]); return 1; }
    NEED(instantiate, "fmi2Instantiate");
    NEED(setup, "fmi2SetupExperiment");
    NEED(enter_init, "fmi2EnterInitializationMode");
    NEED(exit_init, "fmi2ExitInitializationMode");
    NEED(terminate, "fmi2Terminate");
    NEED(free_instance, "fmi2FreeInstance");
    NEED(set_real, "fmi2SetReal");
    NEED(get_real, "fmi2GetReal");
    NEED(set_boolean, "fmi2SetBoolean");
    NEED(enter_event_mode, "fmi2EnterEventMode");
    NEED(enter_ct_mode, "fmi2EnterContinuousTimeMode");
    NEED(new_discrete_states, "fmi2NewDiscreteStates");
    NEED(completed_step, "fmi2CompletedIntegratorStep");
    NEED(set_time, "fmi2SetTime");
    NEED(set_states, "fmi2SetContinuousStates");
    NEED(get_states, "fmi2GetContinuousStates");
    NEED(get_derivatives, "fmi2GetDerivatives");
    NEED(get_indicators, "fmi2GetEventIndicators");
    NEED(directional, "fmi2GetDirectionalDerivative");

    size_t nz = strtoul(argv[3], NULL, 10), nx = 1;
    double stop = atof(argv[4]), h = atof(argv[5]), u = atof(argv[7]);
    unsigned in_vr = (unsigned)strtoul(argv[6], NULL, 10);
    for (const char *p = argv[8]; *p; p++) nx += *p == ',';
    int first = 10;
    size_t nb = 0;
    while (first + (int)nb < argc && argv[first + nb][0] == '+') nb++;
    size_t n = (size_t)(argc - first) - nb;
    unsigned *bools = calloc(nb + 1, sizeof *bools), *vrs = calloc(n + 1, sizeof *vrs);
    unsigned *der_vrs = calloc(nx, sizeof *der_vrs), *state_vrs = calloc(nx, sizeof *state_vrs);
    int *trues = calloc(nb + 1, sizeof *trues);
    double *y = calloc(n + 1, sizeof *y), *x = calloc(nx, sizeof *x), *f = calloc(nx, sizeof *f);
    double *jac = calloc(nx * nx, sizeof *jac), *col = calloc(nx, sizeof *col);
    double *z = calloc(nz + 1, sizeof *z), *z_new = calloc(nz + 1, sizeof *z_new);
    for (size_t k = 0; k < nb; k++) {
        bools[k] = (unsigned)strtoul(argv[first + k] + 1, NULL, 10);
        trues[k] = 1;
    }
    for (size_t k = 0; k < n; k++) vrs[k] = (unsigned)strtoul(argv[first + nb + k], NULL, 10);
    char *p = argv[8], *q = argv[9];
    for (size_t k = 0; k < nx; k++) {
        state_vrs[k] = (unsigned)strtoul(p, &p, 10);
        der_vrs[k] = (unsigned)strtoul(q, &q, 10);
        if (*p == ',') p++;
        if (*q == ',') q++;
    }

    double t = 0.0, next_event;
    callbacks_t cb = {logger, calloc, free, NULL, NULL};
    comp_t c = instantiate("run", 0, argv[2], "file:///tmp", &cb, 0, 0);
    if (!c) { fprintf(stderr, "fmi2Instantiate returned NULL\n"); return 1; }
    CHECK(setup(c, 0, 0.0, 0.0, 1, stop));
    CHECK(enter_init(c));
    CHECK(set_real(c, &in_vr, 1, &u));
    if (nb) CHECK(set_boolean(c, bools, nb, trues));
    CHECK(exit_init(c));
    /* fmi2ExitInitializationMode leaves the instance in Event Mode */
    {
        event_info_t info;
        do {
            memset(&info, 0, sizeof info);
            CHECK(new_discrete_states(c, &info));
        } while (info.new_discrete_states_needed);
        next_event = info.next_event_time_defined ? info.next_event_time : INFINITY;
        CHECK(enter_ct_mode(c));
    }
    if (nz) CHECK(get_indicators(c, z, nz));

    long steps = (long)(stop / h + 0.5);
    for (long i = 1; i <= steps; i++) {
        double t_out = i * h;
        while (t < t_out) {
            double t_end = next_event < t_out ? next_event : t_out, dt = t_end - t;
            CHECK(get_states(c, x, nx));
            CHECK(get_derivatives(c, f, nx));
            for (size_t j = 0; j < nx; j++) {
                double e = 1.0;
                CHECK(directional(c, der_vrs, nx, &state_vrs[j], 1, &e, col));
                for (size_t k = 0; k < nx; k++) jac[k * nx + j] = -dt * col[k] + (k == j);
            }
            for (size_t k = 0; k < nx; k++) f[k] *= dt;
            if (solve(jac, f, nx)) { fprintf(stderr, "singular matrix at t = %g\n", t); return 1; }
            for (size_t k = 0; k < nx; k++) x[k] += f[k];
            t = t_end;
            CHECK(set_time(c, t));
            CHECK(set_states(c, x, nx));
            int enter = 0, term = 0;
            CHECK(completed_step(c, 1, &enter, &term));
            int state_event = 0;
            if (nz) {
                CHECK(get_indicators(c, z_new, nz));
                for (size_t k = 0; k < nz; k++) state_event |= (z[k] > 0) != (z_new[k] > 0);
            }
            if (enter || state_event || t >= next_event) {
                if (event_iteration(c, t, &next_event)) return 1;
                if (nz) CHECK(get_indicators(c, z_new, nz));
            }
            memcpy(z, z_new, nz * sizeof *z);
        }
        CHECK(get_real(c, vrs, n, y));
        printf("%.17g", t);
        for (size_t k = 0; k < n; k++) printf(",%.17g", y[k]);
        printf("\n");
    }
    terminate(c);
    free_instance(c);
    return 0;
}
