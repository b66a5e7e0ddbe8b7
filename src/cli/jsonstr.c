/*
 * jsonstr.c - tool_json_str (tools.h): a string in JSON for every tool's
 * --json and --stats-json, invalid UTF-8 as U+FFFD; tool_json_num: a number,
 * null when not finite. In a file of its own so
 * that info.c, dlca_info.c, event_info.c, analyze.c and main.c share it
 * without importing one another.
 */
#include <math.h>
#include <stdio.h>

#include "tools.h"

/* Length of the valid UTF-8 sequence at c (1-4), or 0 if it is not one
 * (overlong forms, surrogates and code points above U+10FFFF included). */
static int utf8_len(const unsigned char *c)
{
    int n;
    unsigned cp;
    if (c[0] < 0x80) return 1;
    if (c[0] >= 0xc2 && c[0] <= 0xdf) n = 2, cp = c[0] & 0x1fu;
    else if (c[0] >= 0xe0 && c[0] <= 0xef) n = 3, cp = c[0] & 0x0fu;
    else if (c[0] >= 0xf0 && c[0] <= 0xf4) n = 4, cp = c[0] & 0x07u;
    else return 0;
    for (int i = 1; i < n; i++) {
        if ((c[i] & 0xc0) != 0x80) return 0; /* also stops at the NUL */
        cp = cp << 6 | (c[i] & 0x3fu);
    }
    if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10ffff)) ||
        (cp >= 0xd800 && cp <= 0xdfff))
        return 0;
    return n;
}

/* A JSON string: what is not valid UTF-8 becomes U+FFFD, so the output
 * always parses. */
void tool_json_str(FILE *o, const char *s)
{
    fputc('"', o);
    for (const unsigned char *c = (const unsigned char *)s; *c; c++) {
        const int u = utf8_len(c);
        if (u == 0) {
            fputs("\\ufffd", o);
            continue;
        }
        if (u > 1) {
            fwrite(c, 1, (size_t)u, o);
            c += u - 1;
            continue;
        }
        if (*c == '"' || *c == '\\') fprintf(o, "\\%c", *c);
        else if (*c == '\n') fputs("\\n", o);
        else if (*c == '\t') fputs("\\t", o);
        else if (*c < 0x20) fprintf(o, "\\u%04x", *c);
        else fputc(*c, o);
    }
    fputc('"', o);
}


void tool_json_num(FILE *o, double v, int digits)
{
    if (isfinite(v)) fprintf(o, "%.*g", digits, v);
    else fputs("null", o);
}
