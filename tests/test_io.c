/* The format dispatcher: detection, file errors, all-or-nothing writes. */
#include "testutil.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char tri_obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

static void make_triangle(mr_mesh *m)
{
    mr_error err;
    assert_int_equal(mr_mesh_alloc(m, 3, 1, 0, &err), MR_OK);
    const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(m->positions, p, sizeof p);
    m->indices[0] = 0, m->indices[1] = 1, m->indices[2] = 2;
}

static void test_format_from_path(void **state)
{
    (void)state;
    assert_int_equal(mr_format_from_path("a.obj"), MR_FORMAT_OBJ);
    assert_int_equal(mr_format_from_path("dir.x/A.OBJ"), MR_FORMAT_OBJ);
    assert_int_equal(mr_format_from_path("a.Ply"), MR_FORMAT_PLY);
    assert_int_equal(mr_format_from_path("a.stl"), MR_FORMAT_STL);
    assert_int_equal(mr_format_from_path("a.xyz"), MR_FORMAT_XYZ);
    assert_int_equal(mr_format_from_path("a.mesh"), MR_FORMAT_AUTO);
    assert_int_equal(mr_format_from_path("obj"), MR_FORMAT_AUTO);
    assert_int_equal(mr_format_from_path(NULL), MR_FORMAT_AUTO);
}

static void test_sniff(void **state)
{
    (void)state;
    assert_int_equal(mr_format_sniff("ply\nformat ascii 1.0\n", 19), MR_FORMAT_PLY);
    assert_int_equal(mr_format_sniff("solid x\nfacet normal 0 0 1\n", 27), MR_FORMAT_STL);
    assert_int_equal(mr_format_sniff(tri_obj, strlen(tri_obj)), MR_FORMAT_AUTO);
    unsigned char bin[84 + 50] = {0};
    memcpy(bin, "solid but binary", 16);
    bin[80] = 1;
    assert_int_equal(mr_format_sniff(bin, sizeof bin), MR_FORMAT_STL);
    assert_int_equal(mr_format_sniff("", 0), MR_FORMAT_AUTO);
}

static void test_content_beats_extension(void **state)
{
    (void)state;
    /* A PLY file named .obj is read as PLY. */
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(ply, "really-a-ply.obj", &m, &err), MR_OK);
    assert_int_equal(m.triangle_count, 1);
    mr_mesh_free(&m);
}

static void test_unknown_format(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(tu_read_string(tri_obj, "mesh.dat", &m, &err), MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "mesh.dat: unknown file format");
    assert_null(m.positions);
}

static void test_empty_file(void **state)
{
    (void)state;
    const char *path = tu_tmp_path("empty.obj");
    tu_write_file(path, "", 0);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(path, NULL, &m, &err), MR_ERR_EMPTY);
    tu_assert_contains(err.message, "empty.obj: file is empty");
}

static void test_missing_and_directory(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read("/nonexistent/x.obj", NULL, &m, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "/nonexistent/x.obj: cannot open for reading");
    assert_int_equal(mr_mesh_read(MR_TEST_TMPDIR, NULL, &m, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "is a directory");
}

static void test_unreadable(void **state)
{
    (void)state;
    if (geteuid() == 0)
        skip(); /* root reads anything */
    const char *path = tu_tmp_path("secret.obj");
    tu_write_file(path, tri_obj, strlen(tri_obj));
    chmod(path, 0);
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read(path, NULL, &m, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "Permission denied");
}

static int count_temp_files(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strncmp(e->d_name, ".meshreduce-", 12) == 0;
    closedir(d);
    return n;
}

static void test_write_errors_leave_nothing(void **state)
{
    (void)state;
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write("/nonexistent-dir/out.obj", &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "/nonexistent-dir/out.obj: cannot write");

    assert_int_equal(mr_mesh_write(tu_tmp_path("out.unknown"), &m, NULL, &err),
                     MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "cannot tell the output format");

    /* An index out of range is refused before anything is written. */
    const char *path = tu_tmp_path("bad-index.ply");
    m.indices[2] = 7;
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_ERR_INVALID_ARGUMENT);
    tu_assert_contains(err.message, "triangle 0 uses vertex 7");
    assert_false(tu_file_exists(path));
    m.indices[2] = 2;

    /* A point cloud cannot be STL. */
    mr_mesh cloud = m;
    cloud.triangle_count = 0;
    path = tu_tmp_path("cloud.stl");
    assert_int_equal(mr_mesh_write(path, &cloud, NULL, &err), MR_ERR_UNSUPPORTED);
    assert_false(tu_file_exists(path));

    /* A write that fails half way (file size limit reached) reports the
     * error and leaves neither the file nor a temporary behind. Done in a
     * child process so the limit does not outlive the check. */
    path = tu_tmp_path("too-big.obj");
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = {4096, 4096};
        setrlimit(RLIMIT_FSIZE, &rl);
        mr_mesh big;
        mr_error e2;
        if (mr_generate(MR_GEN_SPHERE, 20000, 1, &big, &e2) != MR_OK)
            _exit(10);
        mr_status st = mr_mesh_write(path, &big, NULL, &e2);
        _exit(st == MR_ERR_IO && strstr(e2.message, "too-big.obj") ? 0 : 11);
    }
    int status;
    waitpid(pid, &status, 0);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_false(tu_file_exists(path));
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", tu_tmp_path(""));
    assert_int_equal(count_temp_files(dir), 0);
    mr_mesh_free(&m);
}

static void test_readonly_dir(void **state)
{
    (void)state;
    if (geteuid() == 0)
        skip(); /* root writes anywhere */
    const char *dir = tu_tmp_path("ro");
    mkdir(dir, 0555);
    char path[1100];
    snprintf(path, sizeof path, "%s/x.obj", dir);
    mr_mesh m;
    make_triangle(&m);
    mr_error err;
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_ERR_IO);
    tu_assert_contains(err.message, "cannot write");
    mr_mesh_free(&m);
}

static void test_overwrite_is_atomic(void **state)
{
    (void)state;
    /* A failing write must keep the old content of the destination. */
    const char *path = tu_tmp_path("keep.obj");
    tu_write_file(path, tri_obj, strlen(tri_obj));
    mr_mesh m;
    make_triangle(&m);
    m.indices[1] = 99; /* refused */
    mr_error err;
    assert_int_not_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    size_t n;
    char *back = tu_read_file(path, &n);
    assert_non_null(back);
    assert_string_equal(back, tri_obj);
    free(back);
    /* and a good write replaces it */
    m.indices[1] = 1;
    assert_int_equal(mr_mesh_write(path, &m, NULL, &err), MR_OK);
    mr_mesh r;
    assert_int_equal(mr_mesh_read(path, NULL, &r, &err), MR_OK);
    tu_assert_mesh_equal(&m, &r);
    mr_mesh_free(&r);
    mr_mesh_free(&m);
}

static void test_all_formats_round_trip(void **state)
{
    (void)state;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_generate(MR_GEN_TORUS, 2000, 3, &m, &err), MR_OK);
    const char *names[] = {"rt.obj", "rt.ply", "rt.stl"};
    mr_encoding encs[] = {MR_ENCODING_ASCII, MR_ENCODING_BINARY_LE, MR_ENCODING_BINARY_BE};
    for (int f = 0; f < 3; f++)
        for (int e = 0; e < 3; e++) {
            if (f != 1 && e == 2)
                continue; /* big endian is PLY only */
            mr_write_options w;
            mr_write_options_default(&w);
            w.encoding = encs[e];
            const char *path = tu_tmp_path(names[f]);
            assert_int_equal(mr_mesh_write(path, &m, &w, &err), MR_OK);
            mr_mesh r;
            assert_int_equal(mr_mesh_read(path, NULL, &r, &err), MR_OK);
            if (f == 2) {
                /* STL stores corners, not vertices: the reader numbers the
                 * merged vertices by first use, so compare the geometry of
                 * every corner. */
                assert_int_equal(r.triangle_count, m.triangle_count);
                assert_int_equal(r.vertex_count, m.vertex_count);
                for (size_t c = 0; c < m.triangle_count * 3; c++)
                    assert_memory_equal(m.positions + 3 * m.indices[c],
                                        r.positions + 3 * r.indices[c], 3 * sizeof(float));
            } else {
                tu_assert_mesh_equal(&m, &r);
            }
            mr_mesh_free(&r);
        }
    mr_mesh_free(&m);
}

static void test_forced_format(void **state)
{
    (void)state;
    mr_read_options o;
    mr_read_options_default(&o);
    o.format = MR_FORMAT_OBJ;
    mr_mesh m;
    mr_error err;
    assert_int_equal(mr_mesh_read_memory(tri_obj, strlen(tri_obj), "x.bin", &o, &m, &err),
                     MR_OK);
    assert_int_equal(m.triangle_count, 1);
    mr_mesh_free(&m);
    o.format = MR_FORMAT_PLY;
    assert_int_not_equal(
        mr_mesh_read_memory(tri_obj, strlen(tri_obj), "x.bin", &o, &m, &err), MR_OK);
    tu_assert_contains(err.message, "x.bin");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_format_from_path),
        cmocka_unit_test(test_sniff),
        cmocka_unit_test(test_content_beats_extension),
        cmocka_unit_test(test_unknown_format),
        cmocka_unit_test(test_empty_file),
        cmocka_unit_test(test_missing_and_directory),
        cmocka_unit_test(test_unreadable),
        cmocka_unit_test(test_write_errors_leave_nothing),
        cmocka_unit_test(test_readonly_dir),
        cmocka_unit_test(test_overwrite_is_atomic),
        cmocka_unit_test(test_all_formats_round_trip),
        cmocka_unit_test(test_forced_format),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
