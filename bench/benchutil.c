#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#include "benchutil.h"
#include <math.h>

#include <sched.h>

#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

double bench_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

bench_summary bench_summarize(double *samples, int n)
{
    bench_summary s = {0, 0, 0};
    if (n <= 0)
        return s;
    qsort(samples, (size_t)n, sizeof *samples, cmp_double);
    s.min = samples[0];
    s.max = samples[n - 1];
    s.median = n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
    return s;
}

void bench_print_machine(FILE *f)
{
    char model[256] = "unknown CPU";
    FILE *c = fopen("/proc/cpuinfo", "r");
    if (c) {
        char line[512];
        while (fgets(line, sizeof line, c))
            if (!strncmp(line, "model name", 10)) {
                const char *v = strchr(line, ':');
                if (v) {
                    snprintf(model, sizeof model, "%s", v + 2);
                    model[strcspn(model, "\n")] = '\0';
                }
                break;
            }
        fclose(c);
    }
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    double mem = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE) / (1 << 30);
    char date[32];
    time_t now = time(NULL);
    strftime(date, sizeof date, "%Y-%m-%d", gmtime(&now));
    fprintf(f, "machine: %s, %ld cores, %.0f GiB, %s, meshreduce %s\n", model, cores, mem, date,
            mr_version());
}

void bench_cpu_info(bench_cpu *cpu)
{
    snprintf(cpu->model, sizeof cpu->model, "unknown CPU");
    cpu->logical = cpu->physical = cpu->nproc = 0;
    /* Distinct (physical id, core id) pairs; a few thousand at most. */
    enum { MAX_CORES = 4096 };
    static long pairs[MAX_CORES];
    int n_pairs = 0, have_model = 0;
    long phys = 0, core = -1;
    FILE *c = fopen("/proc/cpuinfo", "r");
    if (c) {
        char line[512];
        while (fgets(line, sizeof line, c)) {
            const char *v = strchr(line, ':');
            v = v ? v + 1 : line;
            while (*v == ' ' || *v == '\t')
                v++;
            if (!strncmp(line, "processor", 9)) {
                cpu->logical++;
                phys = 0;
                core = -1;
            } else if (!strncmp(line, "model name", 10) && !have_model) {
                snprintf(cpu->model, sizeof cpu->model, "%.255s", v);
                cpu->model[strcspn(cpu->model, "\n")] = '\0';
                have_model = 1;
            } else if (!strncmp(line, "physical id", 11)) {
                phys = atol(v);
            } else if (!strncmp(line, "core id", 7)) {
                core = atol(v);
                long key = phys * 65536 + core;
                int seen = 0;
                for (int i = 0; i < n_pairs && !seen; i++)
                    seen = pairs[i] == key;
                if (!seen && n_pairs < MAX_CORES)
                    pairs[n_pairs++] = key;
            }
        }
        fclose(c);
    }
    cpu->physical = n_pairs;
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0)
        cpu->nproc = CPU_COUNT(&set);
    if (cpu->nproc <= 0)
        cpu->nproc = (int)sysconf(_SC_NPROCESSORS_ONLN);
}

size_t bench_peak_rss(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (size_t)ru.ru_maxrss * 1024;
}

char *bench_capture(const char *cmd)
{
    FILE *p = popen(cmd, "r");
    if (!p)
        return NULL;
    size_t cap = 4096, len = 0, n;
    char *buf = malloc(cap);
    while ((n = fread(buf + len, 1, cap - len - 1, p)) > 0) {
        len += n;
        if (cap - len < 2)
            buf = realloc(buf, cap *= 2);
    }
    buf[len] = '\0';
    if (pclose(p) != 0) {
        free(buf);
        return NULL;
    }
    return buf;
}

const char *bench_python(void)
{
    const char *env = getenv("MR_PYTHON");
    if (env && *env)
        return env;
    return access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
}

bool bench_have_open3d(void)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s -c 'import open3d' >/dev/null 2>&1 && echo yes",
             bench_python());
    char *out = bench_capture(cmd);
    bool ok = out && !strncmp(out, "yes", 3);
    free(out);
    return ok;
}

void bench_check(mr_status st, const mr_error *err)
{
    if (st != MR_OK) {
        fprintf(stderr, "bench: %s\n", err->message);
        exit(1);
    }
}

int bench_load_mesh(const char *data_dir, const char *file, size_t triangles, int threads,
                    mr_mesh *mesh, size_t *degenerate, size_t *unreferenced)
{
    mr_error err;
    mr_mesh_init(mesh);
    if (!file) {
        bench_check(mr_generate(MR_GEN_SCAN, triangles, 1, mesh, &err), &err);
    } else {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", data_dir, file);
        if (access(path, R_OK) != 0)
            return 0;
        mr_read_options ro;
        mr_read_options_default(&ro);
        ro.threads = threads;
        bench_check(mr_mesh_read(path, &ro, mesh, &err), &err);
    }
    free(mesh->normals);
    free(mesh->texcoords);
    free(mesh->colors);
    mesh->normals = mesh->texcoords = mesh->colors = NULL;
    bench_check(mr_mesh_remove_degenerate(mesh, 0, degenerate, &err), &err);
    bench_check(mr_mesh_remove_unreferenced(mesh, unreferenced, &err), &err);
    return 1;
}

bench_run_result bench_run(char *const argv[])
{
    bench_run_result r = {0, 0, -1, NULL};
    int pipefd[2];
    if (pipe(pipefd) != 0)
        return r;
    const double t0 = bench_now();
    const pid_t pid = fork();
    if (pid == 0) {
        dup2(pipefd[1], 1);
        close(pipefd[0]);
        close(pipefd[1]);
        execvp(argv[0], argv);
        _exit(127);
    }
    close(pipefd[1]);
    size_t cap = 1 << 16, len = 0;
    r.out = malloc(cap);
    for (;;) {
        if (cap - len < 4096)
            r.out = realloc(r.out, cap *= 2);
        const ssize_t n = read(pipefd[0], r.out + len, cap - len - 1);
        if (n <= 0)
            break;
        len += (size_t)n;
    }
    r.out[len] = '\0';
    close(pipefd[0]);
    int st;
    struct rusage ru;
    wait4(pid, &st, 0, &ru);
    r.seconds = bench_now() - t0;
    r.rss = (size_t)ru.ru_maxrss * 1024;
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
}

void bench_alternate(char *const *av[2], int n, const char *what, double sec[2][64],
                     size_t rss[2])
{
    rss[0] = rss[1] = 0;
    n = n < 64 ? n : 64;
    for (int r = 0; r < n; r++)
        for (int m = 0; m < 2; m++) {
            const int k = (r & 1) ? 1 - m : m;
            bench_run_result rr = bench_run(av[k]);
            free(rr.out);
            if (rr.status != 0) {
                fprintf(stderr, "%s failed (%d)\n", what, rr.status);
                exit(1);
            }
            sec[k][r] = rr.seconds;
            rss[k] = rr.rss > rss[k] ? rr.rss : rss[k];
        }
}

double bench_json_number(const char *json, const char *key)
{
    char pat[128];
    snprintf(pat, sizeof pat, "\"%s\": ", key);
    const char *p = json ? strstr(json, pat) : NULL;
    return p ? strtod(p + strlen(pat), NULL) : NAN;
}
