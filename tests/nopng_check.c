/* Built only without libpng (MR_HAVE_PNG off): mr_png_write fails with
 * MR_ERR_UNSUPPORTED and a message that says PNG support was not built,
 * and creates no file. */
#include "testutil.h"

#include <unistd.h>

static void test_png_not_built(void **state)
{
    (void)state;
    uint8_t img[4 * 2 * 2] = {0};
    const char *path = tu_tmp_path("nopng.png");
    unlink(path);
    mr_error err;
    assert_int_equal(mr_png_write(path, img, 2, 2, &err), MR_ERR_UNSUPPORTED);
    tu_assert_contains(err.message, "PNG output: support was not built");
    assert_int_not_equal(access(path, F_OK), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_png_not_built)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
