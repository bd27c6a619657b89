/* PNG output through libpng, written atomically (temporary file + rename).
 * Built without libpng (MR_HAVE_PNG undefined), mr_png_write fails with
 * MR_ERR_UNSUPPORTED. */
#include "../io/output.h"

#ifdef MR_HAVE_PNG
#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <string.h>

typedef struct png_failure {
    char message[200];
    FILE *f;
    int write_errno; /* of the failed write, or 0 */
} png_failure;

/* libpng's own writer reports a short write as "Write Error" and loses
 * errno: write through stdio here and keep the reason. */
static void on_png_write(png_structp png, png_bytep data, size_t length)
{
    png_failure *f = png_get_io_ptr(png);
    if (fwrite(data, 1, length, f->f) != length) {
        f->write_errno = errno ? errno : EIO;
        png_error(png, strerror(f->write_errno));
    }
}

static void on_png_flush(png_structp png)
{
    (void)png; /* mr_output_close flushes and reports */
}

static void on_png_error(png_structp png, png_const_charp msg)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->message, sizeof f->message, "%s", msg);
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* the library never prints */
}

/* Encode into an open file; returns 0 or -1 with the reason in *fail. */
static int encode(FILE *f, const uint8_t *rgba, int width, int height, png_failure *fail)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, fail, on_png_error,
                                              on_png_warning);
    if (!png) {
        snprintf(fail->message, sizeof fail->message, "out of memory");
        return -1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(fail->message, sizeof fail->message, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    fail->f = f;
    png_set_write_fn(png, fail, on_png_write, on_png_flush);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_set_filler(png, 0, PNG_FILLER_AFTER); /* the input's 4th byte is dropped */
    for (int y = 0; y < height; y++)
        png_write_row(png, (png_const_bytep)(rgba + (size_t)y * 4 * (size_t)width));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

mr_status mr_png_write(const char *path, const uint8_t *rgba, int width, int height,
                       mr_error *err)
{
    mr_error_clear(err);
    if (!path || !rgba)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, NULL, "no path or image given");
    if (width < 1 || height < 1 || width > (1 << 20) || height > (1 << 20))
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, path,
                             "image size %dx%d is invalid", width, height);
    mr_output_file out;
    mr_status st = mr_output_open(&out, path, err);
    if (st != MR_OK)
        return st;
    png_failure fail = {"", NULL, 0};
    if (encode(out.f, rgba, width, height, &fail) != 0)
        st = fail.write_errno
                 ? mr_fail_plain(err, MR_ERR_IO, path, "write failed: %s", fail.message)
                 : mr_fail_plain(err, MR_ERR_IO, path, "PNG encoding failed: %s", fail.message);
    return mr_output_close(&out, path, st, err);
}

#else /* !MR_HAVE_PNG */

mr_status mr_png_write(const char *path, const uint8_t *rgba, int width, int height,
                       mr_error *err)
{
    (void)rgba;
    (void)width;
    (void)height;
    mr_error_clear(err);
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, path,
                         "PNG output: support was not built (libpng was missing when "
                         "meshreduce was built)");
}

#endif
