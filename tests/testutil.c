#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

const char *tu_tmp_path(const char *filename)
{
    static char buf[8][1024];
    static int slot;
    char *p = buf[slot++ % 8];
    char dir[900];
    snprintf(dir, sizeof dir, "%s/%ld", MR_TEST_TMPDIR, (long)getpid());
    mkdir(MR_TEST_TMPDIR, 0777);
    mkdir(dir, 0777);
    snprintf(p, 1024, "%s/%s", dir, filename);
    return p;
}

void tu_write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
}

char *tu_read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    if (fread(buf, 1, (size_t)n, f) != (size_t)n) {
        fclose(f);
        free(buf);
        return NULL;
    }
    buf[n] = '\0';
    fclose(f);
    if (size)
        *size = (size_t)n;
    return buf;
}

int tu_file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

const char *tu_shared_data(const char *filename)
{
    static char buf[4][1024];
    static int slot;
    char *p = buf[slot++ % 4];
    snprintf(p, 1024, "%s/%s", MR_SHARED_DATA, filename);
    return tu_file_exists(p) ? p : NULL;
}

mr_status tu_read_string(const char *text, const char *name, mr_mesh *mesh, mr_error *err)
{
    return mr_mesh_read_memory(text, strlen(text), name, NULL, mesh, err);
}

int tu_run_cli(const char *args, char **out)
{
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "'%s' %s 2>&1", MR_CLI_PATH, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t cap = 4096, len = 0;
    char *buf = malloc(cap);
    size_t n;
    while ((n = fread(buf + len, 1, cap - len - 1, p)) > 0) {
        len += n;
        if (cap - len < 2) {
            cap *= 2;
            buf = realloc(buf, cap);
        }
    }
    buf[len] = '\0';
    int status = pclose(p);
    if (out)
        *out = buf;
    else
        free(buf);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

void tu_assert_contains_impl(const char *haystack, const char *needle, const char *file,
                             int line)
{
    if (!haystack || !strstr(haystack, needle)) {
        print_error("%s:%d: expected to find \"%s\" in:\n%s\n", file, line, needle,
                    haystack ? haystack : "(null)");
        _fail(file, line);
    }
}

void tu_assert_mesh_equal(const mr_mesh *a, const mr_mesh *b)
{
    assert_int_equal(a->vertex_count, b->vertex_count);
    assert_int_equal(a->triangle_count, b->triangle_count);
    assert_memory_equal(a->positions, b->positions, a->vertex_count * 3 * sizeof(float));
    assert_memory_equal(a->indices, b->indices, a->triangle_count * 3 * sizeof(uint32_t));
    assert_int_equal(a->normals != NULL, b->normals != NULL);
    assert_int_equal(a->texcoords != NULL, b->texcoords != NULL);
    assert_int_equal(a->colors != NULL, b->colors != NULL);
    if (a->normals)
        assert_memory_equal(a->normals, b->normals, a->vertex_count * 3 * sizeof(float));
    if (a->texcoords)
        assert_memory_equal(a->texcoords, b->texcoords, a->vertex_count * 2 * sizeof(float));
    if (a->colors)
        assert_memory_equal(a->colors, b->colors, a->vertex_count * 4 * sizeof(float));
}

const char *tu_fmt(const char *format, ...)
{
    static char buf[8192];
    va_list ap;
    va_start(ap, format);
    vsnprintf(buf, sizeof buf, format, ap);
    va_end(ap);
    return buf;
}
