/* Variadic FMI 2.0 logger callback for the Rust host.
 * fmi2CallbackLogger is `void (*)(void*, const char*, int, const char*, const char*, ...)`;
 * the message is a printf format. We format it with vsnprintf and hand the result to Rust,
 * which delivers it to the live instance the componentEnvironment names (src/ffi.rs,
 * `LiveEnvs`): the pointer an FMU passes is never read here. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmi2host_route_fn)(void *env, const char *instance_name, int status,
                                  const char *category, const char *message);

/* Set once by the host before its first FMI 2.0 instance exists. */
static fmi2host_route_fn route = NULL;

void fmi2host_set_route(fmi2host_route_fn f) { route = f; }

static void fmi2host_log_message(void *env, const char *instance_name, int status,
                                 const char *category, const char *message) {
    if (route != NULL) {
        route(env, instance_name, status, category, message);
    }
}

void fmi2host_logger(void *env, const char *instance_name, int status, const char *category,
                     const char *message, ...) {
    char small[1024];
    va_list args;
    if (message == NULL) {
        fmi2host_log_message(env, instance_name, status, category, "(null message)");
        return;
    }
    va_start(args, message);
    int n = vsnprintf(small, sizeof small, message, args);
    va_end(args);
    if (n < 0) {
        fmi2host_log_message(env, instance_name, status, category, message);
        return;
    }
    if ((size_t)n < sizeof small) {
        fmi2host_log_message(env, instance_name, status, category, small);
        return;
    }
    char *big = (char *)malloc((size_t)n + 1);
    if (big == NULL) {
        fmi2host_log_message(env, instance_name, status, category, small);
        return;
    }
    va_start(args, message);
    vsnprintf(big, (size_t)n + 1, message, args);
    va_end(args);
    fmi2host_log_message(env, instance_name, status, category, big);
    free(big);
}

void *fmi2host_calloc(size_t nobj, size_t size) { return calloc(nobj, size); }
void fmi2host_free(void *obj) { free(obj); }
