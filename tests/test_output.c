/* Writing outputs: interrupted writes, outputs that are not plain new files
 * (links, devices, FIFOs, descriptors), non-finite values, and failures that
 * say why. */
#include "testutil.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ---- helpers ------------------------------------------------------------ */

static void make_triangle(mr_mesh *m)
{
    mr_error err;
    assert_int_equal(mr_mesh_alloc(m, 3, 1, 0, &err), MR_OK);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(m->positions, p, sizeof p);
    m->indices[0] = 0, m->indices[1] = 1, m->indices[2] = 2;
}

/* A fresh, empty directory in the scratch area, its path into buf. */
static void fresh_dir(const char *name, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s", tu_tmp_path(name));
    assert_int_equal(mkdir(buf, 0777), 0);
}

/* The first ".meshreduce-*" file in dir (its path into buf), or false. */
static bool find_temp(const char *dir, char *buf, size_t cap)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    bool found = false;
    struct dirent *e;
    while (!found && (e = readdir(d)))
        if (strncmp(e->d_name, ".meshreduce-", 12) == 0) {
            snprintf(buf, cap, "%s/%s", dir, e->d_name);
            found = true;
        }
    closedir(d);
    return found;
}

static void assert_no_temp(const char *dir)
{
    char tmp[2048];
    if (find_temp(dir, tmp, sizeof tmp))
        fail_msg("temporary file left behind: %s", tmp);
}

/* The file at path reads back as the mesh m. */
static void assert_file_holds(const char *path, const mr_mesh *m)
{
    mr_mesh r;
    mr_error err;
    if (mr_mesh_read(path, NULL, &r, &err) != MR_OK)
        fail_msg("%s", err.message);
    tu_assert_mesh_equal(m, &r);
    mr_mesh_free(&r);
}

static void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* ---- (A) interrupted writes --------------------------------------------- */

/* Start the tool writing a 160 MB OBJ (one thread, so the write takes a
 * while) into dir/big.obj with the given signal dispositions; return its
 * pid once its temporary file has data (so the file is registered and the
 * write is under way). */
static pid_t start_big_write(const char *dest, const char *dir, bool ignore_hangup)
{
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        /* The default actions, whatever the test runner set (a background
         * shell ignores SIGINT), except what the case asks for. */
        signal(SIGINT, SIG_DFL);
        signal(SIGTERM, SIG_DFL);
        signal(SIGHUP, ignore_hangup ? SIG_IGN : SIG_DFL);
        sigset_t none;
        sigemptyset(&none);
        sigprocmask(SIG_SETMASK, &none, NULL);
        alarm(300); /* stays through exec: a tool that hangs dies of SIGALRM */
        execl(MR_CLI_PATH, "meshreduce", "--threads", "1", "generate", "scan", "--triangles",
              "4M", "-q", "-o", dest, (char *)NULL);
        _exit(127);
    }
    char tmp[2048];
    for (int waited = 0; waited < 120000; waited += 2) {
        struct stat sb;
        if (find_temp(dir, tmp, sizeof tmp) && stat(tmp, &sb) == 0 && sb.st_size > 0)
            return pid;
        int status;
        if (waitpid(pid, &status, WNOHANG) == pid)
            fail_msg("the tool ended (status %d) before its temporary file was seen", status);
        sleep_ms(2);
    }
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
    fail_msg("no temporary file appeared in %s", dir);
    return -1;
}

/* Signal the tool in the middle of a large write: it dies of that signal
 * and leaves neither its temporary file nor a destination. */
static void signal_mid_write(int sig, const char *name)
{
    char dir[1024], dest[1100];
    fresh_dir(name, dir, sizeof dir);
    snprintf(dest, sizeof dest, "%s/big.obj", dir);
    pid_t pid = start_big_write(dest, dir, false);
    assert_int_equal(kill(pid, sig), 0);
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!WIFSIGNALED(status))
        fail_msg("expected death by signal %d, got exit status %d", sig,
                 WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    assert_int_equal(WTERMSIG(status), sig);
    assert_no_temp(dir);
    assert_false(tu_file_exists(dest));
}

static void test_sigint_mid_write(void **state)
{
    (void)state;
    signal_mid_write(SIGINT, "sigint");
}

static void test_sigterm_mid_write(void **state)
{
    (void)state;
    signal_mid_write(SIGTERM, "sigterm");
}

static void test_sighup_mid_write(void **state)
{
    (void)state;
    signal_mid_write(SIGHUP, "sighup");
}

/* ---- signals at random moments, under load ---------------------------- */

/* A busy process per core and one more, so that the tool's threads are
 * preempted at any instruction (a loaded machine), until stop_load. */
static int start_load(pid_t *pids, int cap)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    int n = (int)(cores > 0 ? cores : 1) + 1;
    n = n < cap ? n : cap;
    for (int i = 0; i < n; i++) {
        pids[i] = fork();
        assert_true(pids[i] >= 0);
        if (pids[i] == 0) {
            alarm(600);
            for (volatile unsigned long x = 0;; x++)
                ;
        }
    }
    return n;
}

static void stop_load(const pid_t *pids, int n)
{
    for (int i = 0; i < n; i++) {
        kill(pids[i], SIGKILL);
        waitpid(pids[i], NULL, 0);
    }
}

static uint64_t next_random(uint64_t *x)
{
    *x ^= *x << 13;
    *x ^= *x >> 7;
    *x ^= *x << 17;
    return *x;
}

static void spin_us(long us)
{
    struct timespec a, b;
    clock_gettime(CLOCK_MONOTONIC, &a);
    do
        clock_gettime(CLOCK_MONOTONIC, &b);
    while ((b.tv_sec - a.tv_sec) * 1000000L + (b.tv_nsec - a.tv_nsec) / 1000 < us);
}

/*
 * The tool, on two threads, writing a mesh while busy processes load every
 * core, gets SIGTERM (some tries SIGTERM and then SIGINT or SIGTERM again
 * at once) at random moments: half the tries a few microseconds after its
 * temporary file is created (inotify tells the moment: the tool may be
 * preempted there, between creating the file and registering it), the
 * others anywhere in the write. Whatever the moment, no temporary file is
 * left, and the destination is either absent (the tool died of the
 * signal) or complete (it had finished).
 */
static void test_signals_at_random_moments(void **state)
{
    (void)state;
    const bool quick = getenv("MR_TEST_QUICK") != NULL;
    const int tries = quick ? 50 : 80;
    const char *size = quick ? "60k" : "200k";
    /* the complete output, to hold a kept destination against */
    char refdir[1024], ref[1100];
    fresh_dir("random-ref", refdir, sizeof refdir);
    snprintf(ref, sizeof ref, "%s/ref.obj", refdir);
    assert_int_equal(tu_run_cli(tu_fmt("--threads 2 generate scan --triangles %s -q -o %s", size,
                                       ref),
                                NULL),
                     0);
    size_t ref_size;
    char *ref_bytes = tu_read_file(ref, &ref_size);
    assert_non_null(ref_bytes);
    pid_t load[64];
    const int nload = start_load(load, 64);
    uint64_t rng = 0x9e3779b97f4a7c15ull ^ (uint64_t)getpid();
    int killed = 0, finished = 0;
    for (int t = 0; t < tries; t++) {
        char dir[1024], dest[1100];
        fresh_dir(tu_fmt("random-%d", t), dir, sizeof dir);
        snprintf(dest, sizeof dest, "%s/big.obj", dir);
        const int watch = inotify_init1(IN_CLOEXEC);
        assert_true(watch >= 0);
        assert_true(inotify_add_watch(watch, dir, IN_CREATE) >= 0);
        pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
            signal(SIGINT, SIG_DFL);
            signal(SIGTERM, SIG_DFL);
            sigset_t none;
            sigemptyset(&none);
            sigprocmask(SIG_SETMASK, &none, NULL);
            alarm(120);
            execl(MR_CLI_PATH, "meshreduce", "--threads", "2", "generate", "scan",
                  "--triangles", size, "-q", "-o", dest, (char *)NULL);
            _exit(127);
        }
        const uint64_t r = next_random(&rng);
        if (t % 2 == 0) {
            /* at the creation of the temporary file */
            char ev[4096];
            const ssize_t n = read(watch, ev, sizeof ev);
            assert_true(n > 0);
            spin_us((long)(r % 40));
        } else {
            /* anywhere from the file's creation to (about) the write's end */
            char ev[4096];
            assert_true(read(watch, ev, sizeof ev) > 0);
            sleep_ms((long)(r % (quick ? 60 : 150)));
        }
        kill(pid, SIGTERM);
        if ((r >> 8) % 4 == 0)
            kill(pid, (r >> 12) % 2 ? SIGINT : SIGTERM);
        close(watch);
        int status;
        assert_int_equal(waitpid(pid, &status, 0), pid);
        char tmp[2048];
        if (find_temp(dir, tmp, sizeof tmp)) {
            stop_load(load, nload);
            fail_msg("try %d: temporary file left behind: %s", t, tmp);
        }
        if (WIFSIGNALED(status))
            killed++;
        else if (WIFEXITED(status) && WEXITSTATUS(status) == 0)
            finished++;
        else {
            stop_load(load, nload);
            fail_msg("try %d: exit status %d", t, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
        }
        /* a destination is there only complete: the write had ended (the
         * signal may still come before the process exits) */
        if (tu_file_exists(dest)) {
            size_t n;
            char *got = tu_read_file(dest, &n);
            const bool same = got && n == ref_size && memcmp(got, ref_bytes, n) == 0;
            free(got);
            if (!same) {
                stop_load(load, nload);
                fail_msg("try %d: %s is not the complete output", t, dest);
            }
            unlink(dest);
        } else if (!WIFSIGNALED(status)) {
            stop_load(load, nload);
            fail_msg("try %d: finished without its output", t);
        }
        rmdir(dir);
    }
    stop_load(load, nload);
    free(ref_bytes);
    unlink(ref);
    rmdir(refdir);
    print_message("%d tries: %d killed, %d finished first\n", tries, killed, finished);
    assert_true(killed >= tries / 2);
}

/* Under nohup (SIGHUP ignored at start) the tool keeps ignoring it and
 * finishes its output. */
static void test_ignored_hangup_runs_on(void **state)
{
    (void)state;
    char dir[1024], dest[1100];
    fresh_dir("nohup", dir, sizeof dir);
    snprintf(dest, sizeof dest, "%s/big.obj", dir);
    pid_t pid = start_big_write(dest, dir, true);
    assert_int_equal(kill(pid, SIGHUP), 0);
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_true(tu_file_exists(dest));
    assert_no_temp(dir);
    unlink(dest);
}

/* With nothing pending the call does nothing, and writes work after it. */
static void test_remove_pending_idle(void **state)
{
    (void)state;
    char dir[1024], path[1100];
    fresh_dir("idle", dir, sizeof dir);
    snprintf(path, sizeof path, "%s/t.obj", dir);
    mr_remove_pending_files();
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    mr_remove_pending_files();
    assert_file_holds(path, &m);
    mr_mesh_free(&m);
}

/* Several threads write at once (each takes a registry slot). */
typedef struct writer_job {
    char path[1100];
    const mr_mesh *mesh;
    mr_status status;
} writer_job;

static void *write_one(void *arg)
{
    writer_job *job = arg;
    mr_error err;
    job->status = mr_mesh_write(job->path, job->mesh, NULL, &err);
    return NULL;
}

static void test_concurrent_writes(void **state)
{
    (void)state;
    enum { N = 8 };
    char dir[1024];
    fresh_dir("threads", dir, sizeof dir);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 20000, 1, &m, &err), MR_OK);
    writer_job jobs[N];
    pthread_t threads[N];
    for (int i = 0; i < N; i++) {
        snprintf(jobs[i].path, sizeof jobs[i].path, "%s/t%d.%s", dir, i, i % 2 ? "ply" : "obj");
        jobs[i].mesh = &m;
        assert_int_equal(pthread_create(&threads[i], NULL, write_one, &jobs[i]), 0);
    }
    for (int i = 0; i < N; i++) {
        pthread_join(threads[i], NULL);
        assert_int_equal(jobs[i].status, MR_OK);
        assert_file_holds(jobs[i].path, &m);
    }
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* ---- (B) outputs that are not plain new files --------------------------- */

static mr_write_options obj_options(void)
{
    mr_write_options o;
    mr_write_options_default(&o);
    o.format = MR_FORMAT_OBJ; /* device names have no extension */
    return o;
}

/* /dev/null is written, not replaced (as root a rename would replace the
 * device node) and no temporary file is made in /dev. */
static void test_dev_null(void **state)
{
    (void)state;
    struct stat before, after;
    assert_int_equal(stat("/dev/null", &before), 0);
    mr_mesh m;
    make_triangle(&m);
    mr_write_options o = obj_options();
    mr_error err;
    assert_int_equal(mr_mesh_write("/dev/null", &m, &o, &err), MR_OK);
    assert_int_equal(stat("/dev/null", &after), 0);
    assert_true(S_ISCHR(after.st_mode));
    assert_int_equal(after.st_rdev, before.st_rdev);
    assert_int_equal(after.st_ino, before.st_ino);
    assert_no_temp("/dev");

    /* and through the command-line tool, by a link named for the format */
    char dir[1024], link[1100];
    fresh_dir("null", dir, sizeof dir);
    snprintf(link, sizeof link, "%s/null.obj", dir);
    assert_int_equal(symlink("/dev/null", link), 0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -q -o '%s'", link), &out),
                     0);
    free(out);
    assert_int_equal(stat("/dev/null", &after), 0);
    assert_true(S_ISCHR(after.st_mode));
    assert_int_equal(after.st_ino, before.st_ino);
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* A FIFO is written into (a reader gets the whole file) and stays a FIFO. */
static void test_fifo(void **state)
{
    (void)state;
    char dir[1024], fifo[1100], copy[1100];
    fresh_dir("fifo", dir, sizeof dir);
    snprintf(fifo, sizeof fifo, "%s/pipe.ply", dir);
    snprintf(copy, sizeof copy, "%s/copy.ply", dir);
    assert_int_equal(mkfifo(fifo, 0666), 0);
    pid_t reader = fork();
    assert_true(reader >= 0);
    if (reader == 0) {
        alarm(120); /* a child that hangs fails the test instead of blocking it */
        /* copy what comes through the FIFO into a regular file */
        int in = open(fifo, O_RDONLY), out = open(copy, O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (in < 0 || out < 0)
            _exit(1);
        char buf[65536];
        ssize_t n;
        while ((n = read(in, buf, sizeof buf)) > 0)
            if (write(out, buf, (size_t)n) != n)
                _exit(2);
        _exit(n == 0 && close(out) == 0 ? 0 : 3);
    }
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 100000, 1, &m, &err), MR_OK);
    mr_status st = mr_mesh_write(fifo, &m, NULL, &err);
    if (st != MR_OK)
        kill(reader, SIGKILL); /* it may still wait for a writer */
    int status;
    assert_int_equal(waitpid(reader, &status, 0), reader);
    if (st != MR_OK)
        fail_msg("%s", err.message);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    struct stat sb;
    assert_int_equal(lstat(fifo, &sb), 0);
    assert_true(S_ISFIFO(sb.st_mode));
    assert_file_holds(copy, &m);
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* A link to a file in another directory: the target gets the new content
 * and keeps its mode, the link stays a link, and the temporary file was
 * made beside the target (the rename would fail across file systems
 * otherwise) and is gone. */
static void test_symlink_to_file(void **state)
{
    (void)state;
    char a[1024], b[1024], link[1100], target[1100];
    fresh_dir("link-a", a, sizeof a);
    fresh_dir("link-b", b, sizeof b);
    snprintf(target, sizeof target, "%s/target.obj", b);
    snprintf(link, sizeof link, "%s/link.obj", a);
    tu_write_file(target, "old\n", 4);
    assert_int_equal(chmod(target, 0640), 0);
    assert_int_equal(symlink("../link-b/target.obj", link), 0); /* relative to its directory */

    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(link, &m, NULL, &err), MR_OK);
    struct stat sb;
    assert_int_equal(lstat(link, &sb), 0);
    assert_true(S_ISLNK(sb.st_mode));
    char to[1100];
    ssize_t n = readlink(link, to, sizeof to - 1);
    assert_true(n > 0);
    to[n] = '\0';
    assert_string_equal(to, "../link-b/target.obj");
    assert_int_equal(lstat(target, &sb), 0);
    assert_true(S_ISREG(sb.st_mode));
    assert_int_equal(sb.st_mode & 07777, 0640);
    assert_file_holds(target, &m);
    assert_no_temp(a);
    assert_no_temp(b);

    /* the same through the command-line tool */
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -q -o '%s'", link), &out),
                     0);
    free(out);
    assert_int_equal(lstat(link, &sb), 0);
    assert_true(S_ISLNK(sb.st_mode));
    mr_mesh r;
    assert_int_equal(mr_mesh_read(target, NULL, &r, &err), MR_OK);
    assert_int_equal(r.triangle_count, 2000);
    mr_mesh_free(&r);
    mr_mesh_free(&m);
}

/* A new name in a directory reached through a link to another directory. */
static void test_new_name_through_linked_directory(void **state)
{
    (void)state;
    char a[1024], b[1024], via[1300], real[1100];
    fresh_dir("dirlink-a", a, sizeof a);
    fresh_dir("dirlink-b", b, sizeof b);
    char dlink[1200];
    snprintf(dlink, sizeof dlink, "%s/to-b", a);
    assert_int_equal(symlink(b, dlink), 0);
    snprintf(via, sizeof via, "%s/new.stl", dlink);
    snprintf(real, sizeof real, "%s/new.stl", b);
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(via, &m, NULL, &err), MR_OK);
    struct stat sb;
    assert_int_equal(lstat(real, &sb), 0);
    assert_true(S_ISREG(sb.st_mode));
    assert_no_temp(b);
    mr_mesh_free(&m);
}

/* An existing file keeps its permission bits; a new one gets 0666 less the
 * umask. */
static void test_modes(void **state)
{
    (void)state;
    char dir[1024], path[1100], fresh[1100];
    fresh_dir("modes", dir, sizeof dir);
    snprintf(path, sizeof path, "%s/kept.ply", dir);
    snprintf(fresh, sizeof fresh, "%s/fresh.ply", dir);
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    const mode_t modes[] = {0640, 0600, 0604, 0755};
    for (size_t i = 0; i < sizeof modes / sizeof *modes; i++) {
        tu_write_file(path, "old\n", 4);
        assert_int_equal(chmod(path, modes[i]), 0);
        assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
        struct stat sb;
        assert_int_equal(stat(path, &sb), 0);
        assert_int_equal(sb.st_mode & 07777, modes[i]);
        assert_file_holds(path, &m);
    }
    mode_t old_mask = umask(027);
    mr_status st = mr_mesh_write(fresh, &m, NULL, &err);
    umask(old_mask);
    assert_int_equal(st, MR_OK);
    struct stat sb;
    assert_int_equal(stat(fresh, &sb), 0);
    assert_int_equal(sb.st_mode & 07777, 0640);
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* A dangling link is an error that names it and its target; nothing is
 * created, the link stays. */
static void test_dangling_link(void **state)
{
    (void)state;
    char dir[1024], link[1100], target[1100];
    fresh_dir("dangling", dir, sizeof dir);
    snprintf(link, sizeof link, "%s/out.obj", dir);
    snprintf(target, sizeof target, "%s/missing.obj", dir);
    assert_int_equal(symlink("missing.obj", link), 0);
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(link, &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, link);
    tu_assert_contains(err.message, "is a dangling symbolic link (to missing.obj)");
    assert_false(tu_file_exists(target));
    struct stat sb;
    assert_int_equal(lstat(link, &sb), 0);
    assert_true(S_ISLNK(sb.st_mode));
    assert_no_temp(dir);

    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -q -o '%s'", link), &out),
                     1);
    tu_assert_contains(out, "is a dangling symbolic link (to missing.obj)");
    free(out);
    assert_false(tu_file_exists(target));
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* A directory is no output. */
static void test_directory_output(void **state)
{
    (void)state;
    char dir[1024], sub[1100];
    fresh_dir("dirout", dir, sizeof dir);
    snprintf(sub, sizeof sub, "%s/d.obj", dir);
    assert_int_equal(mkdir(sub, 0777), 0);
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(sub, &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "is a directory");
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* /dev/stdout names the open descriptor: when it is a regular file, that
 * file is written in place (same inode), not replaced by a rename. */
static void test_dev_stdout_is_written_in_place(void **state)
{
    (void)state;
    char dir[1024], path[1100];
    fresh_dir("stdout", dir, sizeof dir);
    snprintf(path, sizeof path, "%s/captured.obj", dir);
    tu_write_file(path, "", 0);
    struct stat before, after;
    assert_int_equal(stat(path, &before), 0);
    mr_mesh m;
    make_triangle(&m);
    fflush(stdout);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        alarm(120); /* a child that hangs fails the test instead of blocking it */
        int fd = open(path, O_WRONLY);
        if (fd < 0 || dup2(fd, 1) < 0)
            _exit(10);
        mr_write_options o = obj_options();
        mr_error e;
        _exit(mr_mesh_write("/dev/stdout", &m, &o, &e) == MR_OK ? 0 : 11);
    }
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_int_equal(stat(path, &after), 0);
    assert_int_equal(after.st_ino, before.st_ino);
    assert_file_holds(path, &m);
    assert_no_temp(dir);
    assert_no_temp("/dev");

    /* and a pipe, through the tool: its output is the mesh */
    char link[1100];
    snprintf(link, sizeof link, "%s/out.obj", dir);
    assert_int_equal(symlink("/dev/stdout", link), 0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 20 -q -o '%s'", link), &out),
                     0);
    assert_int_equal(strncmp(out, "# meshreduce", 12), 0);
    mr_mesh r;
    mr_error err;
    assert_int_equal(tu_read_string(out, "out.obj", &r, &err), MR_OK);
    assert_int_equal(r.triangle_count, 20);
    mr_mesh_free(&r);
    free(out);
    struct stat sb;
    assert_int_equal(lstat(link, &sb), 0);
    assert_true(S_ISLNK(sb.st_mode));
    mr_mesh_free(&m);
}

/* ---- (C) non-finite values ---------------------------------------------- */

/* Refused before any file is created: the message names the output, the
 * vertex and the value. */
static void expect_refused(const mr_mesh *m, const char *path, const mr_write_options *o,
                           const char *what)
{
    mr_error err;
    assert_int_equal(mr_mesh_write(path, m, o, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, path);
    tu_assert_contains(err.message, what);
    assert_false(tu_file_exists(path));
}

static void test_non_finite_refused(void **state)
{
    (void)state;
    char dir[1024], path[1100];
    fresh_dir("finite", dir, sizeof dir);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_alloc(&m, 3, 1, MR_ATTR_NORMALS | MR_ATTR_TEXCOORDS |
                                                 MR_ATTR_COLORS, &err),
                     MR_OK);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(m.positions, p, sizeof p);
    for (int i = 0; i < 9; i++)
        m.normals[i] = i % 3 == 2 ? 1.0f : 0.0f;
    for (int i = 0; i < 6; i++)
        m.texcoords[i] = 0.5f;
    for (int i = 0; i < 12; i++)
        m.colors[i] = 1.0f;
    m.indices[0] = 0, m.indices[1] = 1, m.indices[2] = 2;
    mr_write_options o;
    mr_write_options_default(&o);

    const char *exts[] = {"obj", "ply", "stl", "xyz"};
    m.positions[4] = NAN;
    for (int f = 0; f < 4; f++) {
        snprintf(path, sizeof path, "%s/pos.%s", dir, exts[f]);
        expect_refused(&m, path, &o, "vertex 1 has a non-finite position (nan)");
    }
    m.positions[4] = -INFINITY;
    snprintf(path, sizeof path, "%s/neg.ply", dir);
    expect_refused(&m, path, &o, "vertex 1 has a non-finite position (-inf)");
    m.positions[4] = 0;

    /* an existing destination keeps its content */
    snprintf(path, sizeof path, "%s/keep.obj", dir);
    tu_write_file(path, "old\n", 4);
    m.positions[8] = INFINITY;
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_ERR_INVALID_ARGUMENT);
    size_t n;
    char *back = tu_read_file(path, &n);
    assert_string_equal(back, "old\n");
    free(back);
    assert_no_temp(dir);
    m.positions[8] = 0;

    /* attributes count where they are written */
    m.normals[6] = INFINITY;
    snprintf(path, sizeof path, "%s/n.obj", dir);
    expect_refused(&m, path, &o, "vertex 2 has a non-finite normal (inf)");
    snprintf(path, sizeof path, "%s/n.xyz", dir);
    expect_refused(&m, path, &o, "vertex 2 has a non-finite normal (inf)");
    snprintf(path, sizeof path, "%s/n.stl", dir); /* STL computes its normals */
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_OK);
    o.write_normals = 0;
    snprintf(path, sizeof path, "%s/n-dropped.ply", dir);
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_OK);
    o.write_normals = 1;
    m.normals[6] = 0;

    m.texcoords[1] = NAN;
    snprintf(path, sizeof path, "%s/t.ply", dir);
    expect_refused(&m, path, &o, "vertex 0 has a non-finite texture coordinate (nan)");
    snprintf(path, sizeof path, "%s/t.xyz", dir); /* XYZ has no texture coordinates */
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_OK);
    m.texcoords[1] = 0.5f;

    m.colors[3] = NAN; /* alpha: PLY writes it, OBJ does not */
    snprintf(path, sizeof path, "%s/c.ply", dir);
    expect_refused(&m, path, &o, "vertex 0 has a non-finite color (nan)");
    snprintf(path, sizeof path, "%s/c.obj", dir);
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_OK);
    m.colors[3] = 1;
    m.colors[4] = INFINITY;
    snprintf(path, sizeof path, "%s/c2.obj", dir);
    expect_refused(&m, path, &o, "vertex 1 has a non-finite color (inf)");
    o.write_colors = 0;
    assert_int_equal(mr_mesh_write(path, &m, &o, &err), MR_OK);
    assert_no_temp(dir);
    mr_mesh_free(&m);
}

/* ---- (D) failures that say why ------------------------------------------ */

/* /dev/full: small meshes fail when the buffer is flushed at the end,
 * large ones in the writers' own fwrite; both say why, in every format. */
static void test_disk_full(void **state)
{
    (void)state;
    mr_mesh small, big;
    make_triangle(&small);
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 100000, 1, &big, &err), MR_OK);
    const mr_format formats[] = {MR_FORMAT_OBJ, MR_FORMAT_PLY, MR_FORMAT_STL, MR_FORMAT_XYZ};
    const mr_encoding encodings[] = {MR_ENCODING_DEFAULT, MR_ENCODING_ASCII};
    for (int f = 0; f < 4; f++)
        for (int e = 0; e < 2; e++)
            for (int s = 0; s < 2; s++) {
                mr_write_options o;
                mr_write_options_default(&o);
                o.format = formats[f];
                o.encoding = encodings[e];
                mr_status st = mr_mesh_write("/dev/full", s ? &big : &small, &o, &err);
                if (st != MR_ERR_IO)
                    fail_msg("format %d encoding %d mesh %d: status %d", f, e, s, st);
                tu_assert_contains(err.message, "/dev/full: write failed: No space left on device");
            }
    struct stat sb;
    assert_int_equal(stat("/dev/full", &sb), 0);
    assert_true(S_ISCHR(sb.st_mode));
    assert_no_temp("/dev");

    /* the tool exits 1 with the reason */
    char dir[1024], link[1100];
    fresh_dir("full", dir, sizeof dir);
    snprintf(link, sizeof link, "%s/full.ply", dir);
    assert_int_equal(symlink("/dev/full", link), 0);
    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -q -o '%s'", link), &out),
                     1);
    tu_assert_contains(out, "full.ply: write failed: No space left on device");
    free(out);
    mr_mesh_free(&small);
    mr_mesh_free(&big);
}

static void test_missing_directory_and_permission(void **state)
{
    (void)state;
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    char dir[1024], path[1100];
    fresh_dir("perm", dir, sizeof dir);
    snprintf(path, sizeof path, "%s/no/such/dir/out.obj", dir);
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "cannot write");
    tu_assert_contains(err.message, "No such file or directory");

    char *out;
    assert_int_equal(tu_run_cli(tu_fmt("generate sphere --triangles 2k -q -o '%s'", path), &out),
                     1);
    tu_assert_contains(out, "No such file or directory");
    free(out);

    /* a file where a directory should be */
    char file[1100];
    snprintf(file, sizeof file, "%s/plain", dir);
    tu_write_file(file, "x", 1);
    snprintf(path, sizeof path, "%s/plain/out.obj", dir);
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "Not a directory");

    if (geteuid() != 0) { /* root writes anywhere */
        char ro[1050];
        snprintf(ro, sizeof ro, "%s/ro", dir);
        assert_int_equal(mkdir(ro, 0555), 0);
        snprintf(path, sizeof path, "%.1080s/out.obj", ro);
        assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_ERR_IO);
        tu_assert_contains(err.message, "Permission denied");
    }
    mr_mesh_free(&m);
}

/* A write that stops half way (the file size limit) says why and leaves
 * nothing; in a child, so that the limit does not outlive the check. The
 * mesh is made before the fork and written as STL, which uses no OpenMP:
 * a forked child cannot use the parent's thread pool. */
static void test_file_too_large(void **state)
{
    (void)state;
    char dir[1024], path[1100];
    fresh_dir("fsize", dir, sizeof dir);
    snprintf(path, sizeof path, "%s/big.stl", dir);
    mr_mesh big;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_SPHERE, 100000, 1, &big, &err), MR_OK);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        alarm(120); /* a child that hangs fails the test instead of blocking it */
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = {1 << 16, 1 << 16};
        setrlimit(RLIMIT_FSIZE, &rl);
        mr_status st = mr_mesh_write(path, &big, NULL, &err);
        _exit(st == MR_ERR_IO && strstr(err.message, "write failed: File too large") ? 0 : 11);
    }
    mr_mesh_free(&big);
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_false(tu_file_exists(path));
    assert_no_temp(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sigint_mid_write),
        cmocka_unit_test(test_sigterm_mid_write),
        cmocka_unit_test(test_sighup_mid_write),
        cmocka_unit_test(test_ignored_hangup_runs_on),
        cmocka_unit_test(test_signals_at_random_moments),
        cmocka_unit_test(test_remove_pending_idle),
        cmocka_unit_test(test_concurrent_writes),
        cmocka_unit_test(test_dev_null),
        cmocka_unit_test(test_fifo),
        cmocka_unit_test(test_symlink_to_file),
        cmocka_unit_test(test_new_name_through_linked_directory),
        cmocka_unit_test(test_modes),
        cmocka_unit_test(test_dangling_link),
        cmocka_unit_test(test_directory_output),
        cmocka_unit_test(test_dev_stdout_is_written_in_place),
        cmocka_unit_test(test_non_finite_refused),
        cmocka_unit_test(test_disk_full),
        cmocka_unit_test(test_missing_directory_and_permission),
        cmocka_unit_test(test_file_too_large),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
