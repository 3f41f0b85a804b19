/* Variadic FMI 2.0 logger callback for the Rust host.
 * fmi2CallbackLogger is `void (*)(void*, const char*, int, const char*, const char*, ...)`;
 * the message is a printf format. We format it with vsnprintf and hand the result to Rust. */
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

/* The componentEnvironment the host passes to fmi2Instantiate points to this struct (see
 * src/ffi.rs `LogEnv`): a Rust sink function (never unwinds) and its data pointer. */
typedef void (*fmi2host_sink_fn)(void *data, const char *instance_name, int status,
                                 const char *category, const char *message);
typedef struct {
    fmi2host_sink_fn sink;
    void *data;
} fmi2host_env;

/* The componentEnvironment pointers handed to live instances. An FMU must pass back the one it
 * was given (FMI 2.0.4 section 2.1.5, fmi2CallbackFunctions); some pass a constant such as
 * (void*)1 instead. A pointer not handed out is never followed: its message goes to the only
 * live instance, or is dropped when several are live. The lock also keeps an environment from
 * being withdrawn (its instance freed) while a message is delivered to it. */
static pthread_mutex_t live_lock = PTHREAD_MUTEX_INITIALIZER;
static void **live_envs = NULL;
static size_t live_count = 0, live_capacity = 0;

/* Registers `env` before it is handed to fmi2Instantiate; 0 when memory ran out. */
int fmi2host_env_register(void *env) {
    int ok = 1;
    pthread_mutex_lock(&live_lock);
    if (live_count == live_capacity) {
        size_t capacity = live_capacity ? 2 * live_capacity : 16;
        void **grown = (void **)realloc(live_envs, capacity * sizeof *grown);
        if (grown == NULL) {
            ok = 0;
        } else {
            live_envs = grown;
            live_capacity = capacity;
        }
    }
    if (ok) {
        live_envs[live_count++] = env;
    }
    pthread_mutex_unlock(&live_lock);
    return ok;
}

/* Withdraws `env` once its instance is freed (or was never created). */
void fmi2host_env_withdraw(void *env) {
    pthread_mutex_lock(&live_lock);
    for (size_t i = 0; i < live_count; i++) {
        if (live_envs[i] == env) {
            live_envs[i] = live_envs[--live_count];
            break;
        }
    }
    pthread_mutex_unlock(&live_lock);
}

static void fmi2host_log_message(void *env, const char *instance_name, int status,
                                 const char *category, const char *message) {
    fmi2host_env *e = NULL;
    pthread_mutex_lock(&live_lock);
    for (size_t i = 0; i < live_count && e == NULL; i++) {
        if (live_envs[i] == env) {
            e = (fmi2host_env *)env;
        }
    }
    if (e == NULL && live_count == 1) {
        e = (fmi2host_env *)live_envs[0];
    }
    if (e != NULL && e->sink != NULL) {
        e->sink(e->data, instance_name, status, category, message);
    }
    pthread_mutex_unlock(&live_lock);
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
