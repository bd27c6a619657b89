/*
 * What the formats and the dispatcher share, below both: the read and
 * write options' defaults, all-or-nothing output files (a hidden
 * temporary file renamed into place) with the registry of pending
 * temporary files that a signal handler removes, and the error of a failed
 * write.
 */
#define _GNU_SOURCE /* realpath, lstat, readlink, fchown, gettid under strict C11 */
#include "output.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

void mr_read_options_default(mr_read_options *options)
{
    options->format = MR_FORMAT_AUTO;
    options->threads = 0;
}

void mr_write_options_default(mr_write_options *options)
{
    memset(options, 0, sizeof *options); /* no materials */
    options->format = MR_FORMAT_AUTO;
    options->encoding = MR_ENCODING_DEFAULT;
    options->write_normals = 1;
    options->write_texcoords = 1;
    options->write_colors = 1;
}

/* ------------------------------------------------------------------------ */
/* Pending temporary files                                                  */
/* ------------------------------------------------------------------------ */

/*
 * The temporary files of the writes in progress, for mr_remove_pending_files,
 * which a signal handler may call at any moment on any thread -- also on
 * the thread that is creating a file, between any two of its instructions.
 * So: fixed slots (no allocation, no lock), each claimed by an atomic
 * compare-and-swap, and a slot names its file *before* the file is
 * created:
 *   FILLING   the writer owns it and writes its path (no file of it exists);
 *   CREATING  the path is complete and the file may exist (the writer is
 *             in open()): a handler on another thread waits until the
 *             writer says (PUBLISHED, or FILLING again when no file was
 *             made); a handler on the writer's own thread has stopped it
 *             there and removes the path at once (the process ends before
 *             the writer goes on);
 *   PUBLISHED the file exists; TAKEN: a handler is removing it; REMOVED:
 *             a handler removed it, the writer frees the slot.
 * A writer checks `removing` after announcing CREATING and a handler
 * raises it before reading any slot (both sequentially consistent), so
 * either the handler sees the slot or the writer sees the handler and
 * waits, creating nothing until the removal is over. Writes made when all
 * slots are taken go unregistered: they work, but a signal would leave
 * their file behind.
 */
enum { PENDING_SLOTS = 64 };
enum { SLOT_FREE, SLOT_FILLING, SLOT_CREATING, SLOT_PUBLISHED, SLOT_TAKEN, SLOT_REMOVED };
typedef struct pending_slot {
    atomic_int state;
    atomic_int owner; /* the writer's thread (gettid) */
    atomic_int taker; /* the thread of the handler removing it */
    char path[MR_OUTPUT_PATH_CAP];
} pending_slot;
static pending_slot pending[PENDING_SLOTS];
static atomic_int removing; /* mr_remove_pending_files calls at work */

/* Async-signal-safe only when the atomics need no lock. */
_Static_assert(ATOMIC_INT_LOCK_FREE == 2, "pending-file slots need lock-free atomic int");

/* A short pause, async-signal-safe (clock_nanosleep is on POSIX's list). */
static void pause_briefly(void)
{
    const struct timespec ts = {0, 20000};
    clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

/* Claim a slot for a file this thread is about to create; -1 when all are
 * taken. */
static int pending_claim(void)
{
    for (int i = 0; i < PENDING_SLOTS; i++) {
        int expected = SLOT_FREE;
        if (atomic_compare_exchange_strong(&pending[i].state, &expected, SLOT_FILLING)) {
            atomic_store(&pending[i].owner, (int)gettid());
            return i;
        }
    }
    return -1;
}

/* Name the file about to be created at path: the slot is CREATING on
 * return, and no removal is under way. */
static void pending_arm(int slot, const char *path)
{
    pending_slot *p = &pending[slot];
    for (;;) {
        memcpy(p->path, path, strlen(path) + 1);
        atomic_store(&p->state, SLOT_CREATING);
        if (atomic_load(&removing) == 0)
            return;
        /* a handler is at work (the process is ending, most likely):
         * nothing is created until it is done */
        atomic_store(&p->state, SLOT_FILLING);
        while (atomic_load(&removing) != 0)
            pause_briefly();
    }
}

/* The open() of an armed slot returned: the file exists (made) or not. */
static void pending_opened(int slot, bool made)
{
    if (slot >= 0)
        atomic_store(&pending[slot].state, made ? SLOT_PUBLISHED : SLOT_FILLING);
}

/* Forget a temporary file that has been renamed or removed, or a claimed
 * slot that made none. */
static void pending_drop(int slot)
{
    if (slot < 0)
        return;
    int expected = SLOT_PUBLISHED;
    if (atomic_compare_exchange_strong(&pending[slot].state, &expected, SLOT_FREE))
        return;
    expected = SLOT_FILLING;
    if (atomic_compare_exchange_strong(&pending[slot].state, &expected, SLOT_FREE))
        return;
    /* A handler took it. Once it is done the slot can be reused; while it
     * is still at work (on another thread: the process is ending) leave it. */
    expected = SLOT_REMOVED;
    atomic_compare_exchange_strong(&pending[slot].state, &expected, SLOT_FREE);
}

void mr_remove_pending_files(void)
{
    int saved = errno; /* a handler must not change errno under the code it interrupted */
    atomic_fetch_add(&removing, 1);
    const int me = (int)gettid();
    for (int i = 0; i < PENDING_SLOTS; i++) {
        pending_slot *p = &pending[i];
        for (;;) {
            int st = atomic_load(&p->state);
            if (st == SLOT_PUBLISHED) {
                if (!atomic_compare_exchange_strong(&p->state, &st, SLOT_TAKEN))
                    continue; /* the writer dropped it meanwhile: look again */
                atomic_store(&p->taker, me);
                unlink(p->path);
                atomic_store(&p->state, SLOT_REMOVED);
            } else if (st == SLOT_CREATING) {
                if (atomic_load(&p->owner) == me) {
                    unlink(p->path); /* stopped in its own creation: made or not */
                } else {
                    pause_briefly(); /* the writer's open() will say */
                    continue;
                }
            } else if (st == SLOT_TAKEN && atomic_load(&p->taker) != me) {
                pause_briefly(); /* another handler is removing it: until it is gone */
                continue;
            }
            break;
        }
    }
    atomic_fetch_sub(&removing, 1);
    errno = saved;
}

/* ------------------------------------------------------------------------ */
/* Output files                                                             */
/* ------------------------------------------------------------------------ */

/* Copy a path into a buffer of MR_OUTPUT_PATH_CAP; false when it does not
 * fit with room for the temporary file's name. */
static bool copy_path(char *dst, const char *src)
{
    size_t n = strlen(src);
    if (n + sizeof "/.meshreduce-4294967295-XXXXXX" > MR_OUTPUT_PATH_CAP)
        return false;
    memcpy(dst, src, n + 1);
    return true;
}

/* Directory part of a path ("." when it has none), into buf. */
static void dir_of(const char *path, char *buf, size_t cap)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(buf, cap, ".");
        return;
    }
    size_t n = (size_t)(slash - path);
    if (n == 0)
        n = 1; /* "/file" */
    if (n >= cap)
        n = cap - 1;
    memcpy(buf, path, n);
    buf[n] = '\0';
}

/* True when following `path` leads through a link that lives in /proc
 * (/dev/stdout -> /proc/self/fd/1, /dev/fd/3, /proc/self/fd/3). Such a name
 * stands for an open descriptor, whatever that refers to (a pipe, a
 * terminal, a file the shell opened), so it is written in place as a shell
 * redirection would, never renamed onto. */
static bool names_descriptor(const char *path)
{
    char cur[MR_OUTPUT_PATH_CAP], dir[MR_OUTPUT_PATH_CAP], link[MR_OUTPUT_PATH_CAP];
    if (!copy_path(cur, path))
        return false;
    for (int hop = 0; hop < 16; hop++) {
        dir_of(cur, dir, sizeof dir);
        char *real = realpath(dir, NULL);
        bool in_proc = real && strncmp(real, "/proc/", 6) == 0;
        free(real);
        if (in_proc)
            return true;
        ssize_t n = readlink(cur, link, sizeof link - 1);
        if (n < 0)
            return false; /* not a link: the end of the chain */
        link[n] = '\0';
        int len = link[0] == '/' ? snprintf(cur, sizeof cur, "%s", link)
                                 : snprintf(cur, sizeof cur, "%s/%s", dir, link);
        if (len < 0 || (size_t)len >= sizeof cur)
            return false;
    }
    return false;
}

/* Where and how an output is written: out->dest and out->direct, and in
 * *old the status of the regular file it replaces (*exists). */
static mr_status plan_output(mr_output_file *out, const char *path, struct stat *old,
                             bool *exists, mr_error *err)
{
    *exists = false;
    if (!copy_path(out->dest, path))
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot write: %s", strerror(ENAMETOOLONG));
    if (names_descriptor(path)) {
        out->direct = true;
        return MR_OK;
    }
    struct stat sb;
    if (lstat(path, &sb) != 0)
        /* Nothing there, or a directory on the way is missing or closed:
         * a new file, and creating the temporary file says what is wrong. */
        return MR_OK;
    if (S_ISLNK(sb.st_mode)) {
        if (stat(path, &sb) != 0) {
            int e = errno;
            char to[MR_OUTPUT_PATH_CAP];
            ssize_t n = readlink(path, to, sizeof to - 1);
            to[n < 0 ? 0 : n] = '\0';
            if (e == ENOENT)
                return mr_fail_plain(err, MR_ERR_IO, path,
                                     "is a dangling symbolic link (to %s)", to);
            return mr_fail_plain(err, MR_ERR_IO, path, "cannot follow the symbolic link "
                                 "(to %s): %s", to, strerror(e));
        }
        if (S_ISREG(sb.st_mode)) {
            /* Write the link's target, as cp does: the temporary file goes
             * beside the target and is renamed onto it; the link stays. */
            char *real = realpath(path, NULL);
            if (!real)
                return mr_fail_plain(err, MR_ERR_IO, path,
                                     "cannot resolve the symbolic link: %s", strerror(errno));
            bool fits = copy_path(out->dest, real);
            free(real);
            if (!fits)
                return mr_fail_plain(err, MR_ERR_IO, path, "cannot write its target: %s",
                                     strerror(ENAMETOOLONG));
        }
    }
    if (S_ISDIR(sb.st_mode))
        return mr_fail_plain(err, MR_ERR_IO, path, "is a directory");
    if (!S_ISREG(sb.st_mode)) {
        /* A device (/dev/null), a FIFO or a socket: a rename would replace
         * the node itself (as root even a device), so it is written in
         * place, with no all-or-nothing guarantee. */
        out->direct = true;
        return MR_OK;
    }
    *exists = true;
    *old = sb;
    return MR_OK;
}

static bool temp_name(char *buf, size_t cap, const char *dir, const char *prefix);

/* Create a new temporary file in `dir` (its path into out->tmp, named
 * after this process: .meshreduce-PID-XXXXXX) with the given mode, which
 * the kernel reduces by the umask, registered in a pending slot
 * (out->slot) before it exists. Not mkstemp: its 0600 would have to be
 * widened by reading the umask, and umask() can only be read by setting
 * it, which races with files other threads create. */
static int create_temp(mr_output_file *out, const char *dir, const char *prefix, int access,
                       mode_t mode)
{
    out->slot = pending_claim();
    for (int attempt = 0; attempt < 100; attempt++) {
        if (!temp_name(out->tmp, sizeof out->tmp, dir, prefix))
            break;
        if (out->slot >= 0)
            pending_arm(out->slot, out->tmp);
        int fd = open(out->tmp, access | O_CREAT | O_EXCL | O_CLOEXEC, mode);
        pending_opened(out->slot, fd >= 0);
        if (fd >= 0)
            return fd;
        if (errno != EEXIST)
            break;
    }
    const int e = errno;
    pending_drop(out->slot);
    out->slot = -1;
    errno = e;
    return -1;
}

/* A fresh name for a temporary file in dir, into buf: dir/PREFIXPID-XXXXXX. */
static bool temp_name(char *buf, size_t cap, const char *dir, const char *prefix)
{
    static const char digits[] = "0123456789abcdefghijklmnopqrstuvwxyz"
                                 "ABCDEFGHIJKLMNOPQRSTUVWXYZ";
    static atomic_uint_fast64_t counter;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t r = mr_mix64(atomic_fetch_add(&counter, 1) ^ (uint64_t)getpid() << 40 ^
                          (uint64_t)ts.tv_sec << 30 ^ (uint64_t)ts.tv_nsec);
    char name[7];
    for (int i = 0; i < 6; i++, r /= 62)
        name[i] = digits[r % 62];
    name[6] = '\0';
    int len = snprintf(buf, cap, "%s/%s%ld-%s", dir, prefix, (long)getpid(), name);
    if (len < 0 || (size_t)len >= cap) {
        errno = ENAMETOOLONG; /* not reached: plan_output checked the length */
        return false;
    }
    return true;
}

/* Open a temporary file beside out->dest into *fd; an existing
 * destination's permission bits (and, where allowed, owner and group) carry
 * over. */
static mr_status open_temp(mr_output_file *out, const char *path, const struct stat *old,
                           bool exists, int *fd, mr_error *err)
{
    char dir[MR_OUTPUT_PATH_CAP];
    dir_of(out->dest, dir, sizeof dir);
    /* a new file gets 0666 less the umask, like any created file; a
     * replacement starts private and then gets the old file's bits */
    *fd = create_temp(out, dir, ".meshreduce-", O_WRONLY, exists ? 0600 : 0666);
    if (*fd < 0)
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot write (in %s): %s", dir,
                             strerror(errno));
    if (!exists)
        return MR_OK;
    /* Best effort, as an editor saving a file does: only root may give a
     * file away, and a group only to one of one's own. Before the chmod,
     * since a chown clears set-id bits. */
    if (old->st_uid != geteuid() || old->st_gid != getegid())
        (void)!fchown(*fd, old->st_uid, old->st_gid);
    if (fchmod(*fd, old->st_mode & 07777) != 0) {
        int e = errno;
        close(*fd);
        unlink(out->tmp);
        pending_drop(out->slot);
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot keep its permissions: %s",
                             strerror(e));
    }
    return MR_OK;
}

mr_status mr_output_open(mr_output_file *out, const char *path, mr_error *err)
{
    out->f = NULL;
    out->direct = false;
    out->slot = -1;
    out->tmp[0] = '\0';
    struct stat old;
    bool exists;
    mr_status st = plan_output(out, path, &old, &exists, err);
    if (st != MR_OK)
        return st;
    int fd;
    if (out->direct) {
        /* Opening a FIFO waits for its reader, as a shell redirection does. */
        fd = open(out->dest, O_WRONLY | O_TRUNC | O_CLOEXEC | O_NOCTTY);
        if (fd < 0)
            return mr_fail_plain(err, MR_ERR_IO, path, "cannot open for writing: %s",
                                 strerror(errno));
    } else {
        /* Write next to the destination, then rename: the destination either
         * keeps its old content or gets the complete new file. */
        st = open_temp(out, path, &old, exists, &fd, err);
        if (st != MR_OK)
            return st;
    }
    out->f = fdopen(fd, "wb");
    if (!out->f) {
        int e = errno;
        close(fd);
        if (!out->direct) {
            unlink(out->tmp);
            pending_drop(out->slot);
        }
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot write: %s", strerror(e));
    }
    return MR_OK;
}

/* Flush and close the stream; the errno of the first failure, or 0. */
static int close_stream(FILE *f)
{
    int e = 0;
    errno = 0;
    if (fflush(f) != 0)
        e = errno ? errno : EIO;
    else if (ferror(f))
        e = EIO; /* an earlier failed write whose errno is gone */
    errno = 0;
    if (fclose(f) != 0 && e == 0)
        e = errno ? errno : EIO;
    return e;
}

mr_status mr_output_close(mr_output_file *out, const char *path, mr_status st, mr_error *err)
{
    int e = close_stream(out->f);
    out->f = NULL;
    if (e != 0 && st == MR_OK)
        st = mr_fail_write(err, path, e);
    if (out->direct)
        return st;
    if (st == MR_OK && rename(out->tmp, out->dest) != 0)
        st = mr_fail_plain(err, MR_ERR_IO, path, "cannot move the written file into place: %s",
                           strerror(errno));
    if (st != MR_OK)
        unlink(out->tmp);
    pending_drop(out->slot);
    return st;
}

mr_status mr_output_finish(mr_output_file *out, const char *path, mr_status st, mr_error *err)
{
    int e = close_stream(out->f);
    out->f = NULL;
    if (e != 0 && st == MR_OK)
        st = mr_fail_write(err, path, e);
    if (st != MR_OK)
        mr_output_abandon(out);
    return st;
}

mr_status mr_output_commit(mr_output_file *out, const char *path, mr_error *err)
{
    if (out->direct || !out->tmp[0])
        return MR_OK;
    mr_status st = MR_OK;
    if (rename(out->tmp, out->dest) != 0) {
        st = mr_fail_plain(err, MR_ERR_IO, path, "cannot move the written file into place: %s",
                           strerror(errno));
        unlink(out->tmp);
    }
    pending_drop(out->slot);
    out->slot = -1;
    out->tmp[0] = '\0';
    return st;
}

void mr_output_abandon(mr_output_file *out)
{
    if (out->direct || !out->tmp[0])
        return;
    unlink(out->tmp);
    pending_drop(out->slot);
    out->slot = -1;
    out->tmp[0] = '\0';
}

mr_status mr_fail_write(mr_error *err, const char *name, int errnum)
{
    return mr_fail_plain(err, MR_ERR_IO, name, "write failed: %s",
                         strerror(errnum ? errnum : EIO));
}


/* ------------------------------------------------------------------------ */
/* Scratch files                                                            */
/* ------------------------------------------------------------------------ */

/* The scratch names of this host: .meshreduce-scratch-HOST- before the
 * PID (the host keeps a shared directory's other machines' files apart). */
static void scratch_prefix(char *buf, size_t cap)
{
    char host[256];
    if (gethostname(host, sizeof host) != 0)
        strcpy(host, "host");
    host[sizeof host - 1] = '\0';
    for (char *c = host; *c; c++)
        if (*c == '/' || *c == '-')
            *c = '_';
    snprintf(buf, cap, ".meshreduce-scratch-%s-", host);
}

int mr_scratch_open(const char *dir, mr_error *err)
{
    int e;
#ifdef O_TMPFILE
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd >= 0)
        return fd;
    e = errno;
    if (e != EOPNOTSUPP && e != EISDIR && e != EINVAL) {
        mr_fail_plain(err, MR_ERR_IO, dir, "cannot create a temporary file there: %s",
                      strerror(e));
        return -1;
    }
#endif
    /* No O_TMPFILE here: a named file, registered while it has its name,
     * unlinked at once. */
    mr_output_file f;
    char prefix[300];
    scratch_prefix(prefix, sizeof prefix);
    int nfd = -1;
    if (strlen(dir) + strlen(prefix) + 32 < sizeof f.tmp)
        nfd = create_temp(&f, dir, prefix, O_RDWR, 0600);
    else
        errno = ENAMETOOLONG;
    e = errno;
    if (nfd >= 0) {
        unlink(f.tmp);
        pending_drop(f.slot);
        return nfd;
    }
    mr_fail_plain(err, MR_ERR_IO, dir, "cannot create a temporary file there: %s", strerror(e));
    return -1;
}

size_t mr_scratch_sweep(const char *dir)
{
    char prefix[300];
    scratch_prefix(prefix, sizeof prefix);
    const size_t plen = strlen(prefix);
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    size_t removed = 0;
    const struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        if (strncmp(de->d_name, prefix, plen) != 0)
            continue;
        char *end;
        errno = 0;
        const long pid = strtol(de->d_name + plen, &end, 10);
        if (errno || end == de->d_name + plen || *end != '-' || pid <= 0 || pid == (long)getpid())
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue; /* alive (or not ours to ask): its file */
        char path[MR_OUTPUT_PATH_CAP];
        if (snprintf(path, sizeof path, "%s/%s", dir, de->d_name) < (int)sizeof path &&
            unlink(path) == 0)
            removed++;
    }
    closedir(d);
    return removed;
}
