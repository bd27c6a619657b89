/* Slow paths of the text scanners and number formatting. */
#include "text.h"

/* Where a number may end besides a blank or a newline: OBJ's corner
 * separator, a comment, the separators of XYZ fields. */
static bool at_number_end(const char *s, const char *end)
{
    return s >= end || mr_is_space(*s) || *s == '\n' || *s == '/' || *s == '#' || *s == ',' ||
           *s == ';';
}

/*
 * A decimal number [+-] digits [. digits] [(e|E) [+-] digits] with at least
 * one mantissa digit, of any length: its value is 0.D * 10^exp10, D being
 * the mantissa digits from `first` (the first nonzero one) to `mant_end`,
 * the '.' skipped. Exponents are saturated far beyond any double, so that
 * no count overflows however long the text.
 */
typedef struct decimal {
    const char *end;      /* just past the number */
    const char *first;    /* first nonzero mantissa digit; NULL when the value is 0 */
    const char *mant_end; /* just past the mantissa (before any exponent) */
    int64_t exp10;
    bool neg;
} decimal;

enum { EXP_CAP = 100000000 }; /* |exponents| are saturated here */

static bool scan_decimal(const char *s, const char *end, decimal *d)
{
    d->neg = false;
    d->first = NULL;
    if (s < end && (*s == '-' || *s == '+')) {
        d->neg = *s == '-';
        s++;
    }
    bool any = false;
    int64_t e = 0;
    for (; s < end && mr_is_digit(*s); s++, any = true) {
        if (!d->first && *s != '0')
            d->first = s;
        if (d->first && e < EXP_CAP)
            e++; /* an integer digit */
    }
    if (s < end && *s == '.') {
        for (s++; s < end && mr_is_digit(*s); s++, any = true)
            if (!d->first) {
                if (*s != '0')
                    d->first = s;
                else if (e > -EXP_CAP)
                    e--; /* a zero before the first significant digit */
            }
    }
    if (!any)
        return false;
    d->mant_end = s;
    if (s < end && (*s == 'e' || *s == 'E')) {
        const char *t = s + 1;
        bool eneg = false;
        if (t < end && (*t == '-' || *t == '+')) {
            eneg = *t == '-';
            t++;
        }
        if (t < end && mr_is_digit(*t)) { /* "1e" without digits: the 'e' is not ours */
            int64_t x = 0;
            for (; t < end && mr_is_digit(*t); t++)
                if (x < EXP_CAP)
                    x = x * 10 + (*t - '0');
            e += eneg ? -x : x;
            s = t;
        }
    }
    d->exp10 = e;
    d->end = s;
    return true;
}

/*
 * The correctly rounded double of a decimal. A halfway point between two
 * doubles has at most 767 significant digits, so the first 800 digits and
 * a nonzero digit after them standing for all the rest (a "sticky" digit)
 * lie on the same side of every double and halfway point as the whole
 * number: strtod of that short form rounds like strtod of the whole.
 */
static double decimal_value(const char *start, const decimal *d)
{
    enum { MAX_SIG = 800, SHORT = 120 };
    if (!d->first || d->exp10 < -400) /* below half the least subnormal: 0 */
        return d->neg ? -0.0 : 0.0;
    if (d->exp10 > 400) /* at least 1e399 */
        return d->neg ? -INFINITY : INFINITY;
    char buf[MAX_SIG + 32];
    size_t len = (size_t)(d->end - start);
    if (len < SHORT) { /* the usual case (17 digits of a double): strtod of the text */
        memcpy(buf, start, len);
        buf[len] = '\0';
        return strtod(buf, NULL);
    }
    size_t n = 0, sig = 0;
    if (d->neg)
        buf[n++] = '-';
    buf[n++] = '0';
    buf[n++] = '.';
    for (const char *c = d->first; c < d->mant_end; c++) {
        if (*c == '.')
            continue;
        if (sig < MAX_SIG) {
            buf[n++] = *c;
            sig++;
        } else if (*c != '0') {
            buf[n++] = '1';
            break;
        }
    }
    snprintf(buf + n, sizeof buf - n, "e%d", (int)d->exp10);
    return strtod(buf, NULL);
}

/* "inf", "infinity", "nan" and "nan(...)" with an optional sign, through
 * strtod on a bounded copy (the buffer is not NUL-terminated). */
static bool parse_special(const char **p, const char *end, double *out)
{
    char buf[64];
    const char *s = *p;
    size_t n = 0;
    while (s + n < end && n < sizeof buf - 1 && !at_number_end(s + n, end))
        n++;
    if (n == 0 || n == sizeof buf - 1)
        return false;
    memcpy(buf, s, n);
    buf[n] = '\0';
    char *stop;
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

bool mr_parse_double_slow(const char **p, const char *end, double *out)
{
    decimal d;
    if (!scan_decimal(*p, end, &d))
        return parse_special(p, end, out);
    *out = decimal_value(*p, &d);
    *p = d.end;
    return true;
}

bool mr_number_too_large(const char *p, const char *end, bool integer)
{
    decimal d;
    if (!scan_decimal(p, end, &d) || !at_number_end(d.end, end))
        return false;
    if (!integer)
        return isinf(decimal_value(p, &d));
    if (d.mant_end != d.end || memchr(p, '.', (size_t)(d.end - p)))
        return false; /* a fraction or an exponent: not an integer at all */
    const char *s = p;
    int64_t v;
    return !mr_parse_i64(&s, end, &v);
}

void mr_number_excerpt(const char *p, const char *end, char *buf, size_t cap)
{
    enum { SHOWN = 24 };
    size_t n = 0, digits = 0;
    while (p + n < end && !at_number_end(p + n, end)) {
        digits += mr_is_digit(p[n]);
        n++;
    }
    char shown[SHOWN + 1];
    size_t k = n < SHOWN ? n : SHOWN;
    for (size_t i = 0; i < k; i++)
        shown[i] = (p[i] >= 32 && p[i] < 127) ? p[i] : '?';
    shown[k] = '\0';
    if (n <= SHOWN)
        snprintf(buf, cap, "'%s'", shown);
    else
        snprintf(buf, cap, "'%s...' (%zu %s)", shown, digits ? digits : n,
                 digits ? "digits" : "characters");
}

void mr_number_error(const char *p, const char *end, bool integer, char *buf, size_t cap)
{
    char tok[80];
    if (mr_number_too_large(p, end, integer)) {
        mr_number_excerpt(p, end, tok, sizeof tok);
        snprintf(buf, cap, "number %s is out of range", tok);
    } else {
        mr_token_excerpt(p, end, tok, sizeof tok);
        snprintf(buf, cap, "malformed number '%s'", tok);
    }
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
    /* a longer token is marked as cut, so that it does not read as whole */
    if (n + 4 <= cap && p + n < end && p[n] != '\n' && p[n] != '\r' && !mr_is_space(p[n])) {
        memcpy(buf + n, "...", 3);
        n += 3;
    }
    buf[n] = '\0';
}
