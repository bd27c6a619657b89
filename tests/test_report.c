/* The benchmark sweep and its report, end to end on the --quick sweep. */
#include "testutil.h"

#include <libgen.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The bench programs live in build/bench beside build/meshreduce; a build
 * without the benchmarks (MR_BUILD_BENCH=OFF) skips. */
static const char *bench_tool(const char *name)
{
    static char paths[2][4096];
    static int slot;
    char *path = paths[slot++ % 2];
    char cli[4096];
    snprintf(cli, sizeof cli, "%s", MR_CLI_PATH);
    snprintf(path, sizeof paths[0], "%s/bench/%s", dirname(cli), name);
    return access(path, X_OK) == 0 ? path : NULL;
}

static const char *expected_header =
    "mesh,algorithm,threads,target,input_triangles,output_triangles,runs,time_median,"
    "time_min,time_max,triangles_per_second,peak_bytes_per_triangle,hausdorff_rel,rms_rel,"
    "vertex_similarity\n";

/* A PNG file of some size at path. */
static void check_png(const char *path)
{
    size_t n;
    char *png = tu_read_file(path, &n);
    assert_non_null(png);
    assert_true(n > 1000);
    assert_memory_equal(png, "\x89PNG\r\n\x1a\n", 8);
    free(png);
}

/* The command fails (non-zero exit) and says `says`. */
static void expect_refusal(const char *cmd, const char *says)
{
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char buf[512] = "";
    const size_t got = fread(buf, 1, sizeof buf - 1, p);
    buf[got] = '\0';
    assert_int_not_equal(pclose(p), 0);
    tu_assert_contains(buf, says);
}

static void test_sweep_and_report(void **state)
{
    (void)state;
    const char *sweep = bench_tool("sweep"), *report = bench_tool("report");
    if (!sweep || !report)
        skip();
    const char *dir = tu_tmp_path("sweep");
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "'%s' --quick --csv '%s/sweep.csv' --dir '%s' >/dev/null 2>&1",
             sweep, dir, dir);
    assert_int_equal(system(tu_fmt("mkdir -p '%s'", dir)), 0);
    assert_int_equal(system(cmd), 0);

    size_t n;
    char *csv = tu_read_file(tu_fmt("%s/sweep.csv", dir), &n);
    assert_non_null(csv);
    tu_assert_contains(csv, "# machine: ");
    tu_assert_contains(csv, "# mesh scan-20k generate:scan:20000:1");
    tu_assert_contains(csv, expected_header);
    /* Every data row has the header's 15 fields; ours at 1 and 2 threads,
     * both targets; numbers where they must be. */
    char *rows = strstr(csv, expected_header) + strlen(expected_header);
    int count = 0, ours2 = 0;
    for (char *line = strtok(rows, "\n"); line; line = strtok(NULL, "\n")) {
        int commas = 0;
        for (char *p = line; *p; p++)
            commas += *p == ',';
        assert_int_equal(commas, 14);
        char mesh[64], alg[64];
        int threads;
        double target, in_t, out_t, runs, tmed;
        assert_int_equal(sscanf(line, "%63[^,],%63[^,],%d,%lf,%lf,%lf,%lf,%lf", mesh, alg,
                                &threads, &target, &in_t, &out_t, &runs, &tmed),
                         8);
        assert_string_equal(mesh, "scan-20k");
        assert_true(target == 0.1 || target == 0.01);
        assert_true(out_t > 0 && out_t < in_t);
        assert_true(tmed > 0);
        ours2 += !strcmp(alg, "meshreduce-full") && threads == 2;
        count++;
    }
    assert_true(count >= 8); /* 2 targets x (2 references + 2 x 2 threaded) */
    assert_int_equal(ours2, 2);
    free(csv);

    snprintf(cmd, sizeof cmd, "'%s' '%s/sweep.csv' --out '%s' --panel 160 >/dev/null 2>&1",
             report, dir, dir);
    assert_int_equal(system(cmd), 0);
    char *md = tu_read_file(tu_fmt("%s/REPORT.md", dir), &n);
    assert_non_null(md);
    tu_assert_contains(md, "Machine: ");
    tu_assert_contains(md, "![speedup vs threads](report/speedup-threads.png)");
    tu_assert_contains(md, "![scan-20k](report/sheet-scan-20k.png)");
    tu_assert_contains(md, "| scan-20k | 10% | meshreduce-full | 2 |");
    free(md);
    /* The plots: bench/plots.py with Debian's matplotlib (make check
     * installs it; without it, the sheet alone is checked). */
    const bool plots = system("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null") == 0;
    if (plots) {
        snprintf(cmd, sizeof cmd,
                 "/usr/bin/python3 '%s/bench/plots.py' '%s/sweep.csv' --out '%s/report' "
                 ">/dev/null 2>&1",
                 MR_SOURCE_DIR, dir, dir);
        assert_int_equal(system(cmd), 0);
    } else {
        print_message("no matplotlib for /usr/bin/python3: the plots are not checked\n");
    }
    static const char *pngs[] = {"sheet-scan-20k", "time-threads", "speedup-threads", "peers",
                                 "error-scan-20k"};
    for (size_t i = 0; i < (plots ? sizeof pngs / sizeof *pngs : 1); i++) {
        check_png(tu_fmt("%s/report/%s.png", dir, pngs[i]));
    }

    /* A CSV that is not the sweep's: a clear error, exit 1. */
    tu_write_file(tu_fmt("%s/bad.csv", dir), "a,b,c\n1,2,3\n", 12);
    snprintf(cmd, sizeof cmd, "'%s' '%s/bad.csv' --out '%s/bad' 2>&1", report, dir, dir);
    expect_refusal(cmd, "not a sweep CSV");
    if (plots) { /* and the plots' script says the same */
        snprintf(cmd, sizeof cmd,
                 "/usr/bin/python3 '%s/bench/plots.py' '%s/bad.csv' --out '%s/bad' 2>&1",
                 MR_SOURCE_DIR, dir, dir);
        expect_refusal(cmd, "not a sweep CSV");
        /* bench_outofcore's CSV: the time and memory curves */
        static const char ooc[] =
            "triangles,config,threads,ranks,memory,seconds,rss_bytes,chunks,levels,temp_bytes,"
            "rms_rel,hausdorff_rel,sampled_rms_rel,sampled_max_rel\n"
            "4000000,in memory,1,0,default,3.15,502000000,0,0,0,1e-4,1e-3,nan,nan\n"
            "20000000,in memory,1,0,default,14.8,2461000000,0,0,0,1e-4,1e-3,nan,nan\n"
            "4000000,out of core,2,0,256M,1.67,314000000,4,3,56000000,1e-4,1e-3,nan,nan\n"
            "20000000,out of core,2,0,256M,9.94,382000000,8,4,276000000,1e-4,1e-3,nan,nan\n"
            "20000000,mpi,1,2,1G,8.85,0,8,4,276000000,1e-4,1e-3,nan,nan\n";
        tu_write_file(tu_fmt("%s/ooc.csv", dir), ooc, sizeof ooc - 1);
        snprintf(cmd, sizeof cmd,
                 "/usr/bin/python3 '%s/bench/plots.py' --outofcore '%s/ooc.csv' --out '%s/report' "
                 ">/dev/null 2>&1",
                 MR_SOURCE_DIR, dir, dir);
        assert_int_equal(system(cmd), 0);
        check_png(tu_fmt("%s/report/outofcore.png", dir));
        snprintf(cmd, sizeof cmd,
                 "/usr/bin/python3 '%s/bench/plots.py' --outofcore '%s/bad.csv' --out '%s/bad' "
                 "2>&1",
                 MR_SOURCE_DIR, dir, dir);
        expect_refusal(cmd, "not a bench_outofcore CSV");
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sweep_and_report),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
