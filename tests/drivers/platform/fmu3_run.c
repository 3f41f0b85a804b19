/* Runs an FMI 3.0 Co-Simulation binary from C, the same code on Linux (dlopen) and Windows
 * (LoadLibrary; cross-compiled with mingw-w64 and run under Wine), so the platform binaries of
 * one FMU can be compared with each other. The FMI 3.0 twin of fmu_run.c.
 *
 * usage: fmu3_run LIBRARY TOKEN STOP STEP INPUT_VR INPUT_VALUE OUTPUT_VR...
 * Instantiates (eventModeUsed = false), initialises with default parameters, holds the input at
 * INPUT_VALUE and prints "time,out1,out2,..." with %.17g after every step. Exit 0 on success, 1 on
 * an FMI error or a fmi3DoStep output other than the standard's for eventModeUsed = false. */
#include <stdbool.h>
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

typedef void *inst_t;
typedef void (*log_t)(void *, int, const char *, const char *);

static void logger(void *env, int status, const char *cat, const char *msg) {
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", status, cat, msg);
}

#define NEED(var, name)                                                    \
    var = SYM(lib, name);                                                  \
    if (!var) { fprintf(stderr, "missing %s\n", name); return 1; }

int main(int argc, char **argv) {
    if (argc < 8) {
        fprintf(stderr, "usage: %s LIBRARY TOKEN STOP STEP INPUT_VR INPUT_VALUE OUTPUT_VR...\n", argv[0]);
        return 2;
    }
    void *lib = LOAD(argv[1]);
    if (!lib) { fprintf(stderr, "cannot load %s\n", argv[1]); return 1; }
    inst_t (*instantiate)(const char *, const char *, const char *, bool, bool, bool, bool,
                          const unsigned *, size_t, void *, log_t, void *);
    int (*enter)(inst_t, bool, double, double, bool, double);
    int (*exit_init)(inst_t), (*terminate)(inst_t);
    void (*free_instance)(inst_t);
    int (*set_f64)(inst_t, const unsigned *, size_t, const double *, size_t);
    int (*get_f64)(inst_t, const unsigned *, size_t, double *, size_t);
    int (*do_step)(inst_t, double, double, bool, bool *, bool *, bool *, double *);
    NEED(instantiate, "fmi3InstantiateCoSimulation");
    NEED(enter, "fmi3EnterInitializationMode");
    NEED(exit_init, "fmi3ExitInitializationMode");
    NEED(terminate, "fmi3Terminate");
    NEED(free_instance, "fmi3FreeInstance");
    NEED(set_f64, "fmi3SetFloat64");
    NEED(get_f64, "fmi3GetFloat64");
    NEED(do_step, "fmi3DoStep");

    double stop = atof(argv[3]), h = atof(argv[4]), u = atof(argv[6]);
    unsigned in_vr = (unsigned)strtoul(argv[5], NULL, 10);
    size_t n = (size_t)(argc - 7);
    unsigned *vrs = calloc(n, sizeof *vrs);
    double *y = calloc(n, sizeof *y);
    for (size_t k = 0; k < n; k++) vrs[k] = (unsigned)strtoul(argv[7 + k], NULL, 10);

    inst_t c = instantiate("run", argv[2], NULL, false, false, false, false, NULL, 0, NULL, logger, NULL);
    if (!c) { fprintf(stderr, "fmi3InstantiateCoSimulation returned NULL\n"); return 1; }
    if (enter(c, false, 0.0, 0.0, true, stop) || set_f64(c, &in_vr, 1, &u, 1) || exit_init(c)) {
        fprintf(stderr, "initialization failed\n");
        return 1;
    }
    long steps = (long)(stop / h + 0.5);
    for (long i = 0; i < steps; i++) {
        double t = i * h, last = -1.0;
        bool event = true, term = true, early = true;
        if (set_f64(c, &in_vr, 1, &u, 1) > 1 || do_step(c, t, h, true, &event, &term, &early, &last) > 1
            || get_f64(c, vrs, n, y, n) > 1) {
            fprintf(stderr, "step at t = %g failed\n", t);
            return 1;
        }
        if (event || term || early || last != t + h) {
            fprintf(stderr, "fmi3DoStep at t = %g: outputs %d %d %d %.17g\n", t, event, term, early, last);
            return 1;
        }
        printf("%.17g", t + h);
        for (size_t k = 0; k < n; k++) printf(",%.17g", y[k]);
        printf("\n");
    }
    terminate(c);
    free_instance(c);
    free(vrs);
    free(y);
    return 0;
}
