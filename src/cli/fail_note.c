/* fail_note.c - see fail_note.h. */
#include "fail_note.h"

#include <stdio.h>
#include <string.h>

void cli_fail_note(cli_fail *f, const char *what, const char *fmt, const char *msg)
{
    if (!f->why[0]) {
        snprintf(f->why, sizeof f->why, fmt, msg);
        return;
    }
    const size_t n = strlen(f->also);
    if (what && n + strlen(what) + 3 < sizeof f->also)
        snprintf(f->also + n, sizeof f->also - n, "%s%s", n ? ", " : "", what);
}
