/*
 * cmdline.c - the command line as typed, shell-quoted (cmdline.h).
 */
#include "cmdline.h"

#include <stdlib.h>
#include <string.h>

/* A word the shell reads back as itself without quotes. */
static int shell_safe(const char *s)
{
    if (!*s) return 0;
    for (; *s; s++)
        if (!((*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') || (*s >= '0' && *s <= '9') ||
              strchr("%+,-./:=@_^", *s)))
            return 0;
    return 1;
}

/* Append word w at p, quoted when it must be; returns the new end. A quoted
 * word takes at most 4 bytes a byte plus its two quotes. The command word
 * (first) is quoted also when it holds '=': unquoted, the shell read
 * "b=c/pdla --target 200" as an assignment and ran "--target". */
static char *put_word(char *p, const char *w, int first)
{
    if (shell_safe(w) && !(first && strchr(w, '='))) {
        const size_t n = strlen(w);
        memcpy(p, w, n);
        return p + n;
    }
    *p++ = '\'';
    for (const char *c = w; *c; c++) {
        if (*c == '\'') {
            memcpy(p, "'\\''", 4);
            p += 4;
        } else {
            *p++ = *c;
        }
    }
    *p++ = '\'';
    return p;
}

char *cli_command_line(const char *prefix, int argc, char **argv)
{
    size_t len = 1 + (prefix ? 4 * strlen(prefix) + 3 : 0);
    for (int i = 0; i < argc; i++) len += 4 * strlen(argv[i]) + 3;
    char *const s = malloc(len);
    if (!s) return NULL;
    char *p = s;
    if (prefix) p = put_word(p, prefix, 1);
    for (int i = 0; i < argc; i++) {
        if (p != s) *p++ = ' ';
        p = put_word(p, argv[i], p == s);
    }
    *p = '\0';
    return s;
}
