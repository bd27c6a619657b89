/* meshreduce: command dispatch. Each subcommand lives in its own file. */
#include "cli.h"

#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../src/core/omp_compat.h"

static const cli_command *const commands[] = {
    &cli_cmd_info, &cli_cmd_convert, &cli_cmd_clean, &cli_cmd_generate, &cli_cmd_demo,
    &cli_cmd_simplify, &cli_cmd_compare, &cli_cmd_weld, &cli_cmd_cluster, &cli_cmd_render,
};
enum { N_COMMANDS = sizeof commands / sizeof *commands };

static void print_help(FILE *f)
{
    fprintf(f,
            "meshreduce %s: reduce triangle meshes and point clouds, fast, on every core.\n"
            "\n"
            "usage: meshreduce COMMAND [options]\n"
            "\n"
            "commands:\n",
            mr_version());
    for (int i = 0; i < N_COMMANDS; i++)
        fprintf(f, "  %-10s %s\n", commands[i]->name, commands[i]->summary);
    fprintf(f, "\n"
               "global options (anywhere on the line):\n"
               "  --threads N   worker threads (default: all cores)\n"
               "  --help        help for a command: meshreduce COMMAND --help\n"
               "  --version     print the version\n"
               "\n"
               "Files are read and written as OBJ, PLY (ascii, binary), STL (ascii, binary)\n"
               "or XYZ point lists, by extension; PLY and STL are also recognised by content.\n");
}

/* SIGINT, SIGTERM or SIGHUP in the middle of a write would leave the
 * output's hidden temporary file behind: remove it, then die of the same
 * signal, so that the parent (a shell, make) sees why the tool stopped.
 * The action stays this handler until the files are gone: a second
 * signal (the same or another of the three) meanwhile reaches another
 * thread, whose handler waits for the removal in progress
 * (mr_remove_pending_files) rather than ending the process under it. Then
 * the default action is restored, and the signal, blocked in its
 * handler, is delivered as the handler returns. */
static void on_terminating_signal(int sig)
{
    mr_remove_pending_files();
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    raise(sig);
}

static void install_signal_handlers(void)
{
    static const int signals[] = {SIGINT, SIGTERM, SIGHUP};
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_terminating_signal;
    /* the others wait on this thread, so that the tool dies of the first */
    sigemptyset(&sa.sa_mask);
    for (size_t i = 0; i < sizeof signals / sizeof *signals; i++)
        sigaddset(&sa.sa_mask, signals[i]);
    /* A file-size limit (ulimit -f) fails the write with EFBIG, which the
     * writers report, rather than ending the process. */
    signal(SIGXFSZ, SIG_IGN);
    for (size_t i = 0; i < sizeof signals / sizeof *signals; i++) {
        struct sigaction old;
        /* A signal ignored at start stays ignored: nohup, and the SIGINT of
         * a background job, mean the tool should run on. */
        if (sigaction(signals[i], NULL, &old) == 0 && old.sa_handler == SIG_IGN)
            continue;
        sigaction(signals[i], &sa, NULL);
    }
}

/* Take "--threads N" / "--threads=N" out of argv wherever it stands, so
 * every subcommand honours it. Returns -1 on a bad value. */
static int take_threads(int *argc, char **argv)
{
    int out = 1;
    for (int i = 1; i < *argc;) {
        const char *v = NULL;
        int j = i;
        if (cli_value(*argc, argv, &j, "--threads", &v)) {
            long long n;
            if (!v || !cli_parse_int(v, &n) || n < 0 || n > 4096) {
                fprintf(stderr, "meshreduce: --threads needs a count from 0 (all cores) "
                                "to 4096\n");
                return -1;
            }
            if (n > 0)
                omp_set_num_threads((int)n);
            i = j;
            continue;
        }
        argv[out++] = argv[i++];
    }
    *argc = out;
    argv[out] = NULL;
    return 0;
}

static int dispatch(int argc, char **argv);

#ifdef MR_MPI
/*
 * meshreduce-mpi: the same commands' code on the ranks of an MPI job
 * (mpirun -np N meshreduce-mpi simplify ...): simplify runs out of core
 * with its chunks spread over the ranks (cli_comm), cluster on rank 0.
 * Only rank 0 writes the output and speaks (the others' stdout and
 * stderr go to /dev/null unless MR_MPI_VERBOSE is set): an error any
 * rank meets is agreed on and said once.
 */
#include "../src/ooc/comm.h"

#include <mpi.h>
#include <stdio.h>

static ooc_comm ranks;

int main(int argc, char **argv)
{
    if (!getenv("GOMP_SPINCOUNT") && !getenv("OMP_WAIT_POLICY") &&
        setenv("GOMP_SPINCOUNT", "10000", 0) == 0)
        execv("/proc/self/exe", argv); /* returns only on failure: go on */
    int provided;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "meshreduce-mpi: MPI_Init failed\n");
        return CLI_FAIL;
    }
    ooc_mpi_comm(&ranks);
    cli_comm = &ranks;
    if (ranks.rank != 0 && !getenv("MR_MPI_VERBOSE")) {
        (void)!freopen("/dev/null", "w", stdout);
        (void)!freopen("/dev/null", "w", stderr);
    }
    int rc;
    if (argc >= 2 && strcmp(argv[1], "simplify") && strcmp(argv[1], "cluster") &&
        argv[1][0] != '-') {
        fprintf(stderr, "meshreduce-mpi: runs simplify and cluster on the ranks of an MPI job "
                        "(mpirun -np N meshreduce-mpi simplify IN -o OUT ...); '%s' is "
                        "meshreduce's\n",
                argv[1]);
        rc = CLI_USAGE;
    } else {
        rc = dispatch(argc, argv);
    }
    ooc_mpi_free(&ranks);
    MPI_Finalize();
    return rc;
}
#else
int main(int argc, char **argv)
{
    /* The parallel simplifier meets at a barrier a few thousand times a
     * run. OpenMP's threads wait there by spinning, by default for long
     * (libgomp: 300,000 turns); on a machine whose cores are busy with
     * other work a spinning thread holds the core its partner needs, and
     * a run took 8x longer. A short spin, then sleep, costs nothing on idle
     * cores. libgomp reads its settings when it is loaded, before main:
     * unless the user set one, the tool starts itself again with a short
     * spin (once: the variable is then set). */
    if (!getenv("GOMP_SPINCOUNT") && !getenv("OMP_WAIT_POLICY") &&
        setenv("GOMP_SPINCOUNT", "10000", 0) == 0)
        execv("/proc/self/exe", argv); /* returns only on failure: go on */
    return dispatch(argc, argv);
}
#endif

static int dispatch(int argc, char **argv)
{
    install_signal_handlers();
    if (take_threads(&argc, argv) != 0)
        return CLI_USAGE;
    if (argc < 2) {
        print_help(stderr);
        return CLI_USAGE;
    }
    const char *name = argv[1];
    if (!strcmp(name, "--help") || !strcmp(name, "-h") || !strcmp(name, "help")) {
        if (argc > 2)
            for (int i = 0; i < N_COMMANDS; i++)
                if (!strcmp(argv[2], commands[i]->name)) {
                    fputs(commands[i]->usage, stdout);
                    return CLI_OK;
                }
        print_help(stdout);
        return CLI_OK;
    }
    if (!strcmp(name, "--version") || !strcmp(name, "version")) {
        printf("meshreduce %s\n", mr_version());
        return CLI_OK;
    }
    for (int i = 0; i < N_COMMANDS; i++) {
        if (strcmp(name, commands[i]->name) != 0)
            continue;
        for (int a = 2; a < argc; a++)
            if (!strcmp(argv[a], "--help") || !strcmp(argv[a], "-h")) {
                fputs(commands[i]->usage, stdout);
                return CLI_OK;
            }
        /* Subcommands see their own name as argv[0]. */
        return commands[i]->run(argc - 1, argv + 1);
    }
    fprintf(stderr, "meshreduce: unknown command '%s'\n\n", name);
    print_help(stderr);
    return CLI_USAGE;
}
