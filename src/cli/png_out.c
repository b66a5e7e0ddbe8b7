/*
 * png_out.c - an 8-bit RGB picture as a PNG for the DLCA and event renders,
 * written as every pdla tool writes its output: into a temporary file
 * beside the target, synced and renamed onto it (tools_out_*, h5read.c),
 * so a failed or killed write leaves what was there; libpng's messages are
 * kept for pdla's one line instead of printed (its default handlers wrote
 * "libpng error: Write Error" on stderr as a second line).
 */
#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <string.h>

#include "h5read.h"
#include "png_out.h"
#include "pdla/pdla.h"

void tools_png_error(png_structp png, png_const_charp msg)
{
    char *const buf = png_get_error_ptr(png);
    const int e = errno;
    snprintf(buf, 160, "%s%s%s", msg, e ? ", " : "", e ? strerror(e) : "");
    png_longjmp(png, 1);
}

void tools_png_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* Rows of rgb (w x h x 3, top row first) into fp; 0, or -1 with msg. */
static int png_rows(FILE *fp, int w, int h, const unsigned char *rgb, char *msg)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, msg, tools_png_error, tools_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        snprintf(msg, 160, "out of memory for libpng");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, fp);
    png_set_compression_level(png, 9);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) png_write_row(png, (png_bytep)(rgb + (size_t)y * (size_t)w * 3));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int tools_png_write(const char *path, int w, int h, const unsigned char *rgb, int force, char *err,
                    size_t errlen)
{
    char tmp[4300], msg[160] = "";
    FILE *fp = tools_out_open(path, tmp, sizeof tmp, err, errlen);
    if (!fp) return -1;
    if (png_rows(fp, w, h, rgb, msg)) {
        tools_out_abort(fp, tmp);
        return pdla_errorf(-1, err, errlen, "cannot write %s: %s", path, msg);
    }
    return tools_out_commit(fp, tmp, path, force, err, errlen);
}
