/* meshreduce simplify IN -o OUT: greedy quadric-error edge collapse. */
#include "cli.h"
#include "../src/ooc/comm.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage[] =
    "usage: meshreduce simplify IN -o OUT TARGET [options]\n"
    "\n"
    "Reduce a triangle mesh by greedy quadric-error edge collapse (Garland-Heckbert),\n"
    "keeping it manifold, its boundaries and attribute seams in place. Normals,\n"
    "texture coordinates and colors are carried through. Where an open border or a\n"
    "seam turns sharply between straight runs (a tile's or a decal's corner), its\n"
    "vertex stays where it is unless the target cannot be reached otherwise.\n"
    "\n"
    "glTF (.gltf, .glb) into glTF keeps the document: each mesh's triangle\n"
    "primitives are simplified on their own (--ratio for each; --triangles and\n"
    "--vertices split over them by their triangles), with their materials; the\n"
    "scene, nodes, skins, animations and extensions stay as they were. JOINTS,\n"
    "WEIGHTS, more UV sets and morph targets are the surviving vertex's; TANGENT is\n"
    "dropped (a note says so). Compressed geometry (Draco, meshopt) is refused.\n"
    "Into another format, a glTF file is its scene's triangles in world space.\n"
    "\n"
    "targets (the first one reached stops; at least one is needed):\n"
    "  --ratio R             keep this fraction of the vertices: 0.1 or 10%\n"
    "  --vertices N          keep N vertices\n"
    "                        (both count points of the surface: the copies of a vertex\n"
    "                        that a UV seam or hard edge splits count once)\n"
    "  --triangles N         keep N triangles; 0: as few as --max-error allows (or,\n"
    "                        without it, as the rules allow)\n"
    "  --max-error E         stop before a collapse whose error exceeds E, relative\n"
    "                        to the diagonal of the input's bounding box (all its\n"
    "                        vertices, as `meshreduce info` prints it; 0.001 = 0.1%)\n"
    "  --absolute            --max-error is in model units\n"
    "The error of a collapse is a quadric error: the RMS distance of the merged\n"
    "vertex to the planes of the original triangles it stands for (area-weighted),\n"
    "not a Hausdorff bound; `meshreduce compare` measures the surface distance.\n"
    "--stats and --json report the largest one as max_error, in the same units.\n"
    "A target that the rules do not allow (locked vertices, every remaining collapse\n"
    "refused by the topology or normal tests) is reported as a warning on stderr and\n"
    "as \"target_reached\": false in --json; the exit status stays 0.\n"
    "\n"
    "options:\n"
    "  -o, --output FILE     output file (required)\n"
    "  --collapse full|half  full: both ends move to the optimal position (default);\n"
    "                        half: one end moves onto the other\n"
    "  --strategy greedy|batched|ppq|rppq|fppq|multiqueue|partitioned|\n"
    "             partitioned-boundary\n"
    "                        batched: passes over all edges, cheapest first, at\n"
    "                        most one collapse per vertex a pass (default);\n"
    "                        greedy: always the single cheapest collapse, from a\n"
    "                        heap (the reference; about 5x slower);\n"
    "                        ppq, rppq, fppq, multiqueue: greedy's vertex queue on\n"
    "                        a concurrent priority queue, threads collapsing at\n"
    "                        once under vertex locks. Relaxed: the output may vary\n"
    "                        with the thread count and the timing; half-edge\n"
    "                        collapse only (--collapse half). What each keeps:\n"
    "                        ppq: strict pops of the root (on one thread the same\n"
    "                        output as greedy --collapse half); rppq: every pop\n"
    "                        among the top n_t = 2^(L+1) - 1 nodes of the heap (no\n"
    "                        rank bound); fppq: every pop among the best\n"
    "                        k = L*2^L + 1 (L filter levels); multiqueue: none\n"
    "                        beyond \"usually near the top\"\n"
    "                        partitioned: vertices in slabs along the longest axis;\n"
    "                        each pass every slab applies its interior collapses\n"
    "                        (both ends' 1-rings in the slab) in cost order on its\n"
    "                        own thread; then the edges across slabs, by slabs\n"
    "                        shifted half a slab where they fit in one, the rest\n"
    "                        in one global order; the same bytes at every thread\n"
    "                        count for a given --partitions\n"
    "                        partitioned-boundary: the same slabs, but each pass\n"
    "                        takes a batch of collapses whose neighbourhoods do\n"
    "                        not touch (claims), per slab and then across slabs\n"
    "                        in one global walk, and applies each batch on every\n"
    "                        thread; rebalances when counts say the slabs are\n"
    "                        stale (--stats says which); same-bytes rule as above\n"
    "  --partitions P        partitioned(-boundary): P slabs, 1..4096 (default 16,\n"
    "                        a constant: not the thread count, so that the output\n"
    "                        does not depend on it)\n"
    "  --quality default|best\n"
    "                        best: full collapse only; Lindstrom-Turk's collapses\n"
    "                        (each survivor where its triangles sweep the least\n"
    "                        volume, the enclosed volume kept; the cheapest sweep\n"
    "                        first) and at the end the vertices fitted to the\n"
    "                        input's surface (least squares, no triangle flips):\n"
    "                        lower RMS and Hausdorff distance, 5-15x the time;\n"
    "                        boundary, seam and locked vertices keep the quadric's\n"
    "                        placement\n"
    "  --filter-levels L     fppq, rppq: L = 1..12 (default from --threads: 1 up to\n"
    "                        4 threads, 2 up to 8, 3 up to 16, 4 up to 32)\n"
    "  --multiqueue-factor C multiqueue: C heaps per thread (default 2)\n"
    "  --lock-border         never move boundary vertices\n"
    "  --seams auto|free|keep\n"
    "                        attribute seams: keep holds them (a seam vertex\n"
    "                        slides along its seam; where islands meet it stays);\n"
    "                        free lets them go from the start, priced by the\n"
    "                        attribute cost (meshoptimizer's permissive mode);\n"
    "                        auto (default) holds them, frees them in a last\n"
    "                        stage when the target needs it, and from the start\n"
    "                        where they lock a tenth of the surface or more\n"
    "  --prune               drop the disconnected pieces no larger than the error\n"
    "                        bound (--max-error, or the largest collapse error made;\n"
    "                        their bounding-box diagonal), never the largest piece\n"
    "                        by that diagonal\n"
    "  --lock FILE           never move these vertices: 0-based indices in the\n"
    "                        input's vertex order (OBJ's v lines, PLY's vertex\n"
    "                        element), separated by spaces, commas or lines; # starts\n"
    "                        a comment\n"
    "  --boundary-weight W   weight of the quadrics that hold boundaries and seams\n"
    "                        (default 1, 0 = none)\n"
    "  --max-normal-turn D   refuse collapses that turn a triangle by more than D\n"
    "                        degrees (default 60)\n"
    "  --lods F1,F2,...      levels of detail instead of one output: level k keeps\n"
    "                        Fk of the input's triangles (\"50%,25%,10%,2%\"),\n"
    "                        simplified from level k-1; OUT gets the input, level k\n"
    "                        goes to OUT's name with .lodK before its extension;\n"
    "                        each level's Hausdorff and RMS distance to the input\n"
    "                        are reported, and its error: the largest Hausdorff\n"
    "                        distance so far\n"
    "  --attribute-weights normal=W,uv=W,color=W\n"
    "                        the attributes' part in the collapse cost: each one's\n"
    "                        deviation times W counts as that fraction of the\n"
    "                        bounding-box diagonal (normals per unit vector, UVs\n"
    "                        per unit of their larger extent, colours per unit);\n"
    "                        defaults normal=0.5,uv=0.25,color=1; 0 or none: only\n"
    "                        interpolated (the errors reported include them)\n"
    "\n"
    "inputs larger than memory (binary PLY, binary STL, OBJ; others are read whole):\n"
    "  --memory SIZE         memory budget (default 4G; K, M, G, T are powers of\n"
    "                        1024). An input whose simplification in memory needs\n"
    "                        more (about 160 bytes a triangle) is simplified out of\n"
    "                        core: cut into chunks that fit, each simplified with\n"
    "                        the vertices it shares with its neighbours locked,\n"
    "                        then neighbouring chunks merged up a tree, their\n"
    "                        shared cut unlocked and reduced, each vertex's quadric\n"
    "                        carried from below, to the last one, which meets the\n"
    "                        target. The chunks depend on the input and SIZE only:\n"
    "                        the same bytes on any machine and thread count. An\n"
    "                        output over 3/4 of a chunk (about SIZE/270 triangles)\n"
    "                        stays as several top chunks, each to its share, whose\n"
    "                        cuts are then reduced in bands, written as one PLY\n"
    "                        stream (other formats: a larger SIZE). Binary PLY,\n"
    "                        binary STL and OBJ are read in passes. Normals,\n"
    "                        texture coordinates and colors (PLY, OBJ) travel\n"
    "                        through the chunks, seams across the cuts and the\n"
    "                        bands too\n"
    "  --temp-dir DIR        temporary files (default: $TMPDIR, else the output's\n"
    "                        directory); they have no name (O_TMPFILE), so nothing\n"
    "                        is left behind however the process ends, SIGKILL\n"
    "                        included. Where the file system lacks O_TMPFILE each is\n"
    "                        named .meshreduce-scratch-HOST-PID-... for the moment\n"
    "                        it takes to unlink it, and a later run removes such\n"
    "                        names of processes that no longer exist\n"
    "  --temp-budget SIZE    fail with a clear error rather than let the temporary\n"
    "                        files pass SIZE (default: no limit; about 12 bytes an\n"
    "                        input triangle at most)\n"
    "--stats and --json say which path ran, the chunks, the levels of the tree\n"
    "and their time, and the temporary disk used.\n"
    "\n"
    "  --stats               print counts, largest error and time per phase\n"
    "  --json                print them as one JSON object on stdout\n"
    "  -q, --quiet           no progress, note or summary on success (--stats and\n"
    "                        --json still print)\n"
    "\n" CLI_OUTPUT_OPTIONS_HELP;

/* A progress bar on stderr, only when it is a terminal and the work has
 * taken more than a second. */
typedef struct progress {
    double start;
    int shown;
    int last_percent;
} progress;

static int show_progress(double fraction, void *user)
{
    progress *p = user;
    if (cli_now() - p->start < 1.0)
        return 0;
    int percent = (int)(fraction * 100.0 + 0.5);
    if (percent == p->last_percent)
        return 0;
    p->last_percent = percent;
    p->shown = 1;
    char bar[41];
    int fill = percent * 40 / 100;
    for (int i = 0; i < 40; i++)
        bar[i] = i < fill ? '#' : ' ';
    bar[40] = '\0';
    fprintf(stderr, "\rsimplifying [%s] %3d%%", bar, percent);
    fflush(stderr);
    return 0; /* go on: Ctrl-C ends the process (cli/main.c's handler) */
}

/* "0.1" or "10%" -> 0.1 */
static bool parse_ratio(const char *s, double *out)
{
    if (!s)
        return false;
    char buf[64];
    size_t n = strlen(s);
    if (n == 0 || n >= sizeof buf)
        return false;
    memcpy(buf, s, n + 1);
    double scale = 1.0;
    if (buf[n - 1] == '%') {
        buf[n - 1] = '\0';
        scale = 0.01;
    }
    double v;
    if (!cli_parse_double(buf, &v))
        return false;
    *out = v * scale;
    return true;
}

/* Levels of detail --lods takes at most. */
#define MAX_LODS 16

/* The options and the statistics of one run. */
typedef struct simplify_job {
    mr_simplify_options o;
    mr_simplify_stats s;
    const char *lock_path; /* --lock FILE */
    uint8_t *lock;         /* its vertices, one byte per input vertex */
    mr_out_of_core_options ooc;
    bool ooc_given;        /* --memory, --temp-dir or --temp-budget */
    const mr_simplify_file_stats *fs; /* the file path's figures, or NULL */
    double lods[MAX_LODS]; /* --lods: fractions of the input's triangles */
    size_t nlods;
    mr_obj_materials mats;    /* an OBJ into an OBJ: its usemtl groups */
    mr_write_options *write;  /* where the output's go: the io's options */
} simplify_job;

/*
 * --lock FILE: vertex indices (0-based, in the input's vertex order),
 * separated by white space or commas, '#' to the end of a line a comment.
 * Fills job->lock for a mesh of vertex_count vertices; an unreadable file
 * or a word that is no vertex index is an error naming the file and line.
 */
static int read_locks(simplify_job *job, size_t vertex_count)
{
    FILE *f = fopen(job->lock_path, "rb");
    if (!f)
        return cli_fail("%s: cannot open for reading: %s", job->lock_path, strerror(errno));
    job->lock = calloc(vertex_count ? vertex_count : 1, 1);
    if (!job->lock) {
        fclose(f);
        return cli_fail("%s: out of memory", job->lock_path);
    }
    char word[64];
    size_t len = 0, line = 1, word_line = 1;
    bool comment = false;
    int rc = CLI_OK;
    for (int ch = 0; ch != EOF && rc == CLI_OK;) {
        ch = fgetc(f);
        const bool sep = ch == EOF || ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' ||
                         ch == ',' || ch == '#';
        if (!sep && !comment) {
            if (len == 0)
                word_line = line;
            if (len + 1 < sizeof word)
                word[len] = (char)ch;
            len++;
            continue;
        }
        if (len) {
            uint64_t v;
            if (len >= sizeof word) {
                rc = cli_fail("%s:%zu: '%.20s...' is no vertex index", job->lock_path,
                              word_line, word);
            } else {
                word[len] = '\0';
                if (!cli_parse_count(word, &v) || strpbrk(word, "kKmMeE."))
                    rc = cli_fail("%s:%zu: '%s' is no vertex index (0-based integers)",
                                  job->lock_path, word_line, word);
                else if (v >= vertex_count)
                    rc = cli_fail("%s:%zu: vertex %s does not exist (the mesh has %zu "
                                  "vertices, 0 to %zu)",
                                  job->lock_path, word_line, word, vertex_count,
                                  vertex_count ? vertex_count - 1 : 0);
                else
                    job->lock[v] = 1;
            }
            len = 0;
        }
        if (ch == '#')
            comment = true;
        if (ch == '\n') {
            comment = false;
            line++;
        }
    }
    if (rc == CLI_OK && ferror(f))
        rc = cli_fail("%s: read failed: %s", job->lock_path, strerror(errno));
    fclose(f);
    if (rc == CLI_OK)
        job->o.vertex_lock = job->lock;
    return rc;
}

/* --lods: fractions ("50%" or "0.5") separated by commas, decreasing. */
static bool parse_lods(const char *v, simplify_job *job)
{
    char buf[512];
    if (!*v || strlen(v) >= sizeof buf)
        return false;
    strcpy(buf, v);
    job->nlods = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok;
         tok = strtok_r(NULL, ",", &save)) {
        double f;
        if (job->nlods == MAX_LODS || !parse_ratio(tok, &f) || !(f > 0 && f < 1) ||
            (job->nlods && !(f < job->lods[job->nlods - 1])))
            return false;
        job->lods[job->nlods++] = f;
    }
    return job->nlods > 0;
}

/* --attribute-weights: "none", or NAME=W pairs separated by commas (the
 * names not given keep their weights). */
static bool parse_attribute_weights(const char *v, mr_simplify_options *o)
{
    if (strcmp(v, "none") == 0) {
        o->normal_weight = o->uv_weight = o->color_weight = 0;
        return true;
    }
    char buf[256];
    if (!*v || strlen(v) >= sizeof buf)
        return false;
    strcpy(buf, v);
    double w[3] = {o->normal_weight, o->uv_weight, o->color_weight};
    static const char *const names[3] = {"normal", "uv", "color"};
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok;
         tok = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(tok, '=');
        if (!eq)
            return false;
        *eq = 0;
        int k = 0;
        while (k < 3 && strcmp(tok, names[k]) != 0)
            k++;
        double x;
        if (k == 3 || !cli_parse_double(eq + 1, &x) || !(x >= 0) || !isfinite(x))
            return false;
        w[k] = x;
    }
    o->normal_weight = w[0];
    o->uv_weight = w[1];
    o->color_weight = w[2];
    return true;
}

static int option(int argc, char **argv, int *i, void *user)
{
    mr_simplify_options *o = &((simplify_job *)user)->o;
    const char *v;
    uint64_t n;
    double x;
    if (cli_value(argc, argv, i, "--ratio", &v)) {
        if (!parse_ratio(v, &x) || !(x > 0.0 && x <= 1.0))
            return cli_usage_error("simplify", "--ratio needs a fraction in (0, 1] or a "
                                               "percentage in (0%%, 100%%], got '%s'",
                                   v ? v : "");
        o->target_ratio = x;
    } else if (cli_value(argc, argv, i, "--vertices", &v)) {
        if (!cli_parse_count(v, &n) || n == 0)
            return cli_usage_error("simplify", "--vertices needs a positive count");
        o->target_vertices = (size_t)n;
    } else if (cli_value(argc, argv, i, "--triangles", &v)) {
        if (!cli_parse_count(v, &n))
            return cli_usage_error("simplify", "--triangles needs a count (0: as far as "
                                               "--max-error allows)");
        o->target_triangles = (size_t)n;
        o->until_error = n == 0;
    } else if (cli_value(argc, argv, i, "--max-error", &v)) {
        if (!cli_parse_double(v, &x) || !(x > 0))
            return cli_usage_error("simplify", "--max-error needs a positive number");
        o->max_error = x;
    } else if (cli_flag(argc, argv, i, "--absolute")) {
        o->error_absolute = 1;
    } else if (cli_value(argc, argv, i, "--collapse", &v)) {
        if (v && !strcmp(v, "full"))
            o->collapse = MR_COLLAPSE_FULL;
        else if (v && !strcmp(v, "half"))
            o->collapse = MR_COLLAPSE_HALF;
        else
            return cli_usage_error("simplify", "--collapse is full or half");
    } else if (cli_value(argc, argv, i, "--strategy", &v)) {
        if (v && !strcmp(v, "greedy"))
            o->strategy = MR_STRATEGY_GREEDY;
        else if (v && !strcmp(v, "batched"))
            o->strategy = MR_STRATEGY_BATCHED;
        else if (v && !strcmp(v, "ppq"))
            o->strategy = MR_STRATEGY_PPQ;
        else if (v && !strcmp(v, "rppq"))
            o->strategy = MR_STRATEGY_RPPQ;
        else if (v && !strcmp(v, "fppq"))
            o->strategy = MR_STRATEGY_FPPQ;
        else if (v && !strcmp(v, "multiqueue"))
            o->strategy = MR_STRATEGY_MULTIQUEUE;
        else if (v && !strcmp(v, "partitioned"))
            o->strategy = MR_STRATEGY_PARTITIONED;
        else if (v && !strcmp(v, "partitioned-boundary"))
            o->strategy = MR_STRATEGY_PARTITIONED_BOUNDARY;
        else
            return cli_usage_error("simplify", "--strategy is greedy, batched, ppq, rppq, "
                                               "fppq, multiqueue, partitioned or "
                                               "partitioned-boundary");
    } else if (cli_value(argc, argv, i, "--quality", &v)) {
        if (v && !strcmp(v, "default"))
            o->quality = MR_QUALITY_DEFAULT;
        else if (v && !strcmp(v, "best"))
            o->quality = MR_QUALITY_BEST;
        else
            return cli_usage_error("simplify", "--quality is default or best");
    } else if (cli_value(argc, argv, i, "--partitions", &v)) {
        if (!cli_parse_count(v, &n) || n < 1 || n > MR_PARTITIONS_MAX)
            return cli_usage_error("simplify", "--partitions needs a count in 1..4096");
        o->partitions = (unsigned)n;
    } else if (cli_value(argc, argv, i, "--filter-levels", &v)) {
        if (!cli_parse_count(v, &n) || n < 1 || n > 12)
            return cli_usage_error("simplify", "--filter-levels needs a count in 1..12");
        o->filter_levels = (unsigned)n;
    } else if (cli_value(argc, argv, i, "--multiqueue-factor", &v)) {
        if (!cli_parse_count(v, &n) || n < 1 || n > 1024)
            return cli_usage_error("simplify", "--multiqueue-factor needs a count in 1..1024");
        o->multiqueue_factor = (unsigned)n;
    } else if (cli_flag(argc, argv, i, "--lock-border")) {
        o->lock_border = 1;
    } else if (cli_flag(argc, argv, i, "--prune")) {
        o->prune = 1;
    } else if (cli_value(argc, argv, i, "--seams", &v)) {
        if (v && !strcmp(v, "auto"))
            o->seams = MR_SEAMS_AUTO;
        else if (v && !strcmp(v, "free"))
            o->seams = MR_SEAMS_FREE;
        else if (v && !strcmp(v, "keep"))
            o->seams = MR_SEAMS_KEEP;
        else
            return cli_usage_error("simplify", "--seams is auto, free or keep");
    } else if (cli_value(argc, argv, i, "--lock", &v)) {
        if (!v || !*v)
            return cli_usage_error("simplify", "--lock needs a file of vertex indices");
        ((simplify_job *)user)->lock_path = v;
    } else if (cli_value(argc, argv, i, "--memory", &v)) {
        simplify_job *job = user;
        if (!cli_parse_size(v, &n) || n == 0)
            return cli_usage_error("simplify", "--memory needs a size such as 512M or 4G");
        job->ooc.memory = n;
        job->ooc_given = true;
    } else if (cli_value(argc, argv, i, "--temp-dir", &v)) {
        simplify_job *job = user;
        if (!v || !*v)
            return cli_usage_error("simplify", "--temp-dir needs a directory");
        job->ooc.temp_dir = v;
        job->ooc_given = true;
    } else if (cli_value(argc, argv, i, "--temp-budget", &v)) {
        simplify_job *job = user;
        if (!cli_parse_size(v, &n) || n == 0)
            return cli_usage_error("simplify", "--temp-budget needs a size such as 10G");
        job->ooc.temp_budget = n;
        job->ooc_given = true;
    } else if (cli_value(argc, argv, i, "--boundary-weight", &v)) {
        if (!cli_parse_double(v, &x) || x < 0)
            return cli_usage_error("simplify", "--boundary-weight needs a number >= 0");
        o->boundary_weight = x;
    } else if (cli_value(argc, argv, i, "--lods", &v)) {
        simplify_job *job = user;
        if (!parse_lods(v, job))
            return cli_usage_error("simplify", "--lods needs up to %d decreasing fractions of "
                                               "the triangles in (0, 1), such as "
                                               "50%%,25%%,10%%,2%%",
                                   MAX_LODS);
    } else if (cli_value(argc, argv, i, "--attribute-weights", &v)) {
        if (!parse_attribute_weights(v, o))
            return cli_usage_error("simplify", "--attribute-weights needs none, or "
                                               "NAME=W,... with NAME normal, uv or color "
                                               "and W a number >= 0");
    } else if (cli_value(argc, argv, i, "--max-normal-turn", &v)) {
        if (!cli_parse_double(v, &x) || !(x > 0 && x <= 180))
            return cli_usage_error("simplify", "--max-normal-turn needs degrees in "
                                               "(0, 180]");
        o->max_normal_turn = x * 3.14159265358979323846 / 180.0;
    } else {
        return CLI_NO_MATCH;
    }
    return CLI_OK;
}

/* What a run says after it: a missed target (even with -q), locked vertices. */
static void warn_after(const cli_io *io, const simplify_job *job)
{
    if (!job->s.target_reached) {
        /* A missed target is a result, not an error: said even with -q. */
        char a[32], b[32];
        fprintf(stderr, "meshreduce: warning: %s: target not reached, stopped at %s vertices "
                        "and %s triangles: %s\n",
                io->in, cli_count(a, sizeof a, job->s.output_points),
                cli_count(b, sizeof b, job->s.output_triangles),
                mr_simplify_stop_string(job->s.stop));
    }
    if (!io->quiet && job->s.locked_vertices) {
        char a[32];
        fprintf(stderr,
                "note: %s vertices stayed in place: their triangles are not one consistently "
                "wound fan (`meshreduce info` counts non-manifold and misoriented edges; "
                "`meshreduce clean` fixes the winding)\n",
                cli_count(a, sizeof a, job->s.locked_vertices));
    }
}

static int work(const cli_io *io, mr_mesh *mesh, mr_mesh *result, void *user)
{
    simplify_job *job = user;
    mr_error err;
    if (mesh->triangle_count == 0) {
        char a[32];
        return cli_fail("%s: a point cloud (%s vertices, no triangles): simplify needs a "
                        "triangle mesh (`meshreduce weld` and `meshreduce cluster` reduce "
                        "point clouds)",
                        io->in, cli_count(a, sizeof a, mesh->vertex_count));
    }
    if (job->lock_path) {
        int rc = read_locks(job, mesh->vertex_count);
        if (rc != CLI_OK)
            return rc;
    }
    progress prog = {cli_now(), 0, -1};
    if (!io->quiet && isatty(STDERR_FILENO)) {
        job->o.progress = show_progress;
        job->o.progress_user = &prog;
    }
    /* an OBJ's usemtl groups are the mesh's materials: simplify keeps them */
    mr_status st = mr_mesh_simplify(mesh, &job->o, result, NULL, &job->s, &err);
    if (st == MR_OK && job->write)
        cli_obj_materials_use(job->write, &job->mats, result, io->in);
    free(job->lock);
    job->lock = NULL;
    job->o.vertex_lock = NULL;
    job->o.progress = NULL;
    job->o.progress_user = NULL;
    if (prog.shown)
        fprintf(stderr, "\r%60s\r", "");
    if (st != MR_OK) /* e.g. a --vertices target above the input's */
        return cli_fail_in(io->in, "simplify", &err);
    if (mesh->tangents && !io->quiet)
        fprintf(stderr, "meshreduce: note: %s: tangents dropped (clients compute MikkTSpace "
                        "tangents where a material needs them)\n",
                io->in);
    warn_after(io, job);
    return CLI_OK;
}

static void print_stats(const cli_io *io, const mr_mesh *result, const cli_times *t,
                        void *user)
{
    const mr_simplify_stats *s = &((simplify_job *)user)->s;
    char a[32], b[32], c[32], d[32];
    fprintf(stderr, "vertices   %s -> %s surface points", cli_count(a, sizeof a, s->input_vertices),
            cli_count(b, sizeof b, s->output_points));
    if (s->output_vertices != s->output_points)
        fprintf(stderr, " (%s vertices with the attribute splits)",
                cli_count(c, sizeof c, s->output_vertices));
    fprintf(stderr, "\n");
    fprintf(stderr, "triangles  %s -> %s\n", cli_count(c, sizeof c, s->input_triangles),
            cli_count(d, sizeof d, s->output_triangles));
    fprintf(stderr, "collapses  %s, largest error %.6g\n", cli_count(a, sizeof a, s->collapses),
            s->max_error);
    fprintf(stderr, "locked     %s vertices (non-manifold or misoriented fans)\n",
            cli_count(a, sizeof a, s->locked_vertices));
    if (s->pruned_parts)
        fprintf(stderr, "pruned     %s pieces\n", cli_count(a, sizeof a, s->pruned_parts));
    fprintf(stderr, "time       read %.3f s, setup %.3f s, collapse %.3f s, output %.3f s, "
                    "write %.3f s\n",
            t->read, s->seconds_setup, s->seconds_collapse, s->seconds_output, t->write);
    const mr_simplify_file_stats *fs = ((simplify_job *)user)->fs;
    if (fs && fs->out_of_core) {
        char e[32], f[32];
        fprintf(stderr,
                "out of core  memory budget %s: %s chunks of at most %s triangles, %u levels, "
                "%u passes over the faces, %s of temporary files at most\n",
                cli_bytes(a, sizeof a, fs->memory), cli_count(b, sizeof b, fs->chunks),
                cli_count(c, sizeof c, fs->chunk_capacity), fs->levels, fs->passes,
                cli_bytes(e, sizeof e, fs->temp_bytes_peak));
        if (fs->top_chunks)
            fprintf(stderr,
                    "  forest     the output does not fit one chunk: the tree ends at %zu "
                    "chunks, each simplified to its share, their cuts reduced in bands "
                    "above them, the output written as one PLY stream\n",
                    fs->top_chunks);
        for (unsigned l = 0; l < fs->levels && l < MR_LEVELS_MAX; l++)
            fprintf(stderr, "  level %-2u   %s chunks, %s triangles in, %.3f s\n", l,
                    cli_count(d, sizeof d, fs->level_chunks[l]),
                    cli_count(f, sizeof f, fs->level_triangles[l]), fs->level_seconds[l]);
    } else if (fs) {
        fprintf(stderr, "in memory  the input fits the memory budget of %s\n",
                cli_bytes(a, sizeof a, fs->memory));
    }
    if (s->queue_pops) /* the concurrent-queue strategies' profile */
        fprintf(stderr,
                "profile    summed over threads: %zu pops, %zu locks taken, %zu lock "
                "failures, %zu topology checks, %zu collapses, %zu priority updates, "
                "%zu compactions\n",
                s->queue_pops, s->lock_acquisitions, s->lock_failures, s->topology_checks,
                s->collapses, s->priority_updates, s->compactions);
    if (s->partition_passes) /* the partitioned strategy's profile */
        fprintf(stderr,
                "profile    %zu passes, %zu interior collapses (slabs in parallel), %zu "
                "boundary collapses (%zu of them on one thread), %zu tail collapses, %zu "
                "rebalances\n",
                s->partition_passes, s->interior_collapses, s->boundary_collapses,
                s->boundary_sequential, s->tail_collapses, s->rebalances);
    if (s->claim_conflicts || s->rebalance_count || s->rebalance_imbalance ||
        s->rebalance_boundary || s->rebalance_acceptance) /* the boundary-aware variant's */
        fprintf(stderr,
                "claims     %zu candidates deferred (neighbourhood claimed); rebalances by "
                "trigger: %zu count, %zu imbalance, %zu boundary fraction, %zu acceptance\n",
                s->claim_conflicts, s->rebalance_count, s->rebalance_imbalance,
                s->rebalance_boundary, s->rebalance_acceptance);
}

static void print_json(const cli_io *io, const mr_mesh *result, const cli_times *t,
                       void *user)
{
    const mr_simplify_stats *s = &((simplify_job *)user)->s;
    cli_json_io(io);
    static const char *const stops[] = {"target", "max_error", "locked", "refused"};
    printf(", \"target_reached\": %s, \"stop_reason\": \"%s\", \"stop\": ",
           s->target_reached ? "true" : "false", stops[s->stop]);
    cli_json_string(stdout, mr_simplify_stop_string(s->stop));
    printf(", \"input_vertices\": %zu, \"output_points\": %zu", s->input_vertices,
           s->output_points);
    printf(", \"input_triangles\": %zu, \"output_vertices\": %zu, "
           "\"output_triangles\": %zu, \"collapses\": %zu, \"max_error\": %.9g, "
           "\"locked_vertices\": %zu, \"pruned_parts\": %zu, "
           "\"seconds\": {\"read\": %.6f, \"setup\": %.6f, \"collapse\": %.6f, "
           "\"output\": %.6f, \"write\": %.6f}",
           s->input_triangles, s->output_vertices, s->output_triangles,
           s->collapses, s->max_error, s->locked_vertices, s->pruned_parts, t->read,
           s->seconds_setup,
           s->seconds_collapse, s->seconds_output, t->write);
    if (s->queue_pops) /* the concurrent-queue strategies' profile */
        printf(", \"profile\": {\"pops\": %zu, \"lock_acquisitions\": %zu, "
               "\"lock_failures\": %zu, \"topology_checks\": %zu, \"collapses\": %zu, "
               "\"priority_updates\": %zu, \"compactions\": %zu}",
               s->queue_pops, s->lock_acquisitions, s->lock_failures, s->topology_checks,
               s->collapses, s->priority_updates, s->compactions);
    if (s->partition_passes) /* the partitioned strategy's profile */
        printf(", \"partitioned\": {\"passes\": %zu, \"interior_collapses\": %zu, "
               "\"boundary_collapses\": %zu, \"boundary_sequential\": %zu, "
               "\"tail_collapses\": %zu, \"rebalances\": %zu, \"claim_conflicts\": %zu, "
               "\"rebalance_triggers\": {\"count\": %zu, \"imbalance\": %zu, "
               "\"boundary\": %zu, \"acceptance\": %zu}}",
               s->partition_passes, s->interior_collapses, s->boundary_collapses,
               s->boundary_sequential, s->tail_collapses, s->rebalances, s->claim_conflicts,
               s->rebalance_count, s->rebalance_imbalance, s->rebalance_boundary,
               s->rebalance_acceptance);
    const mr_simplify_file_stats *fs = ((simplify_job *)user)->fs;
    if (fs) {
        printf(", \"out_of_core\": %s, \"memory\": %llu", fs->out_of_core ? "true" : "false",
               (unsigned long long)fs->memory);
        if (fs->out_of_core) {
            printf(", \"chunks\": %zu, \"chunk_capacity\": %zu, \"oversized_chunks\": %zu, "
                   "\"passes\": %u, \"temp_bytes_peak\": %llu, \"top_chunks\": %zu, "
                   "\"levels\": [",
                   fs->chunks, fs->chunk_capacity, fs->oversized_chunks, fs->passes,
                   (unsigned long long)fs->temp_bytes_peak, fs->top_chunks);
            for (unsigned l = 0; l < fs->levels && l < MR_LEVELS_MAX; l++)
                printf("%s{\"chunks\": %zu, \"triangles\": %zu, \"seconds\": %.6f}",
                       l ? ", " : "", fs->level_chunks[l], fs->level_triangles[l],
                       fs->level_seconds[l]);
            printf("], \"splits\": [");
            for (unsigned k = 0; k < fs->splits; k++)
                printf("%s[%d, %.9g]", k ? ", " : "", fs->split_axis[k], fs->split_at[k]);
            printf("], \"seconds_passes\": %.6f, \"seconds_chunks\": %.6f",
                   fs->seconds_read, fs->seconds_simplify);
        }
        printf(", \"seconds_total\": %.6f", fs->seconds_total);
    }
    printf("}\n");
}

static void print_summary(const cli_io *io, const mr_mesh *result, const cli_times *t,
                          void *user)
{
    const mr_simplify_stats *s = &((simplify_job *)user)->s;
    const mr_simplify_file_stats *fs = ((simplify_job *)user)->fs;
    if (fs && fs->out_of_core && fs->top_chunks)
        cli_summary(io->out, s->output_vertices, s->output_triangles,
                    "simplified out of core in %.3f s: %zu chunks, %u levels; the output "
                    "larger than a chunk: %zu top chunks, their cuts reduced in bands",
                    fs->seconds_total, fs->chunks, fs->levels, fs->top_chunks);
    else if (fs && fs->out_of_core)
        cli_summary(io->out, s->output_vertices, s->output_triangles,
                    "simplified out of core in %.3f s: %zu chunks, %u levels",
                    fs->seconds_total, fs->chunks, fs->levels);
    else
        cli_summary(io->out, s->output_vertices, s->output_triangles, "simplified in %.3f s",
                    s->seconds_setup + s->seconds_collapse + s->seconds_output);
}

/* PLY, STL and OBJ inputs this large go through mr_simplify_file, which
 * decides by the triangle count whether they fit the budget (smaller ones
 * are simplified in memory either way, with the same bytes). */
#define FILE_PATH_BYTES ((unsigned long long)256 << 20)

/* The file path: mr_simplify_file reads, simplifies (in memory or out of
 * core) and writes. */
static int run_file(const cli_io *io, simplify_job *job)
{
    mr_error err;
    if (job->lock_path) {
        size_t nv;
        if (mr_file_counts(io->in, &nv, NULL, &err) != MR_OK)
            return cli_fail_err(&err);
        int rc = read_locks(job, nv);
        if (rc != CLI_OK)
            return rc;
    }
    progress prog = {cli_now(), 0, -1};
    if (!io->quiet && isatty(STDERR_FILENO) && (!cli_comm || cli_comm->rank == 0)) {
        job->o.progress = show_progress;
        job->o.progress_user = &prog;
    }
    /* an OBJ's usemtl groups: kept where the file is simplified in memory
     * (the mesh has them; the writer needs their names) */
    mr_write_options w = io->write;
    const bool groups = mr_format_from_path(io->in) == MR_FORMAT_OBJ &&
                        cli_file_has_line(io->in, "usemtl");
    mr_obj_materials mats;
    memset(&mats, 0, sizeof mats);
    if (groups) {
        int rc = cli_obj_materials(io, &mats);
        if (rc != CLI_OK)
            return rc;
        w.mtllib = mats.mtllib;
        w.material_names = (const char *const *)mats.names;
        w.material_count = mats.count;
        w.materials_from = io->in;
    }
    mr_simplify_file_stats fs;
    const mr_status st = ooc_simplify_file(io->in, io->out, &job->o, &job->ooc, &w, cli_comm,
                                           &fs, &err);
    mr_obj_materials_free(&mats);
    free(job->lock);
    job->lock = NULL;
    job->o.vertex_lock = NULL;
    if (prog.shown)
        fprintf(stderr, "\r%60s\r", "");
    if (st != MR_OK)
        return cli_fail_err(&err);
    job->s = fs.simplify;
    job->fs = &fs;
    if (groups && fs.out_of_core && !io->quiet && (!cli_comm || cli_comm->rank == 0))
        fprintf(stderr,
                "meshreduce: note: %s: its usemtl groups are not kept out of core; the output "
                "has none\n",
                io->in);
    warn_after(io, job);
    const cli_times t = {fs.seconds_read, fs.seconds_simplify, fs.seconds_write};
    if (io->json)
        print_json(io, NULL, &t, job);
    if (io->stats)
        print_stats(io, NULL, &t, job);
    else if (!io->quiet && !io->json)
        print_summary(io, NULL, &t, job);
    job->fs = NULL;
    return CLI_OK;
}

/* A glTF document into a glTF document: mr_simplify_gltf keeps it whole,
 * each triangle primitive simplified on its own. */
static int run_gltf(const cli_io *io, simplify_job *job)
{
    if (job->lock_path)
        return cli_usage_error("simplify", "--lock is not supported for a glTF document");
    if (job->ooc_given)
        return cli_usage_error("simplify", "--memory, --temp-dir and --temp-budget are not "
                                           "supported for a glTF document (it is read whole)");
    progress prog = {cli_now(), 0, -1};
    if (!io->quiet && isatty(STDERR_FILENO)) {
        job->o.progress = show_progress;
        job->o.progress_user = &prog;
    }
    const double t0 = cli_now();
    mr_gltf_simplify_stats gs;
    mr_error err;
    const mr_status st = mr_simplify_gltf(io->in, io->out, &job->o, &gs, &err);
    if (prog.shown)
        fprintf(stderr, "\r%60s\r", "");
    if (st != MR_OK)
        return cli_fail_err(&err);
    job->s = gs.simplify;
    if (gs.dropped_tangents && !io->quiet)
        fprintf(stderr,
                "meshreduce: note: %s: TANGENT dropped from %zu primitive%s (clients compute "
                "MikkTSpace tangents where a material needs them)\n",
                io->in, gs.dropped_tangents, gs.dropped_tangents == 1 ? "" : "s");
    warn_after(io, job);
    const double total = cli_now() - t0;
    const double work_s = gs.simplify.seconds_setup + gs.simplify.seconds_collapse +
                          gs.simplify.seconds_output;
    const cli_times t = {total - work_s > 0 ? total - work_s : 0, work_s, 0};
    if (io->json)
        print_json(io, NULL, &t, job);
    if (io->stats)
        print_stats(io, NULL, &t, job);
    else if (!io->quiet && !io->json)
        cli_summary(io->out, gs.simplify.output_vertices, gs.simplify.output_triangles,
                    "%zu primitive%s simplified in %.3f s", gs.primitives,
                    gs.primitives == 1 ? "" : "s", total);
    return CLI_OK;
}

/* Level k's file: OUT's name with ".lodK" before its extension. */
static void lod_path(const char *out, size_t k, char *buf, size_t cap)
{
    const char *slash = strrchr(out, '/');
    const char *dot = strrchr(slash ? slash + 1 : out, '.');
    if (!dot || dot == (slash ? slash + 1 : out))
        snprintf(buf, cap, "%s.lod%zu", out, k);
    else
        snprintf(buf, cap, "%.*s.lod%zu%s", (int)(dot - out), out, k, dot);
}

/* The levels' report: --json on stdout, else a table on stderr (not with
 * -q); a missed target is a warning. path[k]: level k's file (level 0:
 * the input's copy). */
static void report_lods(const cli_io *io, const simplify_job *job, const mr_lod_level *lv,
                        char (*path)[4096], size_t triangles, size_t vertices,
                        const double t[4])
{
    bool reached = true;
    for (size_t k = 0; k < job->nlods; k++)
        reached &= lv[k].stats.target_reached != 0;
    if (io->json) {
        cli_json_io(io);
        printf(", \"triangles\": %zu, \"levels\": [", triangles);
        for (size_t k = 0; k < job->nlods; k++) {
            const mr_lod_level *l = &lv[k];
            printf("%s{\"file\": ", k ? ", " : "");
            cli_json_string(stdout, path[k + 1]);
            printf(", \"fraction\": %.17g, \"target_triangles\": %zu, \"triangles\": %zu, "
                   "\"vertices\": %zu, \"target_reached\": %s, \"hausdorff_rel\": %.17g, "
                   "\"rms_rel\": %.17g, \"error_rel\": %.17g, \"seconds\": %.6f}",
                   job->lods[k], l->target_triangles, l->stats.output_triangles,
                   l->stats.output_vertices, l->stats.target_reached ? "true" : "false",
                   l->hausdorff_rel, l->rms_rel, l->error_rel,
                   l->stats.seconds_setup + l->stats.seconds_collapse + l->stats.seconds_output);
        }
        printf("], \"read_seconds\": %.6f, \"lods_seconds\": %.6f, \"write_seconds\": %.6f}\n",
               t[1] - t[0], t[2] - t[1], t[3] - t[2]);
    }
    if (!io->quiet && !io->json) {
        char a[32], b[32];
        fprintf(stderr, "%-5s %12s %12s %11s %9s %9s  %s\n", "level", "triangles", "vertices",
                "Hausdorff", "RMS", "error", "file");
        fprintf(stderr, "%-5d %12s %12s %11s %9s %9s  %s\n", 0,
                cli_count(a, sizeof a, triangles), cli_count(b, sizeof b, vertices), "-", "-",
                "-", path[0]);
        for (size_t k = 0; k < job->nlods; k++) {
            const mr_lod_level *l = &lv[k];
            fprintf(stderr, "%-5zu %12s %12s %10.4f%% %8.4f%% %8.4f%%  %s%s\n", k + 1,
                    cli_count(a, sizeof a, l->stats.output_triangles),
                    cli_count(b, sizeof b, l->stats.output_vertices), 100 * l->hausdorff_rel,
                    100 * l->rms_rel, 100 * l->error_rel, path[k + 1],
                    l->stats.target_reached ? "" : " (target not reached)");
        }
        fprintf(stderr, "%zu levels in %.3f s (distances to the input, %% of its bounding-box "
                        "diagonal; error: the largest Hausdorff distance so far)\n",
                job->nlods, t[3] - t[0]);
    }
    if (!reached)
        fprintf(stderr, "meshreduce: warning: %s: a level's target was not reached (the "
                        "rules stopped it above its triangle count)\n",
                io->in);
}

/* --lods: the input to OUT (level 0), level k to OUT.lodK.ext, each level
 * simplified from the one before (mr_mesh_lods) and measured against the
 * input; every file written, or none. A glTF document into glTF: one
 * document, its levels in MSFT_lod (mr_simplify_gltf_lods). */
/* The library that a glTF's materials made beside an OBJ this run wrote
 * (OBJ's name with .mtl, and the map_Kd files it names: mr_write_options'
 * materials_from): removed with the OBJ when a later level fails. */
static void remove_library(const char *obj_path)
{
    char mtl[4200], dir[4200];
    const char *slash = strrchr(obj_path, '/'), *base = slash ? slash + 1 : obj_path;
    const char *dot = strrchr(base, '.');
    snprintf(mtl, sizeof mtl, "%.*s.mtl", (int)(dot && dot > base ? dot - obj_path : (long)strlen(obj_path)),
             obj_path);
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - obj_path + 1) : 0, obj_path);
    FILE *f = fopen(mtl, "r");
    if (!f)
        return;
    char line[2400];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "map_Kd ", 7) != 0)
            continue;
        line[strcspn(line, "\r\n")] = '\0';
        const char *name = strrchr(line, ' ') + 1; /* after "-clamp on", if any */
        char tex[6700];
        snprintf(tex, sizeof tex, "%s%s", dir, name);
        remove(tex);
    }
    fclose(f);
    remove(mtl);
}

static int run_lods(const cli_io *io, simplify_job *job, bool gltf)
{
    if (job->lock_path)
        return cli_usage_error("simplify", "--lock is not supported with --lods");
    if (job->ooc_given || cli_comm)
        return cli_usage_error("simplify", "--lods works in memory (no --memory, --temp-dir, "
                                           "--temp-budget or MPI)");
    double t[4] = {cli_now(), 0, 0, 0};
    mr_lod_level lv[MAX_LODS];
    char path[MAX_LODS + 1][4096];
    mr_error err;
    if (gltf) {
        const mr_status st = mr_simplify_gltf_lods(io->in, io->out, job->lods, job->nlods,
                                                   &job->o, 0, lv, &err);
        if (st != MR_OK)
            return cli_fail_err(&err);
        t[1] = t[0];
        t[2] = t[3] = cli_now();
        for (size_t k = 0; k <= job->nlods; k++)
            snprintf(path[k], sizeof path[k], "%s", io->out);
        size_t nt = 0, nv = 0;
        for (size_t k = 0; k < job->nlods; k++)
            nt = lv[k].stats.input_triangles > nt ? lv[k].stats.input_triangles : nt;
        nv = job->nlods ? lv[0].stats.input_vertices : 0;
        report_lods(io, job, lv, path, nt, nv, t);
        return CLI_OK;
    }
    mr_mesh mesh;
    mr_mesh_init(&mesh);
    if (mr_mesh_read(io->in, NULL, &mesh, &err) != MR_OK)
        return cli_fail_err(&err);
    if (mesh.triangle_count == 0) {
        mr_mesh_free(&mesh);
        return cli_fail("%s: no triangles: levels of detail need a triangle mesh", io->in);
    }
    t[1] = cli_now();
    mr_status st = mr_mesh_lods(&mesh, job->lods, job->nlods, &job->o, 0, lv, &err);
    t[2] = cli_now();
    size_t written = 0;
    for (size_t k = 0; k <= job->nlods && st == MR_OK; k++) {
        if (k)
            lod_path(io->out, k, path[k], sizeof path[k]);
        else
            snprintf(path[0], sizeof path[0], "%s", io->out);
        /* an OBJ into OBJs: each level keeps its usemtl groups */
        const mr_mesh *level = k ? &lv[k - 1].mesh : &mesh;
        mr_write_options w = io->write;
        cli_obj_materials_use(&w, &job->mats, level, io->in);
        st = mr_mesh_write(path[k], level, &w, &err);
        written += st == MR_OK;
    }
    if (st != MR_OK) {
        for (size_t k = 0; k < written; k++) { /* all of them or none */
            if (mesh.materials && mr_format_from_path(io->in) == MR_FORMAT_GLTF)
                remove_library(path[k]);
            remove(path[k]);
        }
        mr_lod_levels_free(lv, job->nlods);
        mr_mesh_free(&mesh);
        return cli_fail_err(&err);
    }
    t[3] = cli_now();
    report_lods(io, job, lv, path, mesh.triangle_count, mesh.vertex_count, t);
    mr_lod_levels_free(lv, job->nlods);
    mr_mesh_free(&mesh);
    return CLI_OK;
}

static int run(int argc, char **argv)
{
    cli_io io;
    cli_io_init(&io, "simplify", CLI_ACCEPT_OUTPUT | CLI_ACCEPT_WRITE | CLI_ACCEPT_REPORT);
    simplify_job job = {.lock_path = NULL, .lock = NULL};
    mr_simplify_options_default(&job.o);
    mr_out_of_core_options_default(&job.ooc);
    int rc = cli_io_parse(&io, argc, argv, option, &job);
    if (rc != CLI_OK)
        return rc;
    if (job.nlods && (job.o.target_ratio != 0 || job.o.target_vertices ||
                      job.o.target_triangles || job.o.until_error))
        return cli_usage_error("simplify", "--lods sets the targets (no --ratio, --vertices "
                                           "or --triangles with it)");
    if (job.o.target_ratio == 0 && job.o.target_vertices == 0 && job.o.target_triangles == 0 &&
        job.o.max_error == 0 && !job.o.until_error && !job.nlods)
        return cli_usage_error("simplify", "no target given (--ratio, --vertices, "
                                           "--triangles or --max-error)");
    if ((rc = cli_check_output_path(io.cmd, io.out, io.write.format)) != CLI_OK)
        return rc;
    static const cli_job steps = {work, print_json, print_stats, print_summary};
    const mr_format in_format = mr_format_from_path(io.in);
    const mr_format out_format =
        io.write.format != MR_FORMAT_AUTO ? io.write.format : mr_format_from_path(io.out);
    if (job.nlods) {
        /* an OBJ into OBJs keeps its mtllib and usemtl groups */
        if ((rc = cli_obj_materials(&io, &job.mats)) != CLI_OK)
            return rc;
        rc = run_lods(&io, &job, in_format == MR_FORMAT_GLTF && out_format == MR_FORMAT_GLTF);
        mr_obj_materials_free(&job.mats);
        return rc;
    }
    if (in_format == MR_FORMAT_GLTF && out_format == MR_FORMAT_GLTF && !cli_comm)
        return run_gltf(&io, &job);
    const bool streamed = in_format == MR_FORMAT_PLY || in_format == MR_FORMAT_STL ||
                          in_format == MR_FORMAT_OBJ;
    if (cli_comm || job.ooc_given || (streamed && cli_file_size(io.in) > FILE_PATH_BYTES))
        return run_file(&io, &job);
    /* an OBJ into an OBJ keeps its mtllib and usemtl groups */
    if ((rc = cli_obj_materials(&io, &job.mats)) != CLI_OK)
        return rc;
    job.write = &io.write;
    rc = cli_run_job(&io, &steps, &job);
    mr_obj_materials_free(&job.mats);
    return rc;
}

const cli_command cli_cmd_simplify = {"simplify", "reduce a mesh by quadric-error edge collapse",
                                      run, usage};
