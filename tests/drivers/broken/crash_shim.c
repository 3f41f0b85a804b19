/* A deliberately broken FMU binary for tests/test_conformance_validate.py: it
 * forwards every FMI 2.0 call to the real binary of the FMU (renamed to real_<id>.so next to it)
 * but dereferences NULL when fmi2DoStep is called on an instance that is not initialized (before
 * fmi2ExitInitializationMode, or after fmi2Terminate/fmi2Reset): a crash on a wrong call order.
 * With -DFAIL_AT=T it also crashes (or, with -DHANG, never returns) in any fmi2DoStep starting at
 * t >= T: a foreign FMU failing in the middle of a correct run.
 * Model Exchange rules broken on purpose (tests/test_conformance_validate.py): -DWRONG_DIRECTIONAL
 * doubles every directional derivative, -DNO_VALUES_CHANGED reports
 * valuesOfContinuousStatesChanged = false from fmi2NewDiscreteStates, -DLENIENT_ME answers
 * fmi2GetDerivatives before initialization with zeros and fmi2OK and ignores
 * fmi2SetContinuousStates outside Continuous-Time Mode (fmi2OK), -DSILENT_ME answers
 * fmi2GetDerivatives before initialization with fmi2Error and no message, -DNO_RESTORE answers
 * fmi2SetFMUstate with fmi2OK without restoring anything.
 * Build: gcc -shared -fPIC -DMODEL_ID=\"Oscillator\" -o Oscillator.so crash_shim.c -ldl */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef MODEL_ID
#error "define MODEL_ID"
#endif

typedef void *C;
typedef unsigned int VR;
typedef int S;

static void *real(void) {
    static void *lib;
    if (!lib) {
        Dl_info info;
        char path[4096], dir[4096];
        dladdr((void *)&real, &info);
        snprintf(dir, sizeof dir, "%s", info.dli_fname);
        snprintf(path, sizeof path, "%s/real_" MODEL_ID ".so", dirname(dir));
        lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (!lib) abort();
    }
    return lib;
}

#define FWD(ret, name, params, args)                         \
    ret name params {                                        \
        static ret(*fp_) params;                             \
        if (!fp_) *(void **)&fp_ = dlsym(real(), #name);       \
        return fp_ args;                                     \
    }

/* instances that are initialized (may step) */
static C ready[256];
static void mark(C c, int on) {
    for (int i = 0; i < 256; i++) {
        if (on && ready[i] == NULL) { ready[i] = c; return; }
        if (!on && ready[i] == c) ready[i] = NULL;
    }
}
static int is_ready(C c) {
    for (int i = 0; i < 256; i++) if (c && ready[i] == c) return 1;
    return 0;
}

FWD(const char *, fmi2GetTypesPlatform, (void), ())
FWD(const char *, fmi2GetVersion, (void), ())
FWD(S, fmi2SetDebugLogging, (C c, int on, size_t n, const char *const *cat), (c, on, n, cat))
FWD(C, fmi2Instantiate, (const char *a, int b, const char *d, const char *e, const void *f, int g, int h), (a, b, d, e, f, g, h))
FWD(S, fmi2SetupExperiment, (C c, int a, double b, double d, int e, double f), (c, a, b, d, e, f))
FWD(S, fmi2EnterInitializationMode, (C c), (c))
FWD(S, fmi2GetReal, (C c, const VR *v, size_t n, double *x), (c, v, n, x))
FWD(S, fmi2GetInteger, (C c, const VR *v, size_t n, int *x), (c, v, n, x))
FWD(S, fmi2GetBoolean, (C c, const VR *v, size_t n, int *x), (c, v, n, x))
FWD(S, fmi2GetString, (C c, const VR *v, size_t n, const char **x), (c, v, n, x))
FWD(S, fmi2SetReal, (C c, const VR *v, size_t n, const double *x), (c, v, n, x))
FWD(S, fmi2SetInteger, (C c, const VR *v, size_t n, const int *x), (c, v, n, x))
FWD(S, fmi2SetBoolean, (C c, const VR *v, size_t n, const int *x), (c, v, n, x))
FWD(S, fmi2SetString, (C c, const VR *v, size_t n, const char *const *x), (c, v, n, x))
FWD(S, fmi2GetFMUstate, (C c, void **s), (c, s))
FWD(S, fmi2FreeFMUstate, (C c, void **s), (c, s))
FWD(S, fmi2SerializedFMUstateSize, (C c, void *s, size_t *n), (c, s, n))
FWD(S, fmi2SerializeFMUstate, (C c, void *s, char *b, size_t n), (c, s, b, n))
FWD(S, fmi2DeSerializeFMUstate, (C c, const char *b, size_t n, void **s), (c, b, n, s))
#ifndef WRONG_DIRECTIONAL
FWD(S, fmi2GetDirectionalDerivative, (C c, const VR *a, size_t b, const VR *d, size_t e, const double *f, double *g), (c, a, b, d, e, f, g))
#else
/* -DWRONG_DIRECTIONAL: every directional derivative twice the real one */
S fmi2GetDirectionalDerivative(C c, const VR *a, size_t b, const VR *d, size_t e, const double *f,
                               double *g) {
    static S (*fp)(C, const VR *, size_t, const VR *, size_t, const double *, double *);
    if (!fp) *(void **)&fp = dlsym(real(), "fmi2GetDirectionalDerivative");
    S st = fp(c, a, b, d, e, f, g);
    for (size_t i = 0; i < b; i++) g[i] *= 2;
    return st;
}
#endif
FWD(S, fmi2SetRealInputDerivatives, (C c, const VR *v, size_t n, const int *o, const double *x), (c, v, n, o, x))
FWD(S, fmi2GetRealOutputDerivatives, (C c, const VR *v, size_t n, const int *o, double *x), (c, v, n, o, x))
FWD(S, fmi2CancelStep, (C c), (c))
FWD(S, fmi2GetStatus, (C c, int k, int *x), (c, k, x))
FWD(S, fmi2GetRealStatus, (C c, int k, double *x), (c, k, x))
FWD(S, fmi2GetIntegerStatus, (C c, int k, int *x), (c, k, x))
FWD(S, fmi2GetBooleanStatus, (C c, int k, int *x), (c, k, x))
FWD(S, fmi2GetStringStatus, (C c, int k, const char **x), (c, k, x))

static S (*real_exit)(C), (*real_terminate)(C), (*real_reset)(C), (*real_set_state)(C, void *);
static S (*real_do_step)(C, double, double, int);
static void (*real_free)(C);
#define LOAD(var, name) if (!var) *(void **)&var = dlsym(real(), name)

S fmi2ExitInitializationMode(C c) {
    LOAD(real_exit, "fmi2ExitInitializationMode");
    S s = real_exit(c);
    if (s <= 1) mark(c, 1);
    return s;
}
S fmi2Terminate(C c) {
    LOAD(real_terminate, "fmi2Terminate");
    mark(c, 0);
    return real_terminate(c);
}
S fmi2Reset(C c) {
    LOAD(real_reset, "fmi2Reset");
    mark(c, 0);
    return real_reset(c);
}
S fmi2SetFMUstate(C c, void *s) {
    LOAD(real_set_state, "fmi2SetFMUstate");
#ifdef NO_RESTORE
    /* -DNO_RESTORE: fmi2SetFMUstate answers fmi2OK and restores nothing */
    (void)c, (void)s;
    return 0;
#endif
    return real_set_state(c, s);
}
#ifdef LENIENT_ME
static void forget_continuous(C c);
#endif
void fmi2FreeInstance(C c) {
    LOAD(real_free, "fmi2FreeInstance");
    mark(c, 0);
#ifdef LENIENT_ME
    /* the next instance may get the same address */
    forget_continuous(c);
#endif
    real_free(c);
}
S fmi2DoStep(C c, double t, double h, int no_prior) {
    LOAD(real_do_step, "fmi2DoStep");
    if (!is_ready(c)) {
        volatile int *null = NULL;
        *null = 42; /* the deliberate bug: crash on a wrong call order */
    }
#ifdef FAIL_AT
    /* -DFAIL_AT=T: a step starting at or after T crashes, or with -DHANG never returns */
    if (t >= FAIL_AT) {
#ifdef HANG
        for (;;) pause();
#else
        volatile int *null = NULL;
        *null = 42;
#endif
    }
#endif
    return real_do_step(c, t, h, no_prior);
}

/* Model Exchange: forwarded; with -DME_FAIL_AT=T, fmi2GetDerivatives crashes (with -DHANG: never
 * returns; with -DME_ERROR: returns fmi2Error) once the time set by fmi2SetTime is at or after T
 * (a foreign ME FMU failing inside the host's integration). */
typedef struct { int a, b, c, d, e; double t; } EventInfo;
#ifndef LENIENT_ME
FWD(S, fmi2EnterEventMode, (C c), (c))
#else
static C continuous[256]; /* instances in Continuous-Time Mode */
static void forget_continuous(C c) {
    for (int i = 0; i < 256; i++)
        if (continuous[i] == c) continuous[i] = NULL;
}
S fmi2EnterEventMode(C c) {
    static S (*fp)(C);
    if (!fp) *(void **)&fp = dlsym(real(), "fmi2EnterEventMode");
    forget_continuous(c);
    return fp(c);
}
#endif
#ifndef NO_VALUES_CHANGED
FWD(S, fmi2NewDiscreteStates, (C c, EventInfo *i), (c, i))
#else
/* -DNO_VALUES_CHANGED: the event re-initializes states, but valuesOfContinuousStatesChanged is
 * reported false */
S fmi2NewDiscreteStates(C c, EventInfo *i) {
    static S (*fp)(C, EventInfo *);
    if (!fp) *(void **)&fp = dlsym(real(), "fmi2NewDiscreteStates");
    S st = fp(c, i);
    i->d = 0;
    return st;
}
#endif
#ifndef LENIENT_ME
FWD(S, fmi2EnterContinuousTimeMode, (C c), (c))
#else
S fmi2EnterContinuousTimeMode(C c) {
    static S (*fp)(C);
    if (!fp) *(void **)&fp = dlsym(real(), "fmi2EnterContinuousTimeMode");
    S st = fp(c);
    for (int i = 0; i < 256; i++)
        if (continuous[i] == NULL || continuous[i] == c) {
            continuous[i] = c;
            break;
        }
    return st;
}
#endif
FWD(S, fmi2CompletedIntegratorStep, (C c, int n, int *e, int *t), (c, n, e, t))
#ifndef LENIENT_ME
FWD(S, fmi2SetContinuousStates, (C c, const double *x, size_t n), (c, x, n))
#else
/* -DLENIENT_ME: fmi2SetContinuousStates outside Continuous-Time Mode answered fmi2OK (ignored) */
S fmi2SetContinuousStates(C c, const double *x, size_t n) {
    static S (*fp)(C, const double *, size_t);
    if (!fp) *(void **)&fp = dlsym(real(), "fmi2SetContinuousStates");
    for (int i = 0; i < 256; i++)
        if (c && continuous[i] == c) return fp(c, x, n);
    return 0;
}
#endif
FWD(S, fmi2GetEventIndicators, (C c, double *z, size_t n), (c, z, n))
FWD(S, fmi2GetContinuousStates, (C c, double *x, size_t n), (c, x, n))
FWD(S, fmi2GetNominalsOfContinuousStates, (C c, double *x, size_t n), (c, x, n))

static double me_time;
static S (*real_set_time)(C, double), (*real_get_derivatives)(C, double *, size_t);
S fmi2SetTime(C c, double t) {
    LOAD(real_set_time, "fmi2SetTime");
    me_time = t;
    return real_set_time(c, t);
}
S fmi2GetDerivatives(C c, double *dx, size_t n) {
    LOAD(real_get_derivatives, "fmi2GetDerivatives");
#ifdef LENIENT_ME
    /* -DLENIENT_ME: before initialization, zeros and fmi2OK instead of the FMU's answer */
    if (!is_ready(c)) {
        for (size_t i = 0; i < n; i++) dx[i] = 0;
        return 0;
    }
#endif
#ifdef SILENT_ME
    /* -DSILENT_ME: before initialization, fmi2Error without a logged message */
    if (!is_ready(c)) return 3;
#endif
#ifdef ME_FAIL_AT
    if (me_time >= ME_FAIL_AT) {
#if defined(ME_ERROR)
        return 3; /* fmi2Error, as an FMU whose equations fail there */
#elif defined(HANG)
        for (;;) pause();
#else
        volatile int *null = NULL;
        *null = 42;
#endif
    }
#endif
    return real_get_derivatives(c, dx, n);
}
