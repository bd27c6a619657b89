/*
 * Bounds-checked scanning of text buffers that are not NUL-terminated
 * (memory-mapped files), shared by the OBJ, PLY-ascii, STL-ascii and XYZ
 * readers, and number formatting for the writers.
 *
 * Every scanner takes a cursor `*p` and an end pointer and never reads at
 * or past `end`.
 */
#ifndef MR_TEXT_H
#define MR_TEXT_H

#include "../core/internal.h"

#include <math.h>
#include <stdio.h>

static inline bool mr_is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
static inline bool mr_is_digit(char c) { return (unsigned)(c - '0') < 10u; }

/* Skip blanks (not newlines). */
static inline void mr_skip_blanks(const char **p, const char *end)
{
    const char *s = *p;
    while (s < end && mr_is_space(*s))
        s++;
    *p = s;
}

/* Advance past the end of the current line (past '\n', or to end). */
static inline void mr_skip_line(const char **p, const char *end)
{
    const char *s = *p;
    const char *nl = memchr(s, '\n', (size_t)(end - s));
    *p = nl ? nl + 1 : end;
}

/* True at end of line: end of buffer, '\n', or a '#' comment. Blanks and
 * '\r' before it are skipped. */
static inline bool mr_at_eol(const char **p, const char *end)
{
    mr_skip_blanks(p, end);
    return *p >= end || **p == '\n' || **p == '#';
}

/* Parse a decimal integer with optional sign. Returns false (cursor
 * unchanged) when no digits are there or the value overflows int64. */
static inline bool mr_parse_i64(const char **p, const char *end, int64_t *out)
{
    const char *s = *p;
    bool neg = false;
    if (s < end && (*s == '-' || *s == '+')) {
        neg = *s == '-';
        s++;
    }
    if (s >= end || !mr_is_digit(*s))
        return false;
    uint64_t v = 0;
    int n = 0;
    while (s < end && mr_is_digit(*s)) {
        v = v * 10 + (uint64_t)(*s - '0');
        s++;
        /* 18 digits always fit; only longer numbers need the exact check */
        if (++n == 18)
            break;
    }
    while (s < end && mr_is_digit(*s)) {
        uint64_t d = (uint64_t)(*s - '0');
        if (v > (UINT64_C(9223372036854775807) - d) / 10)
            return false;
        v = v * 10 + d;
        s++;
    }
    *out = neg ? -(int64_t)v : (int64_t)v;
    *p = s;
    return true;
}

/* The slow path of mr_parse_number: decimals of any length (their first
 * 800 significant digits and whether any later one is nonzero decide the
 * correctly rounded double), exponents of any size, "inf" and "nan". */
bool mr_parse_double_slow(const char **p, const char *end, double *out);

/*
 * Parse a floating-point number: [+-] digits [. digits] [(e|E) [+-] digits],
 * also "inf", "infinity", "nan" (any case) so that callers can reject them
 * with a clear message rather than a generic syntax error. The common case
 * (at most 19 significant digits, exponent within the exactly representable
 * powers of ten) is computed exactly with one double operation (Clinger's
 * fast path); the rest goes through strtod. Returns false, cursor
 * unchanged, when there is no number at the cursor. A decimal too large for
 * a double gives +-infinity, as strtod does (however many digits it has):
 * mr_number_too_large tells it from a written "inf" for messages.
 */
static inline bool mr_parse_number(const char **p, const char *end, double *out, bool exact)
{
    static const double pow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                   1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                   1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    const char *s = *p;
    bool neg = false;
    if (s < end && (*s == '-' || *s == '+')) {
        neg = *s == '-';
        s++;
    }
    uint64_t mant = 0;
    int digits = 0;  /* significant digits accumulated in mant */
    int scale = 0;   /* decimal exponent adjustment */
    bool any = false;
    while (s < end && *s == '0') { /* leading zeros are not significant */
        s++;
        any = true;
    }
    while (s < end && mr_is_digit(*s)) {
        if (digits < 19) {
            mant = mant * 10 + (uint64_t)(*s - '0');
            digits++;
        } else {
            return mr_parse_double_slow(p, end, out);
        }
        s++;
        any = true;
    }
    if (s < end && *s == '.') {
        s++;
        if (mant == 0)
            while (s < end && *s == '0') {
                s++;
                if (--scale < -400) /* very many zeros: no int overflow */
                    return mr_parse_double_slow(p, end, out);
                any = true;
            }
        while (s < end && mr_is_digit(*s)) {
            if (digits < 19) {
                mant = mant * 10 + (uint64_t)(*s - '0');
                digits++;
                scale--;
            } else {
                return mr_parse_double_slow(p, end, out);
            }
            s++;
            any = true;
        }
    }
    if (!any)
        return mr_parse_double_slow(p, end, out); /* inf, nan, or no number */
    if (s < end && (*s == 'e' || *s == 'E')) {
        const char *e = s + 1;
        bool eneg = false;
        if (e < end && (*e == '-' || *e == '+')) {
            eneg = *e == '-';
            e++;
        }
        if (e < end && mr_is_digit(*e)) {
            int ev = 0;
            while (e < end && mr_is_digit(*e)) {
                if (ev < 100000)
                    ev = ev * 10 + (*e - '0');
                e++;
            }
            scale += eneg ? -ev : ev;
            s = e;
        }
        /* "1e" without digits: the 'e' is not part of the number */
    }
    if (mant == 0) {
        *out = neg ? -0.0 : 0.0;
        *p = s;
        return true;
    }
    if (scale < -22 || scale > 22 || (exact && mant > (UINT64_C(1) << 53)))
        return mr_parse_double_slow(p, end, out);
    /* With more than 53 bits of mantissa (numbers written with %.17g) the
     * conversion rounds twice, an error far below a float's precision:
     * callers that want a float accept it. */
    double v = (double)mant;
    v = scale < 0 ? v / pow10[-scale] : v * pow10[scale];
    *out = neg ? -v : v;
    *p = s;
    return true;
}

/* A correctly rounded double. */
static inline bool mr_parse_double(const char **p, const char *end, double *out)
{
    return mr_parse_number(p, end, out, true);
}

/* Parse a float through double: decimal strings written with up to 9
 * significant digits round-trip exactly; longer ones are rounded to double
 * within an ulp first, which cannot change the float except for inputs
 * within 2^-29 of a halfway point between two floats. */
static inline bool mr_parse_float(const char **p, const char *end, float *out)
{
    double d;
    if (!mr_parse_number(p, end, &d, false))
        return false;
    *out = (float)d;
    return true;
}

/* Write the decimal digits of v (no terminator); returns their count. */
static inline int mr_format_u64(char *buf, uint64_t v)
{
    char tmp[20];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10);
        v /= 10;
    } while (v);
    for (int i = 0; i < n; i++)
        buf[i] = tmp[n - 1 - i];
    return n;
}

/* A token ends at end of buffer, a blank or a newline. */
static inline bool mr_at_token_end(const char *p, const char *end)
{
    return p >= end || mr_is_space(*p) || *p == '\n';
}

/* 1-based line number of position `pos` in buffer `begin` (counts '\n').
 * Used only when reporting an error, so speed does not matter. */
uint64_t mr_line_of(const char *begin, const char *pos);

/* Format a float with the fewest significant digits (up to 9) that read
 * back to the same float; returns the length written (buf >= 32 bytes). */
int mr_format_float(char *buf, float v);

/* A short printable excerpt of the token at p (for error messages): its
 * first 24 characters, then "..." when it is longer. */
void mr_token_excerpt(const char *p, const char *end, char *buf, size_t cap);

/* True when the token at p is a well-formed decimal number (an integer
 * when `integer`: [+-] digits only) that is too large for its type: an
 * int64 for integers (mr_parse_i64 refuses it), a double otherwise
 * (mr_parse_double gives infinity). For messages: "out of range" rather
 * than "malformed". A number ends at the end, a blank, a newline or one of
 * / # , ; */
bool mr_number_too_large(const char *p, const char *end, bool integer);

/* The number at p quoted for a message: "'123'", or for a long one its
 * first 24 characters and its length, "'111111111111111111111111...'
 * (10000000 digits)". */
void mr_number_excerpt(const char *p, const char *end, char *buf, size_t cap);

/* The message for a token at p that is not an acceptable number:
 * "number '...' (N digits) is out of range" when mr_number_too_large,
 * else "malformed number '...'". */
void mr_number_error(const char *p, const char *end, bool integer, char *buf, size_t cap);

#endif /* MR_TEXT_H */
