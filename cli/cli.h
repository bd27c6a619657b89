/* Shared helpers of the meshreduce command-line tool. */
#ifndef MR_CLI_H
#define MR_CLI_H

#include "meshreduce.h"

#include <stdbool.h>
#include <stdio.h>

/* Exit statuses: 0 success, 1 the work failed (bad file, I/O), 2 usage. */
enum { CLI_OK = 0, CLI_FAIL = 1, CLI_USAGE = 2 };

/* One subcommand: name, one-line summary, entry point, usage text. */
typedef struct cli_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv);
    const char *usage;
} cli_command;

extern const cli_command cli_cmd_info, cli_cmd_convert, cli_cmd_generate, cli_cmd_clean,
    cli_cmd_demo;
extern const cli_command cli_cmd_compare, cli_cmd_simplify;
extern const cli_command cli_cmd_weld, cli_cmd_cluster, cli_cmd_render;

/* The ranks of meshreduce-mpi's job, or NULL (meshreduce): simplify's
 * out-of-core path runs on them (src/ooc/comm.h). */
struct ooc_comm;
extern struct ooc_comm *cli_comm;

/* Print "meshreduce: <message>" to stderr and return CLI_FAIL. */
int cli_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Print the library error and return CLI_FAIL. */
int cli_fail_err(const mr_error *err);
/* Print the library error of work on the file `path` and return CLI_FAIL:
 * "meshreduce: PATH: message" (the message as is when it already names
 * PATH, as the readers' do), a leading "TAG: " of the message dropped (the
 * library's name for the step, e.g. "simplify"; tag may be NULL). */
int cli_fail_in(const char *path, const char *tag, const mr_error *err);
/* Print "meshreduce <cmd>: <message>" and a hint to --help; return CLI_USAGE. */
int cli_usage_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/*
 * Options of which at most one may be given (weld's --eps, --eps-rel and
 * --reduce, say): a second one, or the same value option twice, is a usage
 * error naming both, not a silent override. `group` says what they choose,
 * for the message ("one radius: --eps, --eps-rel or --reduce"). Returns
 * CLI_OK for the first one given, else the usage status (message printed).
 */
typedef struct cli_choice {
    const char *given; /* the option given first, or NULL */
} cli_choice;
int cli_choose(cli_choice *c, const char *cmd, const char *option, const char *group);
/* The same for flags, of which a repeat changes nothing and is allowed. */
int cli_choose_flag(cli_choice *c, const char *cmd, const char *option, const char *group);

/*
 * Option matching. At argv[*i], accept "--name VALUE" or "--name=VALUE"
 * (value options) or "--name" (flags). On a match, advance *i past what was
 * consumed and return true. A value option given without its value sets
 * *missing and returns true with *value NULL.
 */
bool cli_flag(int argc, char **argv, int *i, const char *name);
bool cli_value(int argc, char **argv, int *i, const char *name, const char **value);

/* Parse counts like "1000000", "1e6", "250k", "4M", "1G". */
bool cli_parse_count(const char *s, uint64_t *out);
/* Parse a size in bytes: "512M", "4G", "1.5GiB", "64k" (binary units:
 * K = 1024), or a plain count of bytes. */
bool cli_parse_size(const char *s, uint64_t *out);
/* Parse an integer / a floating-point number, the whole string. */
bool cli_parse_int(const char *s, long long *out);
bool cli_parse_double(const char *s, double *out);

/* Monotonic wall clock in seconds. */
double cli_now(void);

/* Format n with thousands separators into buf (returns buf). */
const char *cli_count(char *buf, size_t cap, unsigned long long n);
/* Human-readable byte size ("3.2 MB"). */
const char *cli_bytes(char *buf, size_t cap, unsigned long long n);

/* Size of a file in bytes, or 0 when it cannot be stat'ed. */
unsigned long long cli_file_size(const char *path);

/* Print a JSON string literal (with escapes). */
void cli_json_string(FILE *f, const char *s);

/* Output options shared by every command that writes a mesh. */
#define CLI_OUTPUT_OPTIONS_HELP                                                 \
    "output options:\n"                                                         \
    "  --ascii          text encoding for PLY and STL\n"                        \
    "  --binary         binary little-endian PLY/STL (the default)\n"           \
    "  --big-endian     binary big-endian PLY\n"                                \
    "  --no-normals     drop vertex normals\n"                                  \
    "  --no-texcoords   drop texture coordinates\n"                             \
    "  --no-colors      drop vertex colors\n"                                  \
    "  --format F       obj, ply, stl or xyz: the output's format when its name\n" \
    "                   has no extension (-o /dev/stdout, a FIFO)\n"

/* Match one output option at argv[*i]; returns true when it was one. */
bool cli_output_option(int argc, char **argv, int *i, mr_write_options *w);

/* Usage error unless the output path names a format (checked before any
 * work is done). */
int cli_check_output_path(const char *cmd, const char *out, mr_format format);

/* Format name for messages. */
const char *cli_format_name(mr_format f);

/*
 * Commands that write one mesh (clean, cluster, convert, generate, simplify,
 * weld) share their file arguments, -q/--quiet and, as each accepts them,
 * -o/--output, the output options and --stats/--json.
 */
enum {
    CLI_ACCEPT_OUTPUT = 1u << 0, /* -o/--output FILE; without it OUT is the second file */
    CLI_ACCEPT_WRITE = 1u << 1,  /* the output options (CLI_OUTPUT_OPTIONS_HELP) */
    CLI_ACCEPT_REPORT = 1u << 2, /* --stats and --json */
};

/* Returned by option matchers for an argument that is not theirs. */
enum { CLI_NO_MATCH = -1 };

typedef struct cli_io {
    const char *cmd;        /* the command's name, for messages */
    unsigned accepts;       /* CLI_ACCEPT_* */
    const char *in, *out;   /* in NULL: nothing is read */
    bool stats, json, quiet;
    mr_write_options write;
    cli_choice encoding;    /* --ascii, --binary or --big-endian */
} cli_io;

/* Empty arguments with the default output options. */
void cli_io_init(cli_io *io, const char *cmd, unsigned accepts);

/* Match one shared option at argv[*i]: CLI_OK when it was one (*i advanced),
 * CLI_USAGE when it lacks its value or conflicts with one given before
 * (-o twice, two encodings; message printed), else CLI_NO_MATCH. */
int cli_io_option(cli_io *io, int argc, char **argv, int *i);

/* A command's own options, with the contract of cli_io_option. */
typedef int (*cli_option_fn)(int argc, char **argv, int *i, void *user);

/*
 * Parse a whole command line "IN -o OUT" (or "IN OUT") with the shared
 * options and the command's own (`option`, may be NULL). Returns CLI_OK when
 * both files are given, else the usage status (message printed). The output
 * path is not checked here: see cli_check_output_path.
 */
int cli_io_parse(cli_io *io, int argc, char **argv, cli_option_fn option, void *user);

/* Seconds spent reading the input, working, and writing the output. */
typedef struct cli_times {
    double read, work, write;
} cli_times;

/* How a command prints what a successful run did (only once the output
 * is written). */
typedef void (*cli_report_fn)(const cli_io *io, const mr_mesh *result, const cli_times *t,
                              void *user);

/* The work of a mesh-writing command and its reports. */
typedef struct cli_job {
    /* Make *result (empty on entry) from *mesh (what was read; empty when
     * io->in is NULL). May change *mesh or move it into *result. On failure
     * prints the message and returns the exit status. */
    int (*work)(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user);
    cli_report_fn json;    /* on stdout with --json */
    cli_report_fn stats;   /* on stderr with --stats */
    cli_report_fn summary; /* on stderr otherwise, unless -q/--quiet or --json */
} cli_job;

/*
 * Read io->in (unless NULL), run the job's work, write the result to
 * io->out with io->write (complete or not at all) and print the reports.
 * Returns the exit status.
 */
int cli_run_job(const cli_io *io, const cli_job *job, void *user);

/* An OBJ input's materials kept in an OBJ or glTF output (simplify,
 * convert): when io's input is OBJ and its output OBJ or glTF, m gets the
 * input's mtllib and usemtl names (mr_obj_materials_read; m->count 0:
 * none, or another pair of formats). CLI_OK, or the failure's status
 * (message printed). */
int cli_obj_materials(const cli_io *io, mr_obj_materials *m);
/* Whether a line of the file at path starts with `word` (after blanks). */
bool cli_file_has_line(const char *path, const char *word);
/* Point the write options at m's library and names where the output
 * mesh has materials (each face's is the mesh's), or at none; in_path is
 * the OBJ the libraries are beside (a glTF output takes their colours and
 * textures). */
void cli_obj_materials_use(mr_write_options *w, const mr_obj_materials *m, const mr_mesh *out,
                           const char *in_path);

/* Print "OUT: V vertices, T triangles (DETAIL)" on stderr: the line that
 * tells what a command wrote; DETAIL is formatted from fmt. */
void cli_summary(const char *out, size_t vertices, size_t triangles, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Print the opening of a command's JSON report on stdout:
 * {"input": IN, "output": OUT (the caller goes on and closes it). */
void cli_json_io(const cli_io *io);

/* The bounding-box diagonal of the positions of the mesh read from
 * `path`; CLI_OK, else CLI_FAIL with the message (naming path) printed. */
int cli_bbox_diagonal(const char *path, const mr_mesh *m, double *diagonal);

#endif
