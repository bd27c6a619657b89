/*
 * The simplifier's vector kernels (src/qem/core/kernels.h) on every CPU path
 * this machine has: each path gives the default path's bits, and the
 * default path gives the one-edge scalar evaluation's (the greedy
 * strategy's costs and the batched strategy's are the same numbers), on
 * random inputs and on the edge cases each kernel selects on. End to end:
 * the CLI under MR_SIMD=default writes the same bytes as on the best path.
 */
#include "testutil.h"
#include "qem/core/kernels.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double rnd(void) /* [-0.5, 0.5) */
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0 - 0.5;
}

/* A quadric as the simplifier builds them: a few area-weighted planes
 * (kind 0), one plane (singular: the solve falls back to the edge), or
 * nothing at all (kind 2). Relative to its own vertex, so planes pass
 * near the origin. */
static void random_quadric(mr_quadricf *q, int kind)
{
    mr_quadric a;
    mr_quadric_zero(&a);
    const int planes = kind == 0 ? 2 + (int)((rnd() + 0.5) * 6) : kind == 1 ? 1 : 0;
    for (int p = 0; p < planes; p++) {
        double n[3] = {rnd(), rnd(), rnd()};
        const double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int i = 0; i < 3; i++)
            n[i] /= l;
        mr_quadric_add_plane(&a, n, rnd() * 1e-3, (rnd() + 0.5) * 1e-5);
    }
    mr_quadric_store(q, &a);
}

/* Planes through point p (in the quadric's coordinates): moved by p, the
 * quadric's linear part cancels to rounding noise, as at a collapse to
 * the optimum -- where any change in the order of the sums shows in the
 * stored floats. */
static void quadric_through(mr_quadricf *q, const double p[3])
{
    mr_quadric a;
    mr_quadric_zero(&a);
    for (int i = 0; i < 4; i++) {
        double n[3] = {rnd(), rnd(), rnd()};
        const double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; k++)
            n[k] /= l;
        mr_quadric_add_plane(&a, n, -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2]),
                             (rnd() + 0.5) * 1e-5);
    }
    mr_quadric_store(q, &a);
}

static const mr_kernels *path_or_skip(int p)
{
    const mr_kernels *k = mr_kernels_path(p);
    if (!k)
        print_message("path %d: not on this CPU or build, skipped\n", p);
    return k;
}

/* One edge through the one-edge form (stride 1), as full_cost calls it. */
static __attribute__((noinline)) double one_edge(const float *in, double x[3],
                                                 const double box[3])
{
    return mr_free_cost(in, 1, x, 1, box);
}

static void test_free_costs(void **state)
{
    (void)state;
    enum { B = MR_COST_BATCH };
    const double box[3] = {0.5, 0.4, 0.3};
    const mr_kernels *def = mr_kernels_path(MR_PATH_DEFAULT);
    assert_non_null(def);
    size_t solved = 0, on_edge = 0, zero = 0;
    for (int it = 0; it < 3000; it++) {
        static float in[FREE_INPUTS * B];
        const size_t n = 1 + (size_t)it % B; /* partial batches too */
        for (size_t l = 0; l < n; l++) {
            mr_quadricf qu, qw;
            const int kind = (int)(l % 7 == 3) + 2 * (int)(l % 11 == 5);
            random_quadric(&qu, kind);
            random_quadric(&qw, kind);
            /* now and then an edge near the box's wall: optimum outside */
            const double reach = l % 13 == 0 ? 0.49 : 0.3;
            for (int k = 0; k < 11; k++) {
                in[(FREE_QU + k) * B + l] = (&qu.a00)[k];
                in[(FREE_QW + k) * B + l] = (&qw.a00)[k];
            }
            for (int k = 0; k < 3; k++) {
                const float pw = (float)(rnd() * 2 * reach);
                in[(FREE_PW + k) * B + l] = pw;
                in[(FREE_PU + k) * B + l] = pw + (float)(rnd() * 1e-2);
            }
        }
        double ref[B], xref[3 * B];
        def->free_costs(in, n, ref, xref, box);
        for (size_t l = 0; l < n; l++) {
            float one[FREE_INPUTS];
            for (int k = 0; k < FREE_INPUTS; k++)
                one[k] = in[(size_t)k * B + l];
            double x[3];
            const double c = one_edge(one, x, box);
            assert_memory_equal(&c, &ref[l], sizeof c);
            for (int k = 0; k < 3; k++)
                assert_memory_equal(&x[k], &xref[(size_t)k * B + l], sizeof x[k]);
            zero += c == 0;
            /* the target lies on the edge (from w at 0 to u - w) or off it */
            const double d[3] = {(double)one[FREE_PU] - one[FREE_PW],
                                 (double)one[FREE_PU + 1] - one[FREE_PW + 1],
                                 (double)one[FREE_PU + 2] - one[FREE_PW + 2]};
            const double cr[3] = {x[1] * d[2] - x[2] * d[1], x[2] * d[0] - x[0] * d[2],
                                  x[0] * d[1] - x[1] * d[0]};
            const bool along = fabs(cr[0]) + fabs(cr[1]) + fabs(cr[2]) <= 1e-12;
            on_edge += along;
            solved += !along;
        }
        for (int p = MR_PATH_DEFAULT + 1; p < MR_PATHS; p++) {
            const mr_kernels *k = mr_kernels_path(p);
            if (!k)
                continue;
            double c[B], x[3 * B];
            k->free_costs(in, n, c, x, box);
            assert_memory_equal(c, ref, n * sizeof *c);
            for (int r = 0; r < 3; r++)
                assert_memory_equal(x + r * B, xref + r * B, n * sizeof *x);
        }
    }
    /* every branch of the selection was taken */
    assert_true(solved > 1000);
    assert_true(on_edge > 1000);
    assert_true(zero > 100);
    for (int p = MR_PATH_DEFAULT + 1; p < MR_PATHS; p++)
        path_or_skip(p);
}

static void test_plane_terms(void **state)
{
    (void)state;
    enum { R = MR_PLANE_ROW };
    size_t flat = 0;
    for (int it = 0; it < 2000; it++) {
        double in[6 * R], ref[7 * R];
        const size_t n = 4 * (1 + (size_t)it % (MR_PLANE_FAN / 4));
        for (size_t i = 0; i < n; i++) {
            const double scale = i % 5 == 4 ? 1e-9 : 1e-2;
            for (int k = 0; k < 6; k++)
                in[(size_t)k * R + i] = (float)(rnd() * scale);
            if (i % 9 == 2) /* no area: both edges along one line */
                for (int k = 0; k < 3; k++)
                    in[(size_t)(3 + k) * R + i] = 2 * in[(size_t)k * R + i];
            if (i % 17 == 7) /* a point */
                for (int k = 0; k < 6; k++)
                    in[(size_t)k * R + i] = 0;
        }
        mr_kernels_path(MR_PATH_DEFAULT)->plane_terms(in, n, ref);
        for (size_t i = 0; i < n; i++)
            flat += ref[6 * R + i] == 0;
        for (int p = MR_PATH_DEFAULT + 1; p < MR_PATHS; p++) {
            const mr_kernels *k = mr_kernels_path(p);
            if (!k)
                continue;
            double out[7 * R];
            k->plane_terms(in, n, out);
            for (int r = 0; r < 7; r++)
                assert_memory_equal(out + r * R, ref + r * R, n * sizeof *out);
        }
    }
    assert_true(flat > 100);
}

static void test_fan_ok(void **state)
{
    (void)state;
    enum { R = MR_FAN_ROW };
    static double in[9 * R];
    size_t pass = 0, fail = 0;
    for (int it = 0; it < 4000; it++) {
        /* a fan of triangles (o, a, b) around o in the z = 0 plane, o
         * moving to t: small moves keep every normal, larger ones tip or
         * flip some */
        const size_t n = 4 * (1 + (size_t)it % 8);
        for (size_t i = 0; i < n; i++) {
            const double a0 = 6.283185307179586 * (double)i / (double)n,
                         a1 = 6.283185307179586 * (double)(i + 1) / (double)n;
            const double p[9] = {0, 0, 0, cos(a0), sin(a0), rnd() * 0.2,
                                 cos(a1), sin(a1), rnd() * 0.2};
            for (int k = 0; k < 9; k++)
                in[(size_t)k * R + i] = (float)p[k];
        }
        const double reach = it % 4 == 0 ? 0.05 : 1.5;
        const double t[3] = {rnd() * reach, rnd() * reach, rnd() * reach};
        const double min_cos = it % 3 == 0 ? 0.0 : 0.5;
        const bool ref = mr_kernels_path(MR_PATH_DEFAULT)->fan_ok(in, n, t, min_cos);
        pass += ref;
        fail += !ref;
        for (int p = MR_PATH_DEFAULT + 1; p < MR_PATHS; p++) {
            const mr_kernels *k = mr_kernels_path(p);
            if (k)
                assert_int_equal(k->fan_ok(in, n, t, min_cos), ref);
        }
    }
    assert_true(pass > 400);
    assert_true(fail > 400);
}

/* Two fans around the edge (r, k) of a ring mesh: r = 0 and k = 1 in the
 * middle, n outer vertices 2 .. n + 1 around both (wound one way), every
 * triangle listed at its corners; some triangles deleted. */
static void test_fan_sums(void **state)
{
    (void)state;
    enum { NMAX = 24 };
    float pos[3 * (NMAX + 2) + 1];
    uint32_t tris[3 * 2 * NMAX], lr[2 * NMAX], lk[2 * NMAX];
    size_t differ = 0, edges = 0, dead = 0;
    for (int it = 0; it < 3000; it++) {
        const uint32_t n = 4 + (uint32_t)it % (NMAX - 4);
        /* r at the origin, k at (1, 0, 0), the ring around both, bumpy */
        pos[0] = (float)(rnd() * 0.1), pos[1] = (float)(rnd() * 0.1), pos[2] = (float)(rnd() * 0.1);
        pos[3] = (float)(1 + rnd() * 0.1), pos[4] = (float)(rnd() * 0.1), pos[5] = (float)(rnd() * 0.1);
        for (uint32_t i = 0; i < n; i++) {
            const double a = 6.283185307179586 * i / n;
            pos[3 * (2 + i)] = (float)(0.5 + 1.2 * cos(a) + rnd() * 0.2);
            pos[3 * (2 + i) + 1] = (float)(sin(a) + rnd() * 0.2);
            pos[3 * (2 + i) + 2] = (float)(rnd() * 0.6);
        }
        pos[3 * (n + 2)] = 0; /* the padding float */
        /* the ring's first half around r, the second around k; the two
         * triangles between them hold both */
        uint32_t nt = 0, nr = 0, nk = 0;
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t a = 2 + i, b = 2 + (i + 1) % n;
            const bool at_k = i >= n / 2;
            const uint32_t c = at_k ? 1 : 0;
            tris[3 * nt] = c, tris[3 * nt + 1] = a, tris[3 * nt + 2] = b;
            (at_k ? lk : lr)[at_k ? nk++ : nr++] = 3 * nt;
            nt++;
        }
        /* the edge triangles (r, k, ring[0]) and (k, r, ring[n/2]) */
        const uint32_t e[2][3] = {{0, 1, 2}, {1, 0, 2 + n / 2}};
        for (int j = 0; j < 2; j++) {
            memcpy(tris + 3 * nt, e[j], sizeof e[j]);
            lr[nr++] = 3 * nt + (j == 0 ? 0 : 1);
            lk[nk++] = 3 * nt + (j == 0 ? 1 : 0);
            nt++;
            edges++;
        }
        for (uint32_t t = 0; t < nt; t++)
            if (it % 5 == 0 && t % 7 == 3) { /* a lazy list's deleted triangle */
                tris[3 * t] = UINT32_MAX;
                dead++;
            }
        const mr_fan_input in = {pos, tris, lr, lk, nr, nk, 0, 1};
        const double o[3] = {pos[3], pos[4], pos[5]};
        for (int full = 0; full < 2; full++) {
            double ref[MR_FAN_SUMS];
            for (int i = 0; i < MR_FAN_SUMS; i++) /* sums carried in */
                ref[i] = it % 2 ? rnd() : 0;
            double start[MR_FAN_SUMS];
            memcpy(start, ref, sizeof ref);
            mr_kernels_path(MR_PATH_DEFAULT)->fan_sums(&in, o, full, ref);
            /* the default path: g is the normals' sum of the triangles that
             * stay, h the volumes of r's */
            assert_true(ref[MR_FAN_G] != start[MR_FAN_G] || it % 5 == 0);
            for (int p = MR_PATH_DEFAULT + 1; p < MR_PATHS; p++) {
                const mr_kernels *k = mr_kernels_path(p);
                if (!k)
                    continue;
                double got[MR_FAN_SUMS];
                memcpy(got, start, sizeof got);
                k->fan_sums(&in, o, full, got);
                differ += memcmp(got, ref, sizeof got) != 0;
            }
        }
    }
    assert_int_equal(differ, 0);
    assert_true(dead > 100 && edges == 6000);
}

static void test_merge(void **state)
{
    (void)state;
    for (int it = 0; it < 20000; it++) {
        mr_quadricf k0, r0;
        const double s = it % 3 == 0 ? 1e-6 : 1e-2;
        double dk[3] = {rnd() * s, rnd() * s, rnd() * s};
        double dr[3] = {rnd() * s, rnd() * s, rnd() * s};
        if (it % 2) { /* both moved to where their planes meet */
            quadric_through(&k0, dk);
            quadric_through(&r0, dr);
        } else {
            random_quadric(&k0, it % 5 == 0 ? 1 : 0);
            random_quadric(&r0, it % 7 == 0 ? 2 : 0);
        }
        /* the scalar form, written out: shift both, add, store */
        mr_quadric qk, qr;
        mr_quadric_load(&qk, &k0);
        mr_quadric_load(&qr, &r0);
        mr_quadric_shift(&qk, dk);
        mr_quadric_shift(&qr, dr);
        mr_quadric_add(&qk, &qr);
        mr_quadricf want;
        mr_quadric_store(&want, &qk);
        for (int p = MR_PATH_DEFAULT; p < MR_PATHS; p++) {
            const mr_kernels *k = mr_kernels_path(p);
            if (!k)
                continue;
            /* the record after k untouched (the vector form stores 11 floats) */
            mr_quadricf out[2] = {k0, r0};
            k->merge(&out[0], &r0, dk, dr);
            assert_memory_equal(&out[0], &want, sizeof want);
            assert_memory_equal(&out[1], &r0, sizeof r0);
        }
    }
}

static void test_choice(void **state)
{
    (void)state;
    const mr_kernels *best = NULL;
    for (int p = MR_PATHS - 1; p >= MR_PATH_DEFAULT && !best; p--)
        best = mr_kernels_path(p);
    const char *force = getenv("MR_SIMD");
    if (!force || strcmp(force, "default") != 0)
        assert_ptr_equal(mr_kernels_get(), best);
    mr_kernels_use(mr_kernels_path(MR_PATH_DEFAULT));
    assert_ptr_equal(mr_kernels_get(), mr_kernels_path(MR_PATH_DEFAULT));
    mr_kernels_use(NULL);
    assert_non_null(mr_kernels_get());
    print_message("kernels in use: %s\n", mr_kernels_get()->name);
}

/* The CLI on the default path writes the bytes it writes on the best one:
 * a generated scan with boundaries, full and half-edge collapse. */
static void test_cli_paths(void **state)
{
    (void)state;
    char in[512], a[512], b[512], cmd[2048];
    snprintf(in, sizeof in, "%s/kernels-in.ply", MR_TEST_TMPDIR);
    snprintf(a, sizeof a, "%s/kernels-a.ply", MR_TEST_TMPDIR);
    snprintf(b, sizeof b, "%s/kernels-b.ply", MR_TEST_TMPDIR);
    snprintf(cmd, sizeof cmd, "'%s' generate scan --triangles 60k -o '%s' -q", MR_CLI_PATH, in);
    assert_int_equal(system(cmd), 0);
    const char *modes[2] = {"--collapse full", "--collapse half"};
    for (int i = 0; i < 2; i++) {
        snprintf(cmd, sizeof cmd, "'%s' simplify '%s' -o '%s' --ratio 0.05 %s -q", MR_CLI_PATH,
                 in, a, modes[i]);
        assert_int_equal(system(cmd), 0);
        snprintf(cmd, sizeof cmd, "MR_SIMD=default '%s' simplify '%s' -o '%s' --ratio 0.05 %s -q",
                 MR_CLI_PATH, in, b, modes[i]);
        assert_int_equal(system(cmd), 0);
        snprintf(cmd, sizeof cmd, "cmp -s '%s' '%s'", a, b);
        assert_int_equal(system(cmd), 0);
    }
    remove(in);
    remove(a);
    remove(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_free_costs), cmocka_unit_test(test_plane_terms),
        cmocka_unit_test(test_fan_ok),     cmocka_unit_test(test_merge),
        cmocka_unit_test(test_fan_sums),
        cmocka_unit_test(test_choice),     cmocka_unit_test(test_cli_paths),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
