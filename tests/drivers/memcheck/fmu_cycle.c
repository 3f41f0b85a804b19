/* Memory driver for scripts/memcheck (leaks and invalid accesses over whole instance lives): loads an FMU binary with dlopen
 * and runs REPS full life cycles of one instance:
 *   instantiate, setup, enter/exit initialization (inputs set), STEPS steps with changing inputs,
 *   get/set/serialize/deserialize FMU states, a few rejected calls (error paths and logging),
 *   reset, initialize again, step, terminate, free.
 * Every status is checked; any unexpected one exits with status 2. Under valgrind
 * (--error-exitcode=1 --leak-check=full) this shows invalid accesses and leaks.
 * It prints the peak heap in use by one instance (glibc mallinfo2, sampled after every call) and
 * the RSS growth over all cycles.
 *
 * usage: fmu_cycle LIB.so GUID REPS STEPS H INPUT_VRS OUTPUT_VRS   (VR lists comma-separated)
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <malloc.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi2Component;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef int fmi2Status;
typedef int fmi2Boolean;
typedef char fmi2Byte;

typedef struct {
    void (*logger)(void *, const char *, fmi2Status, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, fmi2Status);
    void *componentEnvironment;
} fmi2CallbackFunctions;

static unsigned long n_messages = 0;

static void logger(void *env, const char *name, fmi2Status status, const char *category,
                   const char *message, ...) {
    char buf[2048];
    va_list ap;
    (void)env;
    (void)name;
    (void)status;
    (void)category;
    va_start(ap, message);
    vsnprintf(buf, sizeof buf, message, ap);
    va_end(ap);
    n_messages++;
}

#define FN(ret, name, args) static ret(*name) args
FN(fmi2Component, fmi2Instantiate, (const char *, int, const char *, const char *, const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean));
FN(void, fmi2FreeInstance, (fmi2Component));
FN(fmi2Status, fmi2SetupExperiment, (fmi2Component, fmi2Boolean, double, double, fmi2Boolean, double));
FN(fmi2Status, fmi2EnterInitializationMode, (fmi2Component));
FN(fmi2Status, fmi2ExitInitializationMode, (fmi2Component));
FN(fmi2Status, fmi2Terminate, (fmi2Component));
FN(fmi2Status, fmi2Reset, (fmi2Component));
FN(fmi2Status, fmi2GetReal, (fmi2Component, const fmi2ValueReference *, size_t, double *));
FN(fmi2Status, fmi2SetReal, (fmi2Component, const fmi2ValueReference *, size_t, const double *));
FN(fmi2Status, fmi2DoStep, (fmi2Component, double, double, fmi2Boolean));
FN(fmi2Status, fmi2GetFMUstate, (fmi2Component, fmi2FMUstate *));
FN(fmi2Status, fmi2SetFMUstate, (fmi2Component, fmi2FMUstate));
FN(fmi2Status, fmi2FreeFMUstate, (fmi2Component, fmi2FMUstate *));
FN(fmi2Status, fmi2SerializedFMUstateSize, (fmi2Component, fmi2FMUstate, size_t *));
FN(fmi2Status, fmi2SerializeFMUstate, (fmi2Component, fmi2FMUstate, fmi2Byte *, size_t));
FN(fmi2Status, fmi2DeSerializeFMUstate, (fmi2Component, const fmi2Byte *, size_t, fmi2FMUstate *));
FN(fmi2Status, fmi2SetDebugLogging, (fmi2Component, fmi2Boolean, size_t, const char *const *));

static void *lib;
static void *sym(const char *name) {
    void *p = dlsym(lib, name);
    if (!p) {
        fprintf(stderr, "missing symbol %s\n", name);
        exit(2);
    }
    return p;
}

static size_t baseline_heap, peak_heap;
static void sample_heap(void) {
    struct mallinfo2 mi = mallinfo2();
    size_t used = mi.uordblks + mi.hblkhd;
    if (used > baseline_heap && used - baseline_heap > peak_heap) peak_heap = used - baseline_heap;
}

static const char *where;
static void expect(fmi2Status got, fmi2Status want, const char *call, int rep) {
    sample_heap();
    if (got != want) {
        fprintf(stderr, "rep %d (%s): %s returned %d, expected %d\n", rep, where, call, got, want);
        exit(2);
    }
}
#define CALL(want, expr) expect((expr), (want), #expr, rep)

static size_t parse_vrs(const char *s, fmi2ValueReference *out, size_t max) {
    size_t n = 0;
    while (s && *s && n < max) {
        char *end;
        unsigned long v = strtoul(s, &end, 10);
        if (end == s) break;
        out[n++] = (fmi2ValueReference)v;
        s = (*end == ',') ? end + 1 : end;
    }
    return n;
}

static long rss_kib(void) {
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kib = -1;
    if (!f) return -1;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "VmRSS:", 6) == 0) kib = strtol(line + 6, NULL, 10);
    fclose(f);
    return kib;
}

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: %s LIB.so GUID REPS STEPS H INPUT_VRS OUTPUT_VRS\n", argv[0]);
        return 2;
    }
    const char *guid = argv[2];
    int reps = atoi(argv[3]), steps = atoi(argv[4]);
    double h = atof(argv[5]);
    fmi2ValueReference in[64], out[256];
    size_t nin = parse_vrs(argv[6], in, 64), nout = parse_vrs(argv[7], out, 256);
    double u[64], y[256];

    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    fmi2Instantiate = sym("fmi2Instantiate");
    fmi2FreeInstance = sym("fmi2FreeInstance");
    fmi2SetupExperiment = sym("fmi2SetupExperiment");
    fmi2EnterInitializationMode = sym("fmi2EnterInitializationMode");
    fmi2ExitInitializationMode = sym("fmi2ExitInitializationMode");
    fmi2Terminate = sym("fmi2Terminate");
    fmi2Reset = sym("fmi2Reset");
    fmi2GetReal = sym("fmi2GetReal");
    fmi2SetReal = sym("fmi2SetReal");
    fmi2DoStep = sym("fmi2DoStep");
    fmi2GetFMUstate = sym("fmi2GetFMUstate");
    fmi2SetFMUstate = sym("fmi2SetFMUstate");
    fmi2FreeFMUstate = sym("fmi2FreeFMUstate");
    fmi2SerializedFMUstateSize = sym("fmi2SerializedFMUstateSize");
    fmi2SerializeFMUstate = sym("fmi2SerializeFMUstate");
    fmi2DeSerializeFMUstate = sym("fmi2DeSerializeFMUstate");
    fmi2SetDebugLogging = sym("fmi2SetDebugLogging");

    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    const char *all_categories[] = {"logEvents", "logAll"};
    long rss_start = -1;
    size_t first_peak = 0;

    for (int rep = 0; rep < reps; rep++) {
        struct mallinfo2 mi = mallinfo2();
        baseline_heap = mi.uordblks + mi.hblkhd;
        where = "instantiate";
        fmi2Component c = fmi2Instantiate("memcheck", 1, guid, "file:///tmp", &cb, 0, rep % 2);
        sample_heap();
        if (!c) {
            fprintf(stderr, "rep %d: fmi2Instantiate failed\n", rep);
            return 2;
        }
        if (rep % 3 == 0) CALL(0, fmi2SetDebugLogging(c, 1, 2, all_categories));
        where = "initialize";
        CALL(0, fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0));
        CALL(0, fmi2EnterInitializationMode(c));
        for (size_t i = 0; i < nin; i++) u[i] = 0.0;
        CALL(0, fmi2SetReal(c, in, nin, u));
        CALL(0, fmi2GetReal(c, out, nout, y)); /* outputs in initialization mode */
        CALL(0, fmi2ExitInitializationMode(c));
        where = "steps";
        double t = 0.0;
        fmi2FMUstate mem = NULL, restored = NULL;
        for (int k = 0; k < steps; k++) {
            for (size_t i = 0; i < nin; i++) u[i] = 0.1 * (double)((k * 7 + (int)i * 3) % 11 - 5) / 5.0;
            CALL(0, fmi2SetReal(c, in, nin, u));
            CALL(0, fmi2DoStep(c, t, h, 1));
            t += h;
            CALL(0, fmi2GetReal(c, out, nout, y));
            if (k == steps / 2) {
                where = "FMU state";
                CALL(0, fmi2GetFMUstate(c, &mem));
                CALL(0, fmi2GetFMUstate(c, &mem)); /* overwrite in place */
                size_t size = 0;
                CALL(0, fmi2SerializedFMUstateSize(c, mem, &size));
                fmi2Byte *bytes = malloc(size);
                CALL(0, fmi2SerializeFMUstate(c, mem, bytes, size));
                CALL(0, fmi2DeSerializeFMUstate(c, bytes, size, &restored));
                CALL(3, fmi2DeSerializeFMUstate(c, bytes, size / 2, &restored)); /* damaged */
                free(bytes);
                where = "steps";
            }
        }
        where = "restore";
        CALL(0, fmi2SetFMUstate(c, restored));
        CALL(0, fmi2DoStep(c, t - (steps - steps / 2 - 1) * h, h, 1));
        CALL(0, fmi2SetFMUstate(c, mem));
        CALL(0, fmi2FreeFMUstate(c, &mem));
        if (rep % 2 == 0) CALL(0, fmi2FreeFMUstate(c, &restored)); /* odd reps: freed with the instance */
        where = "rejected calls";
        CALL(3, fmi2DoStep(c, t + 1.0, h, 1));
        CALL(3, fmi2DoStep(c, 0.0, -h, 1));
        CALL(3, fmi2EnterInitializationMode(c));
        CALL(3, fmi2GetReal(c, NULL, 1, y));
        where = "reset";
        CALL(0, fmi2Reset(c));
        CALL(0, fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0));
        CALL(0, fmi2EnterInitializationMode(c));
        CALL(0, fmi2ExitInitializationMode(c));
        CALL(0, fmi2DoStep(c, 0.0, h, 1));
        CALL(0, fmi2Terminate(c));
        fmi2FreeInstance(c);
        if (rep == 0) {
            first_peak = peak_heap;
            rss_start = rss_kib();
        }
    }
    long rss_end = rss_kib();
    printf("reps %d, steps %d: peak heap of one instance %zu bytes (first cycle %zu), "
           "RSS after cycle 1 %ld KiB, after cycle %d %ld KiB, %lu log messages\n",
           reps, steps, peak_heap, first_peak, rss_start, reps, rss_end, n_messages);
    dlclose(lib);
    return 0;
}
