/* Argument parsing, messages and formatting for the command-line tool. */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

int cli_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("meshreduce: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return CLI_FAIL;
}

int cli_fail_err(const mr_error *err)
{
    return cli_fail("%s", err->message[0] ? err->message : mr_status_string(err->status));
}

int cli_fail_in(const char *path, const char *tag, const mr_error *err)
{
    const char *msg = err->message[0] ? err->message : mr_status_string(err->status);
    size_t n = tag ? strlen(tag) : 0;
    if (n && strncmp(msg, tag, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ')
        msg += n + 2;
    n = path ? strlen(path) : 0;
    if (!path || (strncmp(msg, path, n) == 0 && msg[n] == ':'))
        return cli_fail("%s", msg);
    return cli_fail("%s: %s", path, msg);
}

int cli_choose(cli_choice *c, const char *cmd, const char *option, const char *group)
{
    if (!c->given) {
        c->given = option;
        return CLI_OK;
    }
    if (!strcmp(c->given, option))
        return cli_usage_error(cmd, "%s is given twice (%s)", option, group);
    return cli_usage_error(cmd, "%s conflicts with %s (%s)", option, c->given, group);
}

int cli_choose_flag(cli_choice *c, const char *cmd, const char *option, const char *group)
{
    if (c->given && !strcmp(c->given, option))
        return CLI_OK;
    return cli_choose(c, cmd, option, group);
}

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "meshreduce %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n(see 'meshreduce %s --help')\n", cmd);
    va_end(ap);
    return CLI_USAGE;
}

bool cli_flag(int argc, char **argv, int *i, const char *name)
{
    (void)argc;
    if (strcmp(argv[*i], name) != 0)
        return false;
    (*i)++;
    return true;
}

bool cli_value(int argc, char **argv, int *i, const char *name, const char **value)
{
    const char *a = argv[*i];
    size_t n = strlen(name);
    if (strncmp(a, name, n) != 0)
        return false;
    if (a[n] == '=') {
        *value = a + n + 1;
        (*i)++;
        return true;
    }
    if (a[n] != '\0')
        return false;
    if (*i + 1 < argc) {
        *value = argv[*i + 1];
        *i += 2;
    } else {
        *value = NULL;
        (*i)++;
    }
    return true;
}

bool cli_parse_double(const char *s, double *out)
{
    if (!s || !*s)
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (*end != '\0' || errno == ERANGE || !isfinite(v))
        return false;
    *out = v;
    return true;
}

bool cli_parse_int(const char *s, long long *out)
{
    if (!s || !*s)
        return false;
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (*end != '\0' || errno == ERANGE)
        return false;
    *out = v;
    return true;
}

bool cli_parse_count(const char *s, uint64_t *out)
{
    if (!s || !*s || *s == '-')
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || errno == ERANGE || !isfinite(v) || v < 0)
        return false;
    double mult = 1;
    if (*end == 'k' || *end == 'K')
        mult = 1e3, end++;
    else if (*end == 'm' || *end == 'M')
        mult = 1e6, end++;
    else if (*end == 'g' || *end == 'G')
        mult = 1e9, end++;
    if (*end != '\0')
        return false;
    v *= mult;
    if (v > 1.8e19 || v != floor(v))
        return false;
    *out = (uint64_t)v;
    return true;
}

struct ooc_comm *cli_comm;

bool cli_parse_size(const char *s, uint64_t *out)
{
    if (!s || !*s || *s == '-')
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || errno == ERANGE || !isfinite(v) || v < 0)
        return false;
    double mult = 1;
    switch (*end) {
    case 'k': case 'K': mult = 1024.0, end++; break;
    case 'm': case 'M': mult = 1024.0 * 1024, end++; break;
    case 'g': case 'G': mult = 1024.0 * 1024 * 1024, end++; break;
    case 't': case 'T': mult = 1024.0 * 1024 * 1024 * 1024, end++; break;
    default: break;
    }
    if (mult > 1 && *end == 'i')
        end++;
    if (*end == 'b' || *end == 'B')
        end++;
    if (*end != '\0')
        return false;
    v = floor(v * mult);
    if (v > 1.8e19)
        return false;
    *out = (uint64_t)v;
    return true;
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

const char *cli_count(char *buf, size_t cap, unsigned long long n)
{
    char digits[32];
    int len = snprintf(digits, sizeof digits, "%llu", n);
    size_t o = 0;
    for (int i = 0; i < len && o + 2 < cap; i++) {
        if (i > 0 && (len - i) % 3 == 0)
            buf[o++] = ',';
        buf[o++] = digits[i];
    }
    buf[o] = '\0';
    return buf;
}

const char *cli_bytes(char *buf, size_t cap, unsigned long long n)
{
    static const char *units[] = {"B", "KB", "MB", "GB", "TB"};
    double v = (double)n;
    int u = 0;
    while (v >= 1000.0 && u < 4) {
        v /= 1000.0;
        u++;
    }
    if (u == 0)
        snprintf(buf, cap, "%llu B", n);
    else
        snprintf(buf, cap, "%.1f %s", v, units[u]);
    return buf;
}

unsigned long long cli_file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (unsigned long long)sb.st_size : 0;
}

void cli_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

const char *cli_format_name(mr_format f)
{
    switch (f) {
    case MR_FORMAT_OBJ: return "OBJ";
    case MR_FORMAT_PLY: return "PLY";
    case MR_FORMAT_STL: return "STL";
    case MR_FORMAT_XYZ: return "XYZ";
    case MR_FORMAT_GLTF: return "glTF";
    default: return "unknown";
    }
}

bool cli_output_option(int argc, char **argv, int *i, mr_write_options *w)
{
    if (cli_flag(argc, argv, i, "--ascii"))
        w->encoding = MR_ENCODING_ASCII;
    else if (cli_flag(argc, argv, i, "--binary"))
        w->encoding = MR_ENCODING_BINARY_LE;
    else if (cli_flag(argc, argv, i, "--big-endian"))
        w->encoding = MR_ENCODING_BINARY_BE;
    else if (cli_flag(argc, argv, i, "--no-normals"))
        w->write_normals = 0;
    else if (cli_flag(argc, argv, i, "--no-texcoords"))
        w->write_texcoords = 0;
    else if (cli_flag(argc, argv, i, "--no-colors"))
        w->write_colors = 0;
    else
        return false;
    return true;
}

int cli_check_output_path(const char *cmd, const char *out, mr_format format)
{
    if (format == MR_FORMAT_AUTO && mr_format_from_path(out) == MR_FORMAT_AUTO)
        return cli_usage_error(cmd, "cannot tell the output format of '%s' "
                                    "(use .obj, .ply, .stl, .xyz, .gltf or .glb, or --format)",
                               out);
    return CLI_OK;
}

void cli_io_init(cli_io *io, const char *cmd, unsigned accepts)
{
    memset(io, 0, sizeof *io);
    io->cmd = cmd;
    io->accepts = accepts;
    mr_write_options_default(&io->write);
}

int cli_io_option(cli_io *io, int argc, char **argv, int *i)
{
    const char *v;
    const bool report = (io->accepts & CLI_ACCEPT_REPORT) != 0;
    if (io->accepts & CLI_ACCEPT_WRITE) {
        const char *a = argv[*i];
        if (!strcmp(a, "--ascii") || !strcmp(a, "--binary") || !strcmp(a, "--big-endian")) {
            int rc = cli_choose_flag(&io->encoding, io->cmd, a,
                                     "one encoding: --ascii, --binary or --big-endian");
            if (rc != CLI_OK)
                return rc;
        }
        if (cli_output_option(argc, argv, i, &io->write))
            return CLI_OK;
        if (cli_value(argc, argv, i, "--format", &v)) {
            /* the output's format where its name has no extension:
             * /dev/stdout, a FIFO */
            static const struct { const char *name; mr_format f; } names[] = {
                {"obj", MR_FORMAT_OBJ}, {"ply", MR_FORMAT_PLY}, {"stl", MR_FORMAT_STL},
                {"xyz", MR_FORMAT_XYZ}};
            io->write.format = MR_FORMAT_AUTO;
            for (size_t k = 0; v && k < sizeof names / sizeof *names; k++)
                if (!strcmp(v, names[k].name))
                    io->write.format = names[k].f;
            if (io->write.format == MR_FORMAT_AUTO)
                return cli_usage_error(io->cmd, "--format is obj, ply, stl or xyz, got '%s'",
                                       v ? v : "");
            return CLI_OK;
        }
    }
    if ((io->accepts & CLI_ACCEPT_OUTPUT) &&
        (cli_value(argc, argv, i, "-o", &v) || cli_value(argc, argv, i, "--output", &v))) {
        if (!v)
            return cli_usage_error(io->cmd, "-o needs a file name");
        if (io->out)
            return cli_usage_error(io->cmd, "-o is given twice ('%s' and '%s'): one output "
                                            "file at a time", io->out, v);
        io->out = v;
    } else if (report && cli_flag(argc, argv, i, "--stats")) {
        io->stats = true;
    } else if (report && cli_flag(argc, argv, i, "--json")) {
        io->json = true;
    } else if (cli_flag(argc, argv, i, "-q") || cli_flag(argc, argv, i, "--quiet")) {
        io->quiet = true;
    } else {
        return CLI_NO_MATCH;
    }
    return CLI_OK;
}

int cli_io_parse(cli_io *io, int argc, char **argv, cli_option_fn option, void *user)
{
    const bool out_is_file = !(io->accepts & CLI_ACCEPT_OUTPUT);
    for (int i = 1; i < argc;) {
        int rc = cli_io_option(io, argc, argv, &i);
        if (rc == CLI_NO_MATCH && option)
            rc = option(argc, argv, &i, user);
        if (rc == CLI_OK)
            continue;
        if (rc != CLI_NO_MATCH)
            return rc;
        if (argv[i][0] == '-' && argv[i][1] != '\0')
            return cli_usage_error(io->cmd, "unknown option '%s'", argv[i]);
        if (!io->in)
            io->in = argv[i++];
        else if (out_is_file && !io->out)
            io->out = argv[i++];
        else if (out_is_file)
            return cli_usage_error(io->cmd, "too many files ('%s')", argv[i]);
        else
            return cli_usage_error(io->cmd, "one input file at a time (use -o for the output)");
    }
    if (out_is_file && !io->out)
        return cli_usage_error(io->cmd, "needs an input and an output file");
    if (!io->in)
        return cli_usage_error(io->cmd, "no input file given");
    if (!io->out)
        return cli_usage_error(io->cmd, "no output file given (-o FILE)");
    return CLI_OK;
}

int cli_run_job(const cli_io *io, const cli_job *job, void *user)
{
    mr_mesh mesh, result;
    mr_error err;
    mr_mesh_init(&mesh);
    mr_mesh_init(&result);
    double t0 = cli_now();
    if (io->in && mr_mesh_read(io->in, NULL, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    double t1 = cli_now();
    int rc = job->work(io, &mesh, &result, user);
    double t2 = cli_now();
    /* The input is no longer needed: free it before the output is written. */
    mr_mesh_free(&mesh);
    if (rc == CLI_OK && mr_mesh_write(io->out, &result, &io->write, &err) != MR_OK)
        rc = cli_fail_err(&err);
    double t3 = cli_now();
    if (rc == CLI_OK) {
        const cli_times t = {t1 - t0, t2 - t1, t3 - t2};
        if (io->json && job->json)
            job->json(io, &result, &t, user);
        if (io->stats && job->stats)
            job->stats(io, &result, &t, user);
        else if (!io->quiet && !io->json && job->summary)
            job->summary(io, &result, &t, user);
    }
    mr_mesh_free(&result);
    return rc;
}

int cli_obj_materials(const cli_io *io, mr_obj_materials *m)
{
    memset(m, 0, sizeof *m);
    const mr_format out = io->write.format != MR_FORMAT_AUTO ? io->write.format
                                                              : mr_format_from_path(io->out);
    if (!io->in || mr_format_from_path(io->in) != MR_FORMAT_OBJ ||
        (out != MR_FORMAT_OBJ && out != MR_FORMAT_GLTF))
        return CLI_OK;
    mr_error err;
    if (mr_obj_materials_read(io->in, m, &err) != MR_OK)
        return cli_fail_err(&err);
    if (!m->face_material) /* no usemtl: nothing to keep but the library line */
        m->count = 0;
    return CLI_OK;
}

void cli_obj_materials_use(mr_write_options *w, const mr_obj_materials *m, const mr_mesh *out,
                           const char *in_path)
{
    /* each face's material is the mesh's (read, and kept by simplify) */
    const bool on = out->materials && m->count;
    w->mtllib = on ? m->mtllib : NULL;
    w->material_names = on ? (const char *const *)m->names : NULL;
    w->material_count = on ? m->count : 0;
    w->face_material = NULL;
    w->materials_from = in_path; /* a glTF's materials go into an OBJ's library */
}

void cli_summary(const char *out, size_t vertices, size_t triangles, const char *fmt, ...)
{
    char a[32], b[32], detail[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(detail, sizeof detail, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%s: %s vertices, %s triangles (%s)\n", out,
            cli_count(a, sizeof a, vertices), cli_count(b, sizeof b, triangles), detail);
}

void cli_json_io(const cli_io *io)
{
    printf("{\"input\": ");
    cli_json_string(stdout, io->in);
    printf(", \"output\": ");
    cli_json_string(stdout, io->out);
}

int cli_bbox_diagonal(const char *path, const mr_mesh *m, double *diagonal)
{
    mr_stats s;
    mr_error err;
    if (mr_stats_compute(m->positions, 0, m->vertex_count, NULL, 0, &s, &err) != MR_OK)
        return cli_fail_in(path, NULL, &err);
    *diagonal = s.bbox_diagonal;
    return CLI_OK;
}

bool cli_file_has_line(const char *path, const char *word)
{
    const size_t wl = strlen(word);
    FILE *f = wl ? fopen(path, "rb") : NULL;
    if (!f)
        return false;
    char *line = NULL;
    size_t cap = 0;
    bool found = false;
    while (!found && getline(&line, &cap, f) >= 0) {
        const char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        found = strncmp(p, word, wl) == 0 &&
                (p[wl] == ' ' || p[wl] == '\t' || p[wl] == '\r' || p[wl] == '\n' || !p[wl]);
    }
    free(line);
    fclose(f);
    return found;
}
