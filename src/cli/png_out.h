/*
 * png_out.h - libpng's error and warning handlers for pdla's tools: the
 * error's message (with errno's text) goes to the buffer given as libpng's
 * error pointer (160 bytes) and longjmps; warnings are dropped. Nothing is
 * printed, so a tool's failure stays one line.
 */
#ifndef PDLA_CLI_PNG_OUT_H
#define PDLA_CLI_PNG_OUT_H
#include <png.h>

void tools_png_error(png_structp png, png_const_charp msg);
void tools_png_warning(png_structp png, png_const_charp msg);
#endif
