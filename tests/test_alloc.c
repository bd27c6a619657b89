/*
 * The library's array allocation (core/error.c): blocks of every size
 * around the huge-page thresholds hold what is written to them, calloc'd
 * ones start at zero, realloc keeps the contents across the thresholds in
 * both directions, and on Linux the large blocks start on a 2 MiB boundary
 * (where their huge pages are asked for) unless MR_HUGE_PAGES=0.
 */
#include "testutil.h"
#include "core/internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MIB ((size_t)1 << 20)

/* Sizes below, at and above the points where the rule changes: 2 MiB less
 * an eighth (the last huge page taken whole), 2 MiB, 4 MiB. */
static const size_t sizes[] = {1,
                               4096,
                               MIB,
                               2 * MIB - 2 * MIB / 9 - 1,
                               2 * MIB - 2 * MIB / 9 + 64,
                               2 * MIB - 1,
                               2 * MIB,
                               2 * MIB + 1,
                               3 * MIB + 12345,
                               4 * MIB,
                               9 * MIB + 7};

static void fill(uint8_t *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++)
        p[i] = (uint8_t)(i * 2654435761u >> 13 ^ seed);
}

static void check(const uint8_t *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++)
        if (p[i] != (uint8_t)(i * 2654435761u >> 13 ^ seed))
            fail_msg("byte %zu of %zu changed", i, n);
}

static bool huge_on(void)
{
    const char *e = getenv("MR_HUGE_PAGES");
    return !(e && strcmp(e, "0") == 0);
}

static void test_alloc_sizes(void **state)
{
    (void)state;
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        const size_t n = sizes[k];
        uint8_t *p = mr_alloc_array(n, 1);
        assert_non_null(p);
        fill(p, n, (unsigned)k);
        check(p, n, (unsigned)k);
#if defined(__linux__)
        /* from 2 MiB on, a block has at least one whole huge page: it
         * starts on a huge page's boundary */
        if (n >= 2 * MIB && huge_on())
            assert_int_equal((uintptr_t)p % (2 * MIB), 0);
#endif
        free(p);

        uint32_t *z = mr_calloc_array(n / 4 + 1, 4);
        assert_non_null(z);
        for (size_t i = 0; i < n / 4 + 1; i++)
            if (z[i])
                fail_msg("calloc'd word %zu of %zu is %u", i, n / 4 + 1, z[i]);
        free(z);
    }
    /* counts whose product overflows are refused */
    assert_null(mr_alloc_array(SIZE_MAX / 2, 4));
    assert_null(mr_calloc_array(SIZE_MAX / 2, 4));
}

static void test_realloc_across(void **state)
{
    (void)state;
    /* grow from nothing through every size, then shrink back: the common
     * prefix survives each step */
    uint8_t *p = mr_realloc_array(NULL, sizes[0], 1);
    assert_non_null(p);
    fill(p, sizes[0], 7);
    size_t have = sizes[0];
    const size_t ns = sizeof sizes / sizeof *sizes;
    for (size_t k = 1; k < 2 * ns - 1; k++) {
        const size_t n = sizes[k < ns ? k : 2 * ns - 2 - k];
        p = mr_realloc_array(p, n, 1);
        assert_non_null(p);
        check(p, have < n ? have : n, 7);
        fill(p, n, 7);
        have = n;
    }
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alloc_sizes),
        cmocka_unit_test(test_realloc_across),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
