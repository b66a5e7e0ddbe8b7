/*
 * optcheck.c - see optcheck.h.
 */
#include "optcheck.h"

#include <stdio.h>
#include <string.h>

/* An argument quoted in a one-line message: control bytes shown as '?',
 * cut at 48 bytes. */
static const char *shown(char *buf, size_t len, const char *s)
{
    size_t i = 0;
    for (; s[i] && i + 1 < len && i < 48; i++)
        buf[i] = (unsigned char)s[i] < 0x20 || s[i] == 0x7f ? '?' : s[i];
    buf[i] = '\0';
    return buf;
}

int optcheck_exact(int argc, char *const *argv, const struct option *longopts,
                   const char *shortopts, char *err, size_t errlen)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--")) return 0;
        if (a[0] != '-' || a[1] == '\0') continue; /* a non-option (getopt permutes) */
        if (a[1] != '-') {
            /* Short options, maybe clustered; one taking a value ends the
             * cluster and takes the rest or the next argument. */
            for (const char *c = a + 1; *c; c++) {
                const char *s = *c != ':' ? strchr(shortopts, *c) : NULL;
                if (s && s[1] == ':') {
                    if (!c[1]) i++;
                    break;
                }
            }
            continue;
        }
        const char *name = a + 2, *eq = strchr(name, '=');
        const size_t n = eq ? (size_t)(eq - name) : strlen(name);
        const struct option *o = longopts;
        while (o->name && !(strlen(o->name) == n && !strncmp(o->name, name, n))) o++;
        if (!o->name) {
            char b[64];
            if (err && errlen)
                snprintf(err, errlen, "unknown option '%s' (see --help; long options are not abbreviated)",
                         shown(b, sizeof b, a));
            return -1;
        }
        if (o->has_arg == required_argument && !eq) i++;
    }
    return 0;
}
