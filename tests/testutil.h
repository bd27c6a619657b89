/* Helpers shared by the cmocka tests. */
#ifndef MR_TESTUTIL_H
#define MR_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "meshreduce.h"

/* A path in the tests' scratch directory (unique per test process). */
const char *tu_tmp_path(const char *filename);

/* Write `size` bytes to `path`; fails the test on error. */
void tu_write_file(const char *path, const void *data, size_t size);

/* Read a whole file into a malloc'd buffer (NUL-terminated); NULL if absent. */
char *tu_read_file(const char *path, size_t *size);

/* True when a file exists. */
int tu_file_exists(const char *path);

/* Full path of a mesh in ../shared/data, or NULL when the folder (or the
 * file) is absent: the caller then skip()s. */
const char *tu_shared_data(const char *filename);

/* Parse a string as a file of the given name (format from its extension). */
mr_status tu_read_string(const char *text, const char *name, mr_mesh *mesh, mr_error *err);

/* printf into a static buffer (valid until the next call), for building
 * command lines. */
const char *tu_fmt(const char *format, ...) __attribute__((format(printf, 1, 2)));

/* Run the command-line tool with the given arguments (one shell string,
 * appended to the tool's path); returns its exit status and, when out is
 * non-NULL, stores its combined stdout+stderr (malloc'd) there. */
int tu_run_cli(const char *args, char **out);

/* Assert that `haystack` contains `needle`, printing both otherwise. */
#define tu_assert_contains(haystack, needle) \
    tu_assert_contains_impl((haystack), (needle), __FILE__, __LINE__)
void tu_assert_contains_impl(const char *haystack, const char *needle, const char *file,
                             int line);

/* Two meshes hold the same vertices (bitwise positions and attributes) and
 * the same triangles. */
void tu_assert_mesh_equal(const mr_mesh *a, const mr_mesh *b);

#endif
