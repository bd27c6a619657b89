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

/* Print "meshreduce: <message>" to stderr and return CLI_FAIL. */
int cli_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Print the library error and return CLI_FAIL. */
int cli_fail_err(const mr_error *err);
/* Print "meshreduce <cmd>: <message>" and a hint to --help; return CLI_USAGE. */
int cli_usage_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

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
    "  --no-colors      drop vertex colors\n"

/* Match one output option at argv[*i]; returns true when it was one. */
bool cli_output_option(int argc, char **argv, int *i, mr_write_options *w);

/* Usage error unless the output path names a format (checked before any
 * work is done). */
int cli_check_output_path(const char *cmd, const char *out);

/* Format name for messages. */
const char *cli_format_name(mr_format f);

#endif
