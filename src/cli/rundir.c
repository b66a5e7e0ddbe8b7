/*
 * rundir.c - making run directories (rundir.h).
 */
#include "rundir.h"
#include <stdio.h>

#include <dirent.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pdla/h5check.h"
#include "pdla/pdla.h"

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

int cli_foreign_checkpoint(const char *path, const char *own_model, char *what, size_t whatlen)
{
    char model[32];
    if (pdla_h5_file_model(path, model, sizeof model) == 0) {
        if (!strcmp(model, own_model)) return 0;
        snprintf(what, whatlen, "another model's file (model '%s')", model);
        return 1;
    }
    struct stat sb;
    if (stat(path, &sb) != 0) return 0;
    /* a directory or device under the name was put there: not damaged */
    if (S_ISDIR(sb.st_mode) || !S_ISREG(sb.st_mode)) {
        snprintf(what, whatlen, "%s", S_ISDIR(sb.st_mode) ? "a directory" : "not a regular file");
        return 2;
    }
    /* the root only: a whole load of a 1e9-particle DLA checkpoint took
     * gigabytes to refuse it */
    uint64_t gen, particles;
    if (pdla_checkpoint_peek(path, &gen, &particles) != PDLA_OK) return 0;
    snprintf(what, whatlen, "a DLA checkpoint (generation %llu, %llu particles)", (unsigned long long)gen,
             (unsigned long long)particles);
    return 1;
}

/* The names pdla writes under (xdmf.c, output_h5.c and the checkpoint
 * writers add ".PID"; the event model's cluster.h5.tmp and the DLCA
 * model's .new names are bare): each name is one of these, or one followed
 * by '.' and more (.cluster.h5.new.tmp.PID, summary.txt.tmp.PID: the DLA
 * command's). Matched as prefixes, "cluster.h5.tmp" also took a
 * user's cluster.h5.tmpcopy, which the DLCA sweep (since this list) and the
 * event sweep removed, and a --resume of it was refused. */
static const char *const temp_stems[] = {".checkpoint.h5.tmp", "cluster.h5.tmp",  "cluster.xdmf2.tmp",
                                         "cluster-free.xdmf2.tmp", ".cluster.h5.new", ".checkpoint.h5.new",
                                         "summary.txt.tmp"};

int cli_is_temp_name(const char *path)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    for (size_t i = 0; i < sizeof temp_stems / sizeof temp_stems[0]; i++) {
        const size_t n = strlen(temp_stems[i]);
        if (!strncmp(b, temp_stems[i], n) && (b[n] == '\0' || b[n] == '.')) return 1;
    }
    return 0;
}

void cli_remove_temp(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    char p[4400];
    const struct dirent *de;
    while ((de = readdir(d)))
        if (cli_is_temp_name(de->d_name)) {
            snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
            unlink(p);
        }
    closedir(d); /* opened to read names only */
}

int cli_refuse_temp_resume(const char *path)
{
    if (!cli_is_temp_name(path)) return 0;
    fprintf(stderr, "pdla: cannot resume from '%s': an unfinished temporary file (a killed run's); not loaded "
                    "(rename it to resume from it)\n", path);
    return 1;
}

/* Is p a name of the directory dst (its stat) that cli_remove_temp
 * unlinks: a temporary name there, not a directory (unlink leaves those)? */
static int swept_name(const char *p, const struct stat *dst)
{
    const char *slash = strrchr(p, '/');
    if (!cli_is_temp_name(p)) return 0;
    char parent[4400];
    if (!slash) snprintf(parent, sizeof parent, ".");
    else snprintf(parent, sizeof parent, "%.*s", slash == p ? 1 : (int)(slash - p), p);
    struct stat ps, st;
    if (stat(parent, &ps) != 0 || ps.st_dev != dst->st_dev || ps.st_ino != dst->st_ino) return 0;
    return lstat(p, &st) == 0 && !S_ISDIR(st.st_mode);
}

/* Does the symbolic link path lead, hop by hop (at most 40, the kernel's
 * limit), through a name that the sweep of dir (dst) unlinks? That name
 * into hop. Followed by name, not by inode: a hard link under a temporary
 * name loses nothing when the sweep unlinks it, a link to the name
 * dangles. */
static int link_through_temp(const char *path, const struct stat *dst, char *hop, size_t hoplen)
{
    char cur[4400], tgt[4400];
    snprintf(cur, sizeof cur, "%s", path);
    for (int k = 0; k < 40; k++) {
        struct stat st;
        if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode)) return 0;
        const ssize_t n = readlink(cur, tgt, sizeof tgt - 1);
        if (n < 0 || n >= (ssize_t)sizeof tgt - 1) return 0;
        tgt[n] = '\0';
        /* a relative target is read from the link's own folder */
        const char *slash = strrchr(cur, '/');
        char next[4400];
        const int len = tgt[0] == '/' || !slash ? snprintf(next, sizeof next, "%s", tgt)
                                                : snprintf(next, sizeof next, "%.*s/%s", (int)(slash - cur), cur, tgt);
        if (len < 0 || (size_t)len >= sizeof next) return 0;
        if (swept_name(next, dst)) return snprintf(hop, hoplen, "%s", next), 1;
        memcpy(cur, next, (size_t)len + 1);
    }
    return 0;
}

int cli_refuse_temp_links(const char *dir)
{
    struct stat dst;
    DIR *d = stat(dir, &dst) == 0 ? opendir(dir) : NULL;
    if (!d) return 0; /* the sweep cannot read it either; the load says why */
    char p[4400], hop[4400];
    int found = 0;
    const struct dirent *de;
    while (!found && (de = readdir(d))) {
        if (cli_is_temp_name(de->d_name)) continue; /* swept itself: a killed run's, not the user's */
        snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
        found = link_through_temp(p, &dst, hop, sizeof hop);
    }
    closedir(d); /* opened to read names only */
    if (found)
        fprintf(stderr, "pdla: cannot resume: %s is a symbolic link to %s, a temporary name (a killed run's) that "
                "the resume removes; nothing loaded or changed (rename that file and point the link at the new "
                "name to resume from it)\n", p, hop);
    return found;
}
