/* PNG and JPEG images decoded into RGBA for the renderer's textures: PNG
 * through libpng's simplified reader, JPEG through libjpeg(-turbo). Each
 * library is optional at build time (MR_HAVE_PNG, MR_HAVE_JPEG); without
 * it its format fails with MR_ERR_UNSUPPORTED. */
#include "../core/internal.h"

#include "../io/mapped.h"

#include <setjmp.h>
#include <stdio.h>

#ifdef MR_HAVE_PNG
#include <png.h>
#endif
#ifdef MR_HAVE_JPEG
#include <jpeglib.h>
#include <jerror.h>
#endif

/* Largest side and pixel count taken: a texture of 16384 x 16384 is the
 * most a GPU takes too. */
#define MAX_SIDE 32768
#define MAX_PIXELS ((size_t)1 << 28)

void mr_image_free(mr_image *image)
{
    if (!image)
        return;
    free(image->rgba);
    memset(image, 0, sizeof *image);
}

static mr_status check_size(const char *name, long long w, long long h, mr_error *err)
{
    if (w < 1 || h < 1 || w > MAX_SIDE || h > MAX_SIDE ||
        (size_t)w * (size_t)h > MAX_PIXELS)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, name,
                             "image of %lld x %lld pixels: outside 1 to %d a side and %zu "
                             "pixels in all",
                             w, h, MAX_SIDE, MAX_PIXELS);
    return MR_OK;
}

static mr_status decode_png(const void *data, size_t size, const char *name, mr_image *image,
                            mr_error *err)
{
#ifdef MR_HAVE_PNG
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&pi, data, size))
        return mr_fail_plain(err, MR_ERR_PARSE, name, "not a readable PNG: %s", pi.message);
    mr_status st = check_size(name, pi.width, pi.height, err);
    if (st != MR_OK) {
        png_image_free(&pi);
        return st;
    }
    pi.format = PNG_FORMAT_RGBA;
    uint8_t *px = malloc(PNG_IMAGE_SIZE(pi));
    if (!px) {
        png_image_free(&pi);
        return mr_fail_nomem(err, name, PNG_IMAGE_SIZE(pi));
    }
    if (!png_image_finish_read(&pi, NULL, px, 0, NULL)) {
        free(px);
        st = mr_fail_plain(err, MR_ERR_PARSE, name, "PNG data is damaged: %s", pi.message);
        png_image_free(&pi);
        return st;
    }
    image->width = (int)pi.width;
    image->height = (int)pi.height;
    image->rgba = px;
    png_image_free(&pi);
    return MR_OK;
#else
    (void)data, (void)size, (void)image;
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                         "is a PNG image, and PNG support was not built (Debian: libpng-dev)");
#endif
}

#ifdef MR_HAVE_JPEG
typedef struct jpeg_failure {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
} jpeg_failure;

static void on_jpeg_error(j_common_ptr cinfo)
{
    jpeg_failure *f = (jpeg_failure *)cinfo->err;
    f->mgr.format_message(cinfo, f->message);
    longjmp(f->jump, 1);
}

static void on_jpeg_message(j_common_ptr cinfo, int level)
{
    /* Warnings about damaged bytes are not errors (viewers show such
     * images), but data that ends early is: libjpeg would make up the
     * rest of a picture that may say it is 32768 pixels a side. */
    jpeg_failure *f = (jpeg_failure *)cinfo->err;
    if (level < 0 && f->mgr.msg_code == JWRN_JPEG_EOF) {
        f->mgr.format_message(cinfo, f->message);
        longjmp(f->jump, 1);
    }
}
#endif

static mr_status decode_jpeg(const void *data, size_t size, const char *name, mr_image *image,
                             mr_error *err)
{
#ifdef MR_HAVE_JPEG
    struct jpeg_decompress_struct cinfo;
    jpeg_failure fail;
    /* Written between setjmp and longjmp: volatile. */
    uint8_t *volatile px = NULL;
    uint8_t *volatile row = NULL;
    cinfo.err = jpeg_std_error(&fail.mgr);
    fail.mgr.error_exit = on_jpeg_error;
    fail.mgr.emit_message = on_jpeg_message;
    fail.message[0] = '\0';
    if (setjmp(fail.jump)) {
        jpeg_destroy_decompress(&cinfo);
        free(px);
        free(row);
        return mr_fail_plain(err, MR_ERR_PARSE, name, "not a readable JPEG: %s", fail.message);
    }
    jpeg_create_decompress(&cinfo);
    jpeg_mem_src(&cinfo, (const unsigned char *)data, (unsigned long)size);
    jpeg_read_header(&cinfo, TRUE);
    cinfo.out_color_space = JCS_RGB;
    mr_status st = check_size(name, cinfo.image_width, cinfo.image_height, err);
    if (st != MR_OK) {
        jpeg_destroy_decompress(&cinfo);
        return st;
    }
    jpeg_start_decompress(&cinfo);
    const size_t w = cinfo.output_width, h = cinfo.output_height;
    px = malloc(4 * w * h);
    row = malloc(3 * w);
    if (!px || !row) {
        jpeg_destroy_decompress(&cinfo);
        free(px);
        free(row);
        return mr_fail_nomem(err, name, 4 * w * h);
    }
    while (cinfo.output_scanline < h) {
        const size_t y = cinfo.output_scanline;
        JSAMPROW rows[1] = {row};
        jpeg_read_scanlines(&cinfo, rows, 1);
        uint8_t *out = px + 4 * w * y;
        for (size_t x = 0; x < w; x++) {
            out[4 * x] = row[3 * x];
            out[4 * x + 1] = row[3 * x + 1];
            out[4 * x + 2] = row[3 * x + 2];
            out[4 * x + 3] = 255;
        }
    }
    jpeg_finish_decompress(&cinfo);
    jpeg_destroy_decompress(&cinfo);
    free(row);
    image->width = (int)w;
    image->height = (int)h;
    image->rgba = px;
    return MR_OK;
#else
    (void)data, (void)size, (void)image;
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                         "is a JPEG image, and JPEG support was not built (Debian: "
                         "libjpeg62-turbo-dev)");
#endif
}

mr_status mr_image_decode(const void *data, size_t size, const char *name, mr_image *image,
                          mr_error *err)
{
    mr_error_clear(err);
    if (!image)
        return mr_fail_plain(err, MR_ERR_INVALID_ARGUMENT, "image", "no image given");
    memset(image, 0, sizeof *image);
    name = name ? name : "image";
    const uint8_t *b = data;
    static const uint8_t png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (b && size >= 8 && !memcmp(b, png_magic, 8))
        return decode_png(data, size, name, image, err);
    if (b && size >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff)
        return decode_jpeg(data, size, name, image, err);
    return mr_fail_plain(err, MR_ERR_UNSUPPORTED, name,
                         "is neither a PNG nor a JPEG image (the textures drawn are those two)");
}

mr_status mr_image_read(const char *path, mr_image *image, mr_error *err)
{
    mr_mapped_file f;
    mr_status st = mr_map_file(path, &f, err);
    if (st != MR_OK) {
        if (image)
            memset(image, 0, sizeof *image);
        return st;
    }
    st = mr_image_decode(f.data, f.size, path, image, err);
    mr_unmap_file(&f);
    return st;
}
