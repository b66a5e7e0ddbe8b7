/*
 * scene.c - scene files (see scene.h): read the text and split it into
 * KEY = VALUE entries with their line numbers. It knows nothing of options:
 * parse.c applies the entries with the same code as the command line, so
 * this file sits below the option table.
 */
#include "scene.h"

#include "pdla/pdla.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

static char *trim(char *s)
{
    while (is_blank(*s)) s++;
    size_t n = strlen(s);
    while (n && is_blank(s[n - 1])) s[--n] = '\0';
    return s;
}

void scene_free(scene *sc)
{
    free(sc->entries);
    free(sc->buf);
    memset(sc, 0, sizeof *sc);
}

/* en->key from key: lower-case letters, digits, '-' and '_' (read as '-'),
 * as long as the option names; -1 with err naming line lineno. */
static int set_key(scene_entry *en, const char *key, const char *name, int lineno, char *err,
                   size_t errlen)
{
    const size_t kl = strlen(key);
    int ok = kl < sizeof en->key;
    for (size_t i = 0; ok && i < kl; i++)
        ok = (key[i] >= 'a' && key[i] <= 'z') || (key[i] >= '0' && key[i] <= '9') ||
             key[i] == '-' || key[i] == '_';
    if (!ok) {
        char shown[40];
        snprintf(shown, sizeof shown, "%.32s%s", key, kl > 32 ? "..." : "");
        for (char *c = shown; *c; c++)
            if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
        return pdla_errorf(-1, err, errlen, "%s:%d: bad key '%s' (keys are option names such as 'target')",
                           name, lineno, shown);
    }
    for (size_t i = 0; i <= kl; i++) en->key[i] = key[i] == '_' ? '-' : key[i];
    return 0;
}

int scene_read_text(const char *name, const char *text, size_t len, scene *sc, char *err,
                    size_t errlen)
{
    memset(sc, 0, sizeof *sc);
    if (len > SCENE_MAX_BYTES)
        return pdla_errorf(-1, err, errlen, "%s: too large (a scene is at most %d bytes)", name, SCENE_MAX_BYTES);
    if (memchr(text, '\0', len))
        return pdla_errorf(-1, err, errlen, "%s: contains a NUL byte (not a text file?)", name);
    char *buf = malloc(len + 1);
    scene_entry *entries = calloc(SCENE_MAX_BYTES / 4 + 1, sizeof *entries);
    sc->buf = buf;
    sc->entries = entries;
    int rc = 0, n = 0;
    if (!buf || !entries) {
        rc = pdla_errorf(-1, err, errlen, "%s: out of memory", name);
        goto out;
    }
    memcpy(buf, text, len);
    buf[len] = '\0';

    char *line = buf;
    for (int lineno = 1; line && *line; lineno++) {
        char *nl = strchr(line, '\n');
        if (nl) *nl = '\0';
        if (strlen(line) > SCENE_MAX_LINE) {
            rc = pdla_errorf(-1, err, errlen, "%s:%d: line too long (at most %d bytes)", name, lineno,
                      SCENE_MAX_LINE);
            goto out;
        }
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        char *s = trim(line);
        line = nl ? nl + 1 : NULL;
        if (!*s) continue;
        char *eq = strchr(s, '=');
        if (!eq) {
            rc = pdla_errorf(-1, err, errlen, "%s:%d: missing '=' (lines are KEY = VALUE)", name, lineno);
            goto out;
        }
        *eq = '\0';
        char *key = trim(s), *value = trim(eq + 1);
        if (!*key) {
            rc = pdla_errorf(-1, err, errlen, "%s:%d: missing key before '='", name, lineno);
            goto out;
        }
        scene_entry *en = &entries[n];
        if ((rc = set_key(en, key, name, lineno, err, errlen))) goto out;
        if (!*value) {
            rc = pdla_errorf(-1, err, errlen, "%s:%d: missing value for '%s'", name, lineno, en->key);
            goto out;
        }
        for (int i = 0; i < n; i++)
            if (!strcmp(entries[i].key, en->key)) {
                rc = pdla_errorf(-1, err, errlen, "%s:%d: duplicate key '%s' (first set on line %d)", name,
                          lineno, en->key, entries[i].line);
                goto out;
            }
        en->value = value;
        en->line = lineno;
        n++;
    }

out:
    sc->n = n;
    sc->len = len;
    if (rc) scene_free(sc);
    return rc;
}

int scene_read_file(const char *path, scene *sc, char *err, size_t errlen)
{
    memset(sc, 0, sizeof *sc);
    /* O_NONBLOCK and a regular-file check: a FIFO would wait for a writer. */
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return pdla_errorf(-1, err, errlen, "cannot open scene %s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return pdla_errorf(-1, err, errlen, "scene %s is not a regular file", path);
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        close(fd);
        return pdla_errorf(-1, err, errlen, "cannot open scene %s: %s", path, strerror(errno));
    }
    char *buf = malloc(SCENE_MAX_BYTES + 1);
    if (!buf) {
        fclose(f);
        return pdla_errorf(-1, err, errlen, "%s: out of memory", path);
    }
    const size_t len = fread(buf, 1, SCENE_MAX_BYTES + 1, f);
    const int rerr = ferror(f);
    fclose(f);
    int rc;
    if (rerr) rc = pdla_errorf(-1, err, errlen, "cannot read scene %s", path);
    else rc = scene_read_text(path, buf, len, sc, err, errlen);
    free(buf);
    return rc;
}
