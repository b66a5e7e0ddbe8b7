/*
 * scene.c - scene files (see scene.h): read the file, split it into
 * KEY = VALUE lines and hand each to parse.c's cli_set_option, the same code
 * that handles command-line options. Errors carry FILE:LINE.
 */
#include "scene.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct scene_entry {
    char key[64];    /* normalised: '_' -> '-' */
    const char *value;
    int line;
} scene_entry;

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return CLI_PARSE_ERROR;
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

static char *trim(char *s)
{
    while (is_blank(*s)) s++;
    size_t n = strlen(s);
    while (n && is_blank(s[n - 1])) s[--n] = '\0';
    return s;
}

/* Apply entries[0..n) except `skip` (-1: none) to a copy of base. */
static int apply_all(const cli_options *base, const scene_entry *entries, int n, int skip,
                     cli_options *out, int *bad_line, char *err, size_t errlen)
{
    *out = *base;
    for (int i = 0; i < n; i++) {
        if (i == skip) continue;
        const int rc = cli_set_option(out, entries[i].key, entries[i].value, err, errlen);
        if (rc != CLI_PARSE_OK) {
            *bad_line = entries[i].line;
            return rc;
        }
    }
    return CLI_PARSE_OK;
}

/* The scene's strings live in the file buffer, which is freed: keep the
 * paths in the options themselves. */
static void keep_strings(cli_options *o, const char *buf, size_t len)
{
    if (o->out_dir && o->out_dir >= buf && o->out_dir < buf + len) {
        snprintf(o->scene_out, sizeof o->scene_out, "%s", o->out_dir);
        o->out_dir = o->scene_out;
    }
    if (o->stats_json && o->stats_json >= buf && o->stats_json < buf + len) {
        snprintf(o->scene_stats, sizeof o->scene_stats, "%s", o->stats_json);
        o->stats_json = o->scene_stats;
    }
    if (o->resume && o->resume >= buf && o->resume < buf + len) {
        snprintf(o->scene_resume, sizeof o->scene_resume, "%s", o->resume);
        o->resume = o->scene_resume;
    }
}

int scene_apply_text(const char *name, const char *text, size_t len, cli_options *o, char *err,
                     size_t errlen)
{
    if (len > SCENE_MAX_BYTES)
        return fail(err, errlen, "%s: too large (a scene is at most %d bytes)", name, SCENE_MAX_BYTES);
    if (memchr(text, '\0', len))
        return fail(err, errlen, "%s: contains a NUL byte (not a text file?)", name);
    char *buf = malloc(len + 1);
    scene_entry *entries = calloc(SCENE_MAX_BYTES / 4 + 1, sizeof *entries);
    cli_options *tmp = malloc(sizeof *tmp);
    int rc = CLI_PARSE_OK, n = 0;
    if (!buf || !entries || !tmp) {
        rc = fail(err, errlen, "%s: out of memory", name);
        goto out;
    }
    memcpy(buf, text, len);
    buf[len] = '\0';

    char *line = buf;
    for (int lineno = 1; line && *line; lineno++) {
        char *nl = strchr(line, '\n');
        if (nl) *nl = '\0';
        if (strlen(line) > SCENE_MAX_LINE) {
            rc = fail(err, errlen, "%s:%d: line too long (at most %d bytes)", name, lineno,
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
            rc = fail(err, errlen, "%s:%d: missing '=' (lines are KEY = VALUE)", name, lineno);
            goto out;
        }
        *eq = '\0';
        char *key = trim(s), *value = trim(eq + 1);
        if (!*key) {
            rc = fail(err, errlen, "%s:%d: missing key before '='", name, lineno);
            goto out;
        }
        size_t kl = strlen(key);
        int ok = kl < sizeof entries[n].key;
        for (size_t i = 0; ok && i < kl; i++)
            ok = (key[i] >= 'a' && key[i] <= 'z') || (key[i] >= '0' && key[i] <= '9') ||
                 key[i] == '-' || key[i] == '_';
        if (!ok) {
            char shown[40];
            snprintf(shown, sizeof shown, "%.32s%s", key, kl > 32 ? "..." : "");
            for (char *c = shown; *c; c++)
                if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
            rc = fail(err, errlen, "%s:%d: bad key '%s' (keys are option names such as 'target')",
                      name, lineno, shown);
            goto out;
        }
        scene_entry *en = &entries[n];
        for (size_t i = 0; i <= kl; i++) en->key[i] = key[i] == '_' ? '-' : key[i];
        if (!*value) {
            rc = fail(err, errlen, "%s:%d: missing value for '%s'", name, lineno, en->key);
            goto out;
        }
        for (int i = 0; i < n; i++)
            if (!strcmp(entries[i].key, en->key)) {
                rc = fail(err, errlen, "%s:%d: duplicate key '%s' (first set on line %d)", name,
                          lineno, en->key, entries[i].line);
                goto out;
            }
        en->value = value;
        en->line = lineno;
        n++;
    }

    /* Each key, with its value checked by the command line's parsers. */
    char why[512];
    int bad_line = 0;
    rc = apply_all(o, entries, n, -1, tmp, &bad_line, why, sizeof why);
    if (rc != CLI_PARSE_OK) {
        fail(err, errlen, "%s:%d: %s", name, bad_line, why);
        goto out;
    }
    /* The scene on its own must be a valid run. Blame the line whose
     * removal makes it valid, if there is one. */
    if (pdla_params_validate(&tmp->params, why, sizeof why) != PDLA_OK) {
        int blamed = 0, named = 0;
        for (int i = n - 1; i >= 0 && !named; i--) {
            cli_options *t2 = malloc(sizeof *t2);
            char ignore[512];
            if (t2 && apply_all(o, entries, n, i, t2, &bad_line, ignore, sizeof ignore) == CLI_PARSE_OK &&
                pdla_params_validate(&t2->params, ignore, sizeof ignore) == PDLA_OK) {
                /* prefer the line whose key the message names ("kill ratio") */
                char words[64];
                snprintf(words, sizeof words, "%s", entries[i].key);
                for (char *c = words; *c; c++)
                    if (*c == '-') *c = ' ';
                named = strstr(why, words) != NULL;
                if (!blamed || named) blamed = entries[i].line;
            }
            free(t2);
        }
        rc = blamed ? fail(err, errlen, "%s:%d: %s", name, blamed, why)
                    : fail(err, errlen, "%s: %s", name, why);
        goto out;
    }
    keep_strings(tmp, buf, len);
    *o = *tmp;
    /* *o was copied from tmp: repoint what pointed into tmp's own arrays. */
    if (tmp->out_dir == tmp->scene_out) o->out_dir = o->scene_out;
    if (tmp->stats_json == tmp->scene_stats) o->stats_json = o->scene_stats;
    if (tmp->resume == tmp->scene_resume) o->resume = o->scene_resume;
out:
    free(tmp);
    free(entries);
    free(buf);
    return rc;
}

int scene_apply(const char *path, cli_options *o, char *err, size_t errlen)
{
    /* O_NONBLOCK and a regular-file check: a FIFO would wait for a writer. */
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return fail(err, errlen, "cannot open scene %s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return fail(err, errlen, "scene %s is not a regular file", path);
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        close(fd);
        return fail(err, errlen, "cannot open scene %s: %s", path, strerror(errno));
    }
    char *buf = malloc(SCENE_MAX_BYTES + 1);
    if (!buf) {
        fclose(f);
        return fail(err, errlen, "%s: out of memory", path);
    }
    const size_t len = fread(buf, 1, SCENE_MAX_BYTES + 1, f);
    const int rerr = ferror(f);
    fclose(f);
    int rc;
    if (rerr) rc = fail(err, errlen, "cannot read scene %s", path);
    else rc = scene_apply_text(path, buf, len, o, err, errlen);
    free(buf);
    return rc;
}
