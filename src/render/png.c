/* PNG output through libpng, written atomically (temporary file + rename). */
#define _GNU_SOURCE /* mkstemp, fdopen under strict C11 */
#include "../core/internal.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

/* The directory part of a path ("." when it has none). */
static void dir_of(const char *path, char *buf, size_t cap)
{
    const char *slash = strrchr(path, '/');
    size_t n = slash ? (size_t)(slash - path) : 0;
    if (!slash) {
        snprintf(buf, cap, ".");
        return;
    }
    if (n == 0)
        n = 1; /* "/file" */
    if (n >= cap)
        n = cap - 1;
    memcpy(buf, path, n);
    buf[n] = '\0';
}

typedef struct png_failure {
    char message[200];
} png_failure;

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
    png_init_io(png, f);
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
    char dir[4096], tmp[4200];
    dir_of(path, dir, sizeof dir);
    snprintf(tmp, sizeof tmp, "%s/.meshreduce-XXXXXX", dir);
    int fd = mkstemp(tmp);
    if (fd < 0)
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot write (in %s): %s", dir,
                             strerror(errno));
    FILE *f = fdopen(fd, "wb");
    if (!f) {
        int e = errno;
        close(fd);
        unlink(tmp);
        return mr_fail_plain(err, MR_ERR_IO, path, "cannot write: %s", strerror(e));
    }
    png_failure fail = {""};
    mr_status st = MR_OK;
    if (encode(f, rgba, width, height, &fail) != 0)
        st = mr_fail_plain(err, MR_ERR_IO, path, "PNG encoding failed: %s", fail.message);
    if (st == MR_OK && (fflush(f) != 0 || ferror(f)))
        st = mr_fail_plain(err, MR_ERR_IO, path, "write failed: %s", strerror(errno));
    if (fclose(f) != 0 && st == MR_OK)
        st = mr_fail_plain(err, MR_ERR_IO, path, "write failed: %s", strerror(errno));
    if (st == MR_OK) {
        /* mkstemp creates 0600; give the file the usual permissions. */
        mode_t mask = umask(0);
        umask(mask);
        chmod(tmp, 0666 & ~mask);
        if (rename(tmp, path) != 0)
            st = mr_fail_plain(err, MR_ERR_IO, path, "cannot write: %s", strerror(errno));
    }
    if (st != MR_OK)
        unlink(tmp);
    return st;
}
