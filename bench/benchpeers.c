/* Timed runs of our simplifier and the peers, peak-memory measurement:
 * see benchpeers.h. */
#include "benchpeers.h"

#include <float.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#ifdef MR_HAVE_MESHOPT
#include <meshoptimizer.h>
#endif

/* A /proc/self/status field ("VmRSS", "VmHWM") in bytes, or -1. */
static long long status_bytes(const char *field)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    long long kb = -1;
    size_t n = strlen(field);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, field, n) && line[n] == ':') {
            kb = atoll(line + n + 1);
            break;
        }
    fclose(f);
    return kb < 0 ? -1 : kb * 1024;
}

/* Reset VmHWM to the current resident set (Linux >= 4.0). */
static int reset_peak(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f)
        return 0;
    int ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

double bench_child_peak(bench_job_fn job, void *ctx, int threads)
{
    int fd[2];
    if (pipe(fd) != 0)
        return -1;
    long long parent_rss = status_bytes("VmRSS");
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]);
        close(fd[1]);
        return -1;
    }
    if (pid == 0) {
        close(fd[0]);
        omp_set_num_threads(threads > 0 ? threads : 1);
#ifdef __GLIBC__
        malloc_trim(0);
#endif
        long long peak = -1;
        if (reset_peak()) {
            long long base = status_bytes("VmRSS");
            job(ctx);
            long long hwm = status_bytes("VmHWM");
            if (base >= 0 && hwm >= base)
                peak = hwm - base;
        } else {
            /* Fallback: this child's own peak (it starts at the parent's
             * resident set at the fork) minus that resident set. */
            job(ctx);
            struct rusage ru;
            getrusage(RUSAGE_SELF, &ru);
            long long maxrss = (long long)ru.ru_maxrss * 1024;
            if (parent_rss >= 0 && maxrss >= parent_rss)
                peak = maxrss - parent_rss;
        }
        ssize_t w = write(fd[1], &peak, sizeof peak);
        _exit(w == (ssize_t)sizeof peak ? 0 : 1);
    }
    close(fd[1]);
    long long peak = -1;
    if (read(fd[0], &peak, sizeof peak) != (ssize_t)sizeof peak)
        peak = -1;
    close(fd[0]);
    int status = 0;
    if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
        return -1;
    return (double)peak;
}

typedef struct ours_job {
    const mr_mesh *in;
    mr_simplify_options opt;
} ours_job;

static void ours_once(void *ctx)
{
    ours_job *j = ctx;
    mr_simplified out;
    mr_error err;
    if (mr_simplify(j->in->positions, 0, j->in->vertex_count, j->in->indices,
                    j->in->triangle_count, &j->opt, &out, &err) == MR_OK)
        mr_simplified_free(&out);
}

void bench_run_ours(const mr_mesh *in, const mr_simplify_options *opt, int runs,
                    bench_summary *timing, double *peak_bytes, mr_simplified *out)
{
    double *times = malloc(sizeof(double) * (size_t)runs);
    memset(out, 0, sizeof *out);
    for (int k = 0; k < runs; k++) {
        mr_error err;
        if (k > 0)
            mr_simplified_free(out);
        double t0 = bench_now();
        bench_check(mr_simplify(in->positions, 0, in->vertex_count, in->indices,
                                in->triangle_count, opt, out, &err),
                    &err);
        times[k] = bench_now() - t0;
    }
    *timing = bench_summarize(times, runs);
    free(times);
    ours_job one = {in, *opt};
    one.opt.threads = 1;
    *peak_bytes = bench_child_peak(ours_once, &one, 1);
}

/* ---- peak memory in a fresh process (bench_exec_peak) ---------------------- */

#define RAW_MAGIC 0x3157415252444d4dULL /* "MMDRRAW1" */

int bench_raw_write(const mr_mesh *m, const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    uint64_t head[3] = {RAW_MAGIC, m->vertex_count, m->triangle_count};
    int ok = fwrite(head, sizeof head, 1, f) == 1 &&
             fwrite(m->positions, sizeof(float) * 3, m->vertex_count, f) == m->vertex_count &&
             fwrite(m->indices, sizeof(uint32_t) * 3, m->triangle_count, f) ==
                 m->triangle_count;
    if (fclose(f) != 0)
        ok = 0;
    if (!ok)
        unlink(path);
    return ok ? 0 : -1;
}

double bench_exec_peak(const char *self, const char *raw_path, const mr_simplify_options *opt)
{
    char threads[32], ratio[64], collapse[16], strategy[16], quality[16];
    snprintf(threads, sizeof threads, "%d", opt->threads);
    snprintf(ratio, sizeof ratio, "%.17g", opt->target_ratio);
    snprintf(collapse, sizeof collapse, "%d", (int)opt->collapse);
    snprintf(strategy, sizeof strategy, "%d", (int)opt->strategy);
    snprintf(quality, sizeof quality, "%d", (int)opt->quality);
    char *args[] = {(char *)self, "--peak-child", (char *)raw_path, threads, ratio, collapse,
                    strategy, quality, NULL};
    int fd[2];
    if (pipe(fd) != 0)
        return -1;
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]);
        close(fd[1]);
        return -1;
    }
    if (pid == 0) {
        /* Only async-signal-safe calls until the exec. */
        close(fd[0]);
        if (fd[1] != STDOUT_FILENO) {
            dup2(fd[1], STDOUT_FILENO);
            close(fd[1]);
        }
        execv(self, args);
        _exit(127);
    }
    close(fd[1]);
    char buf[256];
    size_t len = 0;
    ssize_t n;
    while (len < sizeof buf - 1 && (n = read(fd[0], buf + len, sizeof buf - 1 - len)) != 0) {
        if (n < 0)
            break;
        len += (size_t)n;
    }
    buf[len] = '\0';
    close(fd[0]);
    int status = 0;
    if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
        return -1;
    double peak = -1;
    if (sscanf(buf, "peak_bytes %lf", &peak) != 1)
        return -1;
    return peak;
}

int bench_peak_child_main(int argc, char **argv)
{
    if (argc != 8 || strcmp(argv[1], "--peak-child") != 0) {
        fprintf(stderr, "bench: --peak-child RAW THREADS RATIO COLLAPSE STRATEGY QUALITY\n");
        return 2;
    }
    FILE *f = fopen(argv[2], "rb");
    uint64_t head[3];
    if (!f || fread(head, sizeof head, 1, f) != 1 || head[0] != RAW_MAGIC) {
        fprintf(stderr, "bench: --peak-child: cannot read %s\n", argv[2]);
        if (f)
            fclose(f);
        return 1;
    }
    size_t nv = (size_t)head[1], nt = (size_t)head[2];
    float *positions = malloc(sizeof(float) * 3 * (nv ? nv : 1));
    uint32_t *indices = malloc(sizeof(uint32_t) * 3 * (nt ? nt : 1));
    int ok = positions && indices && fread(positions, sizeof(float) * 3, nv, f) == nv &&
             fread(indices, sizeof(uint32_t) * 3, nt, f) == nt;
    fclose(f);
    if (!ok) {
        fprintf(stderr, "bench: --peak-child: %s is short\n", argv[2]);
        return 1;
    }
    mr_simplify_options opt;
    mr_simplify_options_default(&opt);
    opt.threads = atoi(argv[3]);
    opt.target_ratio = strtod(argv[4], NULL);
    opt.collapse = (mr_collapse_kind)atoi(argv[5]);
    opt.strategy = (mr_strategy)atoi(argv[6]);
    opt.quality = (mr_simplify_quality)atoi(argv[7]);
    omp_set_num_threads(opt.threads > 0 ? opt.threads : omp_get_max_threads());
#ifdef __GLIBC__
    malloc_trim(0);
#endif
    int cleared = reset_peak();
    long long base = status_bytes("VmRSS");
    mr_simplified out;
    mr_error err;
    if (mr_simplify(positions, 0, nv, indices, nt, &opt, &out, &err) != MR_OK) {
        fprintf(stderr, "bench: --peak-child: %s\n", err.message);
        return 1;
    }
    long long hwm;
    if (cleared) {
        hwm = status_bytes("VmHWM");
    } else {
        struct rusage ru;
        getrusage(RUSAGE_SELF, &ru);
        hwm = (long long)ru.ru_maxrss * 1024;
    }
    mr_simplified_free(&out);
    free(positions);
    free(indices);
    if (base < 0 || hwm < base)
        return 1;
    printf("peak_bytes %lld\n", hwm - base);
    return fflush(stdout) == 0 ? 0 : 1;
}

void bench_output_free(bench_output *o)
{
    free(o->positions);
    free(o->indices);
    memset(o, 0, sizeof *o);
}

/* Compact an index buffer that refers to the input's vertex array. */
void bench_compact(const mr_mesh *in, const uint32_t *idx, size_t n, bench_output *out)
{
    uint32_t *remap = malloc(sizeof(uint32_t) * (in->vertex_count ? in->vertex_count : 1));
    memset(remap, 0xff, sizeof(uint32_t) * in->vertex_count);
    size_t nv = 0;
    for (size_t i = 0; i < n; i++)
        if (remap[idx[i]] == UINT32_MAX)
            remap[idx[i]] = (uint32_t)nv++;
    out->positions = malloc(sizeof(float) * 3 * (nv ? nv : 1));
    out->indices = malloc(sizeof(uint32_t) * (n ? n : 1));
    for (size_t v = 0; v < in->vertex_count; v++)
        if (remap[v] != UINT32_MAX)
            memcpy(out->positions + 3 * (size_t)remap[v], in->positions + 3 * v,
                   3 * sizeof(float));
    for (size_t i = 0; i < n; i++)
        out->indices[i] = remap[idx[i]];
    out->vertex_count = nv;
    out->triangle_count = n / 3;
    free(remap);
}

#ifdef MR_HAVE_MESHOPT
typedef struct meshopt_job {
    const mr_mesh *in;
    size_t target_indices;
    int sloppy;
} meshopt_job;

static size_t meshopt_call(const meshopt_job *j, unsigned int *dst)
{
    const mr_mesh *in = j->in;
    float result_error = 0;
    if (j->sloppy)
        return meshopt_simplifySloppy(dst, in->indices, 3 * in->triangle_count, in->positions,
                                      in->vertex_count, 3 * sizeof(float), j->target_indices,
                                      FLT_MAX, &result_error);
    return meshopt_simplify(dst, in->indices, 3 * in->triangle_count, in->positions,
                            in->vertex_count, 3 * sizeof(float), j->target_indices, FLT_MAX, 0,
                            &result_error);
}

static void meshopt_once(void *ctx)
{
    meshopt_job *j = ctx;
    unsigned int *dst = malloc(sizeof(unsigned int) * 3 * j->in->triangle_count);
    if (dst)
        meshopt_call(j, dst);
    free(dst);
}
#endif

int bench_have_meshopt(void)
{
#ifdef MR_HAVE_MESHOPT
    return 1;
#else
    return 0;
#endif
}

int bench_meshopt_call(const mr_mesh *in, size_t target_triangles, int sloppy, uint32_t *dst,
                       size_t *index_count, double *seconds)
{
#ifdef MR_HAVE_MESHOPT
    meshopt_job j = {in, 3 * target_triangles, sloppy};
    double t0 = bench_now();
    *index_count = meshopt_call(&j, dst);
    *seconds = bench_now() - t0;
    return 1;
#else
    (void)in, (void)target_triangles, (void)sloppy, (void)dst;
    *index_count = 0;
    *seconds = 0;
    return 0;
#endif
}

double bench_meshopt_peak(const mr_mesh *in, size_t target_triangles, int sloppy)
{
#ifdef MR_HAVE_MESHOPT
    meshopt_job j = {in, 3 * target_triangles, sloppy};
    return bench_child_peak(meshopt_once, &j, 1);
#else
    (void)in, (void)target_triangles, (void)sloppy;
    return -1;
#endif
}

int bench_run_meshopt(const mr_mesh *in, size_t target_triangles, int sloppy, int runs,
                      bench_summary *timing, int *runs_done, double *peak_bytes,
                      bench_output *out)
{
#ifdef MR_HAVE_MESHOPT
    unsigned int *dst = malloc(sizeof(unsigned int) * 3 * (in->triangle_count + 1));
    double *times = malloc(sizeof(double) * (size_t)runs);
    size_t n = 0;
    for (int k = 0; k < runs; k++)
        bench_meshopt_call(in, target_triangles, sloppy, dst, &n, &times[k]);
    *timing = bench_summarize(times, runs);
    *runs_done = runs;
    free(times);
    *peak_bytes = bench_meshopt_peak(in, target_triangles, sloppy);
    bench_compact(in, dst, n, out);
    free(dst);
    return 1;
#else
    (void)in, (void)target_triangles, (void)sloppy, (void)runs, (void)timing, (void)runs_done,
        (void)peak_bytes, (void)out;
    return 0;
#endif
}

int bench_have_openmesh(void)
{
#ifdef MR_OPENMESH_DRIVER
    return 1;
#else
    return 0;
#endif
}

#if defined(MR_OPENMESH_DRIVER) || defined(MR_CGAL_DRIVER)
/* Run a peer driver (the openmesh_decimate / cgal_decimate protocol: lines
 * "input V F", "seconds S" per run, "peak_bytes B", the result in
 * out_path) and read its result back. */
static int run_driver(const char *what, const char *cmd, const mr_mesh *in,
                      const char *out_path, int runs, int keep_output, bench_summary *timing,
                      int *runs_done, double *peak_bytes, bench_output *out)
{
    char *text = bench_capture(cmd);
    if (!text) {
        fprintf(stderr, "bench: the %s driver failed: %s\n", what, cmd);
        return 0;
    }
    double *times = malloc(sizeof(double) * (size_t)runs);
    int nt = 0;
    size_t in_v = 0, in_f = 0;
    *peak_bytes = -1;
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        double x;
        if (sscanf(line, "seconds %lf", &x) == 1 && nt < runs)
            times[nt++] = x;
        else if (sscanf(line, "peak_bytes %lf", &x) == 1)
            *peak_bytes = x;
        else
            sscanf(line, "input %zu %zu", &in_v, &in_f);
    }
    free(text);
    *runs_done = nt;
    if (nt == 0) {
        free(times);
        fprintf(stderr, "bench: no timing from the %s driver\n", what);
        return 0;
    }
    *timing = bench_summarize(times, nt);
    free(times);
    if (in_v != in->vertex_count || in_f != in->triangle_count)
        fprintf(stderr, "bench: note: %s read %zu vertices, %zu faces (ours: %zu, %zu)\n", what,
                in_v, in_f, in->vertex_count, in->triangle_count);
    mr_mesh m;
    mr_error err;
    if (mr_mesh_read(out_path, NULL, &m, &err) != MR_OK) {
        fprintf(stderr, "bench: reading %s's output: %s\n", what, err.message);
        return 0;
    }
    mr_mesh_remove_unreferenced(&m, NULL, &err);
    out->vertex_count = m.vertex_count;
    out->triangle_count = m.triangle_count;
    out->positions = m.positions;
    out->indices = m.indices;
    m.positions = NULL;
    m.indices = NULL;
    mr_mesh_free(&m);
    if (!keep_output)
        unlink(out_path);
    return 1;
}
#endif

int bench_run_openmesh(const mr_mesh *in, const char *in_path, const char *out_path,
                       size_t target_vertices, int runs, double budget, int keep_output,
                       bench_summary *timing, int *runs_done, double *peak_bytes,
                       bench_output *out)
{
#ifdef MR_OPENMESH_DRIVER
    char cmd[3 * 4096 + 64];
    snprintf(cmd, sizeof cmd, "'%s' '%s' '%s' %zu %d %g", MR_OPENMESH_DRIVER, in_path, out_path,
             target_vertices, runs, budget);
    return run_driver("OpenMesh", cmd, in, out_path, runs, keep_output, timing, runs_done,
                      peak_bytes, out);
#else
    (void)in, (void)in_path, (void)out_path, (void)target_vertices, (void)runs, (void)budget,
        (void)keep_output, (void)timing, (void)runs_done, (void)peak_bytes, (void)out;
    return 0;
#endif
}

int bench_have_cgal(void)
{
#ifdef MR_CGAL_DRIVER
    return access(MR_CGAL_DRIVER, X_OK) == 0;
#else
    return 0;
#endif
}

int bench_run_cgal(const char *policy, const mr_mesh *in, const char *in_path,
                   const char *out_path, size_t target_edges, int runs, double budget,
                   int keep_output, bench_summary *timing, int *runs_done, double *peak_bytes,
                   bench_output *out)
{
#ifdef MR_CGAL_DRIVER
    if (!bench_have_cgal())
        return 0;
    char cmd[3 * 4096 + 64];
    snprintf(cmd, sizeof cmd, "'%s' '%s' '%s' %s %zu %d %g", MR_CGAL_DRIVER, in_path, out_path,
             policy, target_edges, runs, budget);
    return run_driver("CGAL", cmd, in, out_path, runs, keep_output, timing, runs_done,
                      peak_bytes, out);
#else
    (void)policy, (void)in, (void)in_path, (void)out_path, (void)target_edges, (void)runs,
        (void)budget, (void)keep_output, (void)timing, (void)runs_done, (void)peak_bytes,
        (void)out;
    return 0;
#endif
}

static int u64_cmp(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

size_t bench_edge_count(const uint32_t *indices, size_t triangle_count)
{
    uint64_t *e = malloc(sizeof *e * 3 * (triangle_count ? triangle_count : 1));
    if (!e)
        return 0;
    for (size_t t = 0; t < triangle_count; t++)
        for (int j = 0; j < 3; j++) {
            const uint64_t a = indices[3 * t + j], b = indices[3 * t + (j + 1) % 3];
            e[3 * t + (size_t)j] = a < b ? a << 32 | b : b << 32 | a;
        }
    qsort(e, 3 * triangle_count, sizeof *e, u64_cmp);
    size_t n = 0;
    for (size_t i = 0; i < 3 * triangle_count; i++)
        n += i == 0 || e[i] != e[i - 1];
    free(e);
    return n;
}
