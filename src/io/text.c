/* Slow paths of the text scanners and number formatting. */
#include "text.h"

#include <errno.h>

bool mr_parse_double_slow(const char **p, const char *end, double *out)
{
    /* Longest accepted token: longer ones are not numbers we write or
     * that exporters produce, and reading them through a bounded copy
     * keeps strtod away from the unterminated buffer. */
    char buf[128];
    const char *s = *p;
    size_t n = 0;
    while (s + n < end && n < sizeof buf - 1 && !mr_is_space(s[n]) && s[n] != '\n' &&
           s[n] != '/' && s[n] != '#' && s[n] != ',' && s[n] != ';')
        n++;
    if (n == 0 || n == sizeof buf - 1)
        return false;
    memcpy(buf, s, n);
    buf[n] = '\0';
    char *stop;
    errno = 0;
    double v = strtod(buf, &stop);
    if (stop == buf)
        return false;
    /* strtod accepts hex floats ("0x1p3"); the formats we read do not. */
    for (const char *c = buf; c < stop; c++)
        if (*c == 'x' || *c == 'X')
            return false;
    *out = v;
    *p = s + (stop - buf);
    return true;
}

uint64_t mr_line_of(const char *begin, const char *pos)
{
    uint64_t line = 1;
    for (const char *c = begin; c < pos; c++)
        line += *c == '\n';
    return line;
}

/* The general path: printf's rounding at increasing precision. */
static int format_float_printf(char *buf, float v)
{
    for (int prec = 6; prec < 9; prec++) {
        int n = snprintf(buf, 32, "%.*g", prec, (double)v);
        if (strtof(buf, NULL) == v)
            return n;
    }
    return snprintf(buf, 32, "%.9g", (double)v);
}

/* Write the decimal m * 10^(e10 - ndigits + 1), m having ndigits digits,
 * in fixed notation, trailing zeros of the fraction removed. */
static int write_fixed(char *buf, bool neg, uint64_t m, int ndigits, int e10)
{
    char digits[20];
    for (int i = ndigits - 1; i >= 0; i--) {
        digits[i] = (char)('0' + m % 10);
        m /= 10;
    }
    while (ndigits > 1 && digits[ndigits - 1] == '0' && ndigits > e10 + 1)
        ndigits--;
    char *o = buf;
    if (neg)
        *o++ = '-';
    if (e10 < 0) {
        *o++ = '0';
        *o++ = '.';
        for (int i = 0; i < -e10 - 1; i++)
            *o++ = '0';
        memcpy(o, digits, (size_t)ndigits);
        o += ndigits;
    } else {
        for (int i = 0; i <= e10; i++)
            *o++ = i < ndigits ? digits[i] : '0';
        if (ndigits > e10 + 1) {
            *o++ = '.';
            memcpy(o, digits + e10 + 1, (size_t)(ndigits - e10 - 1));
            o += ndigits - e10 - 1;
        }
    }
    *o = '\0';
    return (int)(o - buf);
}

int mr_format_float(char *buf, float v)
{
    static const double p10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                 1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    if (v == 0.0f)
        return snprintf(buf, 32, "%s", signbit(v) ? "-0" : "0");
    double d = fabs((double)v);
    /* The fast path covers the magnitudes of mesh coordinates; the rest
     * (and non-finite values) goes through printf. */
    if (!(d >= 1e-5 && d < 1e9))
        return format_float_printf(buf, v);
    int e10 = (int)floor(log10(d));
    /* Shortest digits first: 6 significant digits cover most values that
     * have a short form; then 7, 8 and 9 (9 always round-trips). Each
     * candidate m * 10^(e10 - prec + 1) is checked by converting it back,
     * which is exact here (m < 2^53, power of ten <= 10^22). */
    for (int prec = 6; prec <= 9; prec++) {
        int k = prec - 1 - e10; /* scale to prec integer digits */
        double scaled = k >= 0 ? d * p10[k] : d / p10[-k];
        uint64_t m = (uint64_t)(scaled + 0.5);
        int e = e10;
        if (m >= (uint64_t)p10[prec]) { /* log10 rounded up, or carry */
            m = (m + 5) / 10;
            e++;
        } else if (m < (uint64_t)p10[prec - 1]) {
            return format_float_printf(buf, v);
        }
        int back_k = prec - 1 - e;
        double back = back_k >= 0 ? (double)m / p10[back_k] : (double)m * p10[-back_k];
        if ((float)back == fabsf(v))
            return write_fixed(buf, v < 0, m, prec, e);
    }
    return format_float_printf(buf, v);
}

void mr_token_excerpt(const char *p, const char *end, char *buf, size_t cap)
{
    size_t n = 0;
    while (p + n < end && n + 1 < cap && n < 24 && p[n] != '\n' && p[n] != '\r' &&
           !mr_is_space(p[n]))
        n++;
    for (size_t i = 0; i < n; i++)
        buf[i] = (p[i] >= 32 && p[i] < 127) ? p[i] : '?';
    buf[n] = '\0';
}
