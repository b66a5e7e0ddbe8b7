/*
 * rundir.c - making run directories (rundir.h).
 */
#include "rundir.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int cli_mkdir_p(const char *path)
{
    char *buf = strdup(path);
    if (!buf) return ENOMEM;
    int rc = 0;
    for (char *p = buf + 1;; p++) {
        if (*p != '/' && *p != '\0') continue;
        const char save = *p;
        *p = '\0';
        /* An existing directory may answer EEXIST, EACCES or EROFS: what
         * counts is whether a directory is there afterwards. */
        const int made = mkdir(buf, 0777) == 0;
        const int e = errno;
        struct stat st;
        if (!made && stat(buf, &st)) {
            rc = e;
            break;
        }
        if (!made && !S_ISDIR(st.st_mode)) {
            rc = ENOTDIR;
            break;
        }
        *p = save;
        if (!save) break;
    }
    free(buf);
    return rc;
}

int cli_mkdir_parents(const char *dir)
{
    char *parent = strdup(dir);
    if (!parent) return ENOMEM;
    char *slash = strrchr(parent, '/');
    int rc = 0;
    if (slash && slash != parent) {
        *slash = '\0';
        rc = cli_mkdir_p(parent);
    }
    free(parent);
    return rc;
}
