/* Runs an FMI 2.0 Co-Simulation binary from C, the same code on Linux (dlopen) and Windows
 * (LoadLibrary; cross-compiled with mingw-w64 and run under Wine), so the platform binaries of
 * one FMU can be compared with each other.
 *
 * usage: fmu_run LIBRARY GUID STOP STEP INPUT_VR INPUT_VALUE OUTPUT_VR...
 * Instantiates, initialises with default parameters, holds the input at INPUT_VALUE and prints
 * "time,out1,out2,..." with %.17g after every step. Exit 0 on success, 1 on an FMI error. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
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

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", name, status, cat);
    va_start(ap, msg);
    vfprintf(stderr, msg, ap);
    va_end(ap);
    fputc('\n', stderr);
}

#define NEED(var, name)                                                    \
    var = SYM(lib, name);                                                  \
    if (!var) { fprintf(stderr, "missing %s\n", name); return 1; }

int main(int argc, char **argv) {
    if (argc < 8) {
        fprintf(stderr, "usage: %s LIBRARY GUID STOP STEP INPUT_VR INPUT_VALUE [+BOOLEAN_VR...] OUTPUT_VR...\n"
                        "  +VR: a Boolean parameter set true before initialization\n", argv[0]);
        return 2;
    }
    void *lib = LOAD(argv[1]);
    if (!lib) { fprintf(stderr, "cannot load %s\n", argv[1]); return 1; }
    comp_t (*instantiate)(const char *, int, const char *, const char *, const callbacks_t *, int, int);
    int (*setup)(comp_t, int, double, double, int, double);
    int (*enter)(comp_t), (*exit_init)(comp_t), (*terminate)(comp_t);
    void (*free_instance)(comp_t);
    int (*set_real)(comp_t, const unsigned *, size_t, const double *);
    int (*get_real)(comp_t, const unsigned *, size_t, double *);
    int (*set_boolean)(comp_t, const unsigned *, size_t, const int *);
    int (*do_step)(comp_t, double, double, int);
    NEED(instantiate, "fmi2Instantiate");
    NEED(setup, "fmi2SetupExperiment");
    NEED(enter, "fmi2EnterInitializationMode");
    NEED(exit_init, "fmi2ExitInitializationMode");
    NEED(terminate, "fmi2Terminate");
    NEED(free_instance, "fmi2FreeInstance");
    NEED(set_real, "fmi2SetReal");
    NEED(get_real, "fmi2GetReal");
    NEED(set_boolean, "fmi2SetBoolean");
    NEED(do_step, "fmi2DoStep");

    double stop = atof(argv[3]), h = atof(argv[4]), u = atof(argv[6]);
    unsigned in_vr = (unsigned)strtoul(argv[5], NULL, 10);
    size_t nb = 0;
    while (7 + (int)nb < argc && argv[7 + nb][0] == '+') nb++;
    size_t n = (size_t)(argc - 7) - nb;
    unsigned *bools = calloc(nb + 1, sizeof *bools);
    int *trues = calloc(nb + 1, sizeof *trues);
    unsigned *vrs = calloc(n, sizeof *vrs);
    double *y = calloc(n, sizeof *y);
    for (size_t k = 0; k < nb; k++) {
        bools[k] = (unsigned)strtoul(argv[7 + k] + 1, NULL, 10);
        trues[k] = 1;
    }
    for (size_t k = 0; k < n; k++) vrs[k] = (unsigned)strtoul(argv[7 + nb + k], NULL, 10);

    callbacks_t cb = {logger, calloc, free, NULL, NULL};
    comp_t c = instantiate("run", 1, argv[2], "file:///tmp", &cb, 0, 0);
    if (!c) { fprintf(stderr, "fmi2Instantiate returned NULL\n"); return 1; }
    if (setup(c, 0, 0.0, 0.0, 1, stop) || enter(c) || set_real(c, &in_vr, 1, &u)
        || (nb && set_boolean(c, bools, nb, trues)) || exit_init(c)) {
        fprintf(stderr, "initialization failed\n");
        return 1;
    }
    long steps = (long)(stop / h + 0.5);
    for (long i = 0; i < steps; i++) {
        double t = i * h;
        if (set_real(c, &in_vr, 1, &u) > 1 || do_step(c, t, h, 1) > 1 || get_real(c, vrs, n, y) > 1) {
            fprintf(stderr, "step at t = %g failed\n", t);
            return 1;
        }
        printf("%.17g", t + h);
        for (size_t k = 0; k < n; k++) printf(",%.17g", y[k]);
        printf("\n");
    }
    terminate(c);
    free_instance(c);
    free(bools);
    free(trues);
    free(vrs);
    free(y);
    return 0;
}
