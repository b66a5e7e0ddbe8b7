/*
 * scene.c - scene files (see scene.h): read the text and split it into
 * KEY = VALUE entries with their line numbers. It knows nothing of options:
 * parse.c applies the entries with the same code as the command line, so
 * this file sits below the option table.
 */
#include "scene.h"

#include "pdla/pdla.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
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

/* en->key from key: letters, digits, '-' and '_' (read as '-'), as long
 * as the option names; the case is kept (the caller matches keys
 * case-sensitively). -1 with err naming line lineno. */
static int set_key(scene_entry *en, const char *key, const char *name, int lineno, char *err,
                   size_t errlen)
{
    const size_t kl = strlen(key);
    int ok = kl < sizeof en->key;
    for (size_t i = 0; ok && i < kl; i++)
        ok = (key[i] >= 'a' && key[i] <= 'z') || (key[i] >= 'A' && key[i] <= 'Z') ||
             (key[i] >= '0' && key[i] <= '9') || key[i] == '-' || key[i] == '_';
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

const scene_entry *scene_find(const scene *sc, const char *key)
{
    for (int i = 0; i < sc->n; i++)
        if (!strcmp(sc->entries[i].key, key)) return &sc->entries[i];
    return NULL;
}

/* One line (comment still in it) into sc->entries[sc->n], if it is not
 * blank: 0, or -1 with err. */
static int split_line(const char *name, int lineno, char *line, scene *sc, char *err, size_t errlen)
{
    char *hash = strchr(line, '#');
    if (hash) *hash = '\0';
    char *s = trim(line);
    if (!*s) return 0;
    char *eq = strchr(s, '=');
    if (!eq) return pdla_errorf(-1, err, errlen, "%s:%d: missing '=' (lines are KEY = VALUE)", name, lineno);
    *eq = '\0';
    char *key = trim(s), *value = trim(eq + 1);
    if (!*key) return pdla_errorf(-1, err, errlen, "%s:%d: missing key before '='", name, lineno);
    scene_entry *en = &sc->entries[sc->n];
    if (set_key(en, key, name, lineno, err, errlen)) return -1;
    if (!*value) return pdla_errorf(-1, err, errlen, "%s:%d: missing value for '%s'", name, lineno, en->key);
    const scene_entry *first = scene_find(sc, en->key);
    if (first)
        return pdla_errorf(-1, err, errlen, "%s:%d: duplicate key '%s' (first set on line %d)", name, lineno,
                           en->key, first->line);
    en->value = value;
    en->line = lineno;
    sc->n++;
    return 0;
}

/* Split buf[0, len) (buf[len] is '\0'; written in place) into sc->entries,
 * sc->n counting the entries of the lines before the first bad one: 0, or
 * -1 with err. A NUL byte is refused in the line that holds it. */
static int split_lines(const char *name, char *buf, size_t len, scene *sc, char *err, size_t errlen)
{
    char *const end = buf + len;
    char *line = buf;
    for (int lineno = 1; line < end; lineno++) {
        char *nl = memchr(line, '\n', (size_t)(end - line));
        char *const stop = nl ? nl : end;
        if (memchr(line, '\0', (size_t)(stop - line)))
            return pdla_errorf(-1, err, errlen, "%s:%d: contains a NUL byte (not a text file?)", name, lineno);
        if (stop - line > SCENE_MAX_LINE)
            return pdla_errorf(-1, err, errlen, "%s:%d: line too long (at most %d bytes)", name, lineno,
                               SCENE_MAX_LINE);
        *stop = '\0';
        if (split_line(name, lineno, line, sc, err, errlen)) return -1;
        line = stop + 1;
    }
    return 0;
}

/* sc with room for a scene's entries (at most one a 4 bytes: "k=v\n") and
 * a copy of text[0, len): 0, or -1 (out of memory; sc freed). */
static int scene_alloc(scene *sc, const char *text, size_t len)
{
    memset(sc, 0, sizeof *sc);
    sc->buf = malloc(len + 1);
    sc->entries = calloc(SCENE_MAX_BYTES / 4 + 1, sizeof *sc->entries);
    if (!sc->buf || !sc->entries) {
        scene_free(sc);
        return -1;
    }
    memcpy(sc->buf, text, len);
    sc->buf[len] = '\0';
    sc->len = len;
    return 0;
}

int scene_read_text(const char *name, const char *text, size_t len, scene *sc, char *err,
                    size_t errlen)
{
    memset(sc, 0, sizeof *sc);
    if (len > SCENE_MAX_BYTES)
        return pdla_errorf(-1, err, errlen, "%s: too large (a scene is at most %d bytes)", name, SCENE_MAX_BYTES);
    if (scene_alloc(sc, text, len)) return pdla_errorf(-1, err, errlen, "%s: out of memory", name);
    const int rc = split_lines(name, sc->buf, len, sc, err, errlen);
    if (rc) scene_free(sc);
    return rc;
}

/* The file's first SCENE_MAX_BYTES + 1 bytes into a new *buf (its length in
 * *len): 0, or -1 with err. Regular files only. */
static int load_file(const char *path, char **buf, size_t *len, char *err, size_t errlen)
{
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
    *buf = malloc(SCENE_MAX_BYTES + 1);
    if (!*buf) {
        fclose(f);
        return pdla_errorf(-1, err, errlen, "%s: out of memory", path);
    }
    *len = fread(*buf, 1, SCENE_MAX_BYTES + 1, f);
    const int rerr = ferror(f);
    fclose(f);
    if (!rerr) return 0;
    free(*buf);
    *buf = NULL;
    return pdla_errorf(-1, err, errlen, "cannot read scene %s", path);
}

int scene_read_file(const char *path, scene *sc, char *err, size_t errlen)
{
    memset(sc, 0, sizeof *sc);
    char *buf;
    size_t len;
    if (load_file(path, &buf, &len, err, errlen)) return -1;
    const int rc = scene_read_text(path, buf, len, sc, err, errlen);
    free(buf);
    return rc;
}

void scene_model(const char *path, char *model, size_t len)
{
    if (len) model[0] = '\0';
    char *text, err[256];
    size_t n;
    if (load_file(path, &text, &n, err, sizeof err)) return;
    scene sc;
    if (scene_alloc(&sc, text, n > SCENE_MAX_BYTES ? SCENE_MAX_BYTES : n) == 0) {
        (void)split_lines(path, sc.buf, sc.len, &sc, err, sizeof err); /* the lines before an error count */
        const scene_entry *m = scene_find(&sc, "model");
        if (m) snprintf(model, len, "%s", m->value);
        scene_free(&sc);
    }
    free(text);
}

int scene_same_but_case(const char *a, const char *b)
{
    for (; *a && *b; a++, b++) {
        const int x = *a == '_' ? '-' : tolower((unsigned char)*a), y = *b == '_' ? '-' : tolower((unsigned char)*b);
        if (x != y) return 0;
    }
    return *a == *b;
}

int scene_unknown_key(const char *key, const char *near, const char *tail, char *err, size_t errlen)
{
    if (near) return pdla_errorf(-1, err, errlen, "unknown key '%s' (keys are case-sensitive: '%s')", key, near);
    return pdla_errorf(-1, err, errlen, "unknown key '%s'%s", key, tail);
}
