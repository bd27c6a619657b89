/* libFuzzer target for the texture decoders (mr_image_decode: PNG and
 * JPEG): any input is rejected cleanly or gives an image of the size it
 * says, never a crash or a read out of bounds. */
#include "meshreduce.h"

#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    mr_image image;
    mr_error err;
    if (mr_image_decode(data, size, "fuzz", &image, &err) == MR_OK) {
        if (image.width < 1 || image.height < 1 || !image.rgba)
            abort();
        /* touch the last pixel: the buffer holds them all */
        volatile uint8_t last =
            image.rgba[4 * (size_t)image.width * (size_t)image.height - 1];
        (void)last;
        mr_image_free(&image);
    } else if (err.message[0] == '\0' || image.rgba) {
        abort(); /* every failure says what is wrong, and leaves no pixels */
    }
    return 0;
}
