/*
 * rundir.c - making run directories (rundir.h).
 */
#define _GNU_SOURCE /* O_PATH */
#include "rundir.h"
#include <stdio.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
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

/* Links are followed as the kernel follows them (path_resolution(7)),
 * component by component from the directory reached so far, so that a
 * temporary name used as a directory step (a -> .checkpoint.h5.new/x, with
 * .checkpoint.h5.new a link to a folder) is seen as well as one at the
 * end. The directory is held open, not as a path: ".." is then its real
 * parent, and no path of the run directory is built or cut. */
#ifdef O_PATH
#define DIR_OPEN (O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC) /* search permission only, as the kernel needs */
#else
#define DIR_OPEN (O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC)
#endif

/* The links the check follows for one path before it gives up. The
 * kernel stops at 40 (Linux MAXSYMLINKS, ELOOP), but a chain of 46 links
 * to a temporary name is a path the user may shorten, and the sweep
 * removed the file at its end: the check follows on past 40, to a
 * temporary name (refused), the end, or a loop (safe: see walk_link). */
enum { LINK_HOPS = 1000 };

enum link_walk {
    WALK_SAFE, /* resolved, a loop, or failed where the loader fails too: the sweep loses nothing through it */
    WALK_TEMP, /* through a name that the sweep unlinks */
    WALK_LOOP, /* more than LINK_HOPS links without a loop: too long a chain, not proven safe */
    WALK_LONG, /* the path left to follow outgrew rest: not proven safe */
    WALK_ERR   /* a call failed otherwise (err) */
};

/* A link being followed: its folder and itself, and the length of the
 * names after it (the walk is inside its target while more is left). */
struct active {
    dev_t ddev, dev;
    ino_t dino, ino;
    size_t tail;
};

struct walk {
    char rest[2 * PATH_MAX]; /* the names still to follow */
    char name[NAME_MAX + 1]; /* WALK_TEMP: the run directory's name that the sweep unlinks */
    int step;                /* WALK_TEMP: name is a directory step, not the end */
    int err;                 /* WALK_ERR: the errno */
    int (*swept)(const char *name); /* the names the sweep unlinks */
    struct active act[LINK_HOPS];   /* the links whose targets the walk is in, outermost first */
};

/* A failure that the loader's open meets at the same component (followed
 * in the same order): the link is broken already, and no name before it
 * was a swept one, so the sweep breaks nothing. */
static enum link_walk walk_failed(int e, struct walk *w)
{
    if (e == ENOENT || e == ENOTDIR || e == EACCES || e == ENAMETOOLONG) return WALK_SAFE;
    w->err = e;
    return WALK_ERR;
}

/* Into the directory name (absolute, or under *fd), held as *fd. 0 or an
 * errno. */
static int enter_dir(int *fd, const char *name)
{
    const int nfd = openat(*fd, name, DIR_OPEN);
    if (nfd < 0) return errno;
    close(*fd);
    *fd = nfd;
    return 0;
}

/* Is fd the swept directory (dst, its stat)? */
static int is_swept_dir(int fd, const struct stat *dst)
{
    struct stat st;
    return fstat(fd, &st) == 0 && st.st_dev == dst->st_dev && st.st_ino == dst->st_ino;
}

/* w->rest becomes the target of the link name (under fd) followed by tail,
 * the names after it (tail lies inside w->rest). Where the walk ends here,
 * w->rest is left empty. */
static enum link_walk splice_link(int fd, const char *name, const char *tail, struct walk *w)
{
    char tgt[PATH_MAX + 1];
    const ssize_t n = readlinkat(fd, name, tgt, sizeof tgt);
    w->rest[0] = '\0';
    if (n < 0) return walk_failed(errno, w);
    if ((size_t)n >= sizeof tgt) return WALK_LONG;
    if (n == 0) return WALK_SAFE; /* an empty target resolves to nothing (ENOENT) */
    const size_t t = strlen(tail);
    if ((size_t)n + 1 + t + 1 > sizeof w->rest) return WALK_LONG;
    memmove(w->rest + n + 1, tail, t + 1);
    memcpy(w->rest, tgt, (size_t)n);
    w->rest[n] = t ? '/' : '\0'; /* no '/' added at the end: "file/" fails, "file" does not */
    return WALK_SAFE;
}

/* Is the link c of the folder fd (st, its lstat) one whose target the
 * walk is inside already (m: the length of the names after c)? Then the
 * walk is in a loop: from here it repeats what it followed since it met
 * the link first, for ever, and never reaches the names after it. Else
 * it is recorded (0), or -1 when LINK_HOPS are inside one another. */
static int in_loop(int fd, const struct stat *st, size_t m, struct walk *w, int *depth)
{
    /* the links whose targets were followed to their end (the walk is in
     * the names after them) are done: the inner ones have the longer tails */
    while (*depth > 0 && w->act[*depth - 1].tail > m) --*depth;
    struct stat ds;
    if (fstat(fd, &ds) != 0) return -1;
    for (int i = 0; i < *depth; i++)
        if (w->act[i].ino == st->st_ino && w->act[i].dev == st->st_dev && w->act[i].dino == ds.st_ino &&
            w->act[i].ddev == ds.st_dev)
            return 1;
    if (*depth >= LINK_HOPS) return -1;
    w->act[*depth] = (struct active){ds.st_dev, st->st_dev, ds.st_ino, st->st_ino, m};
    ++*depth;
    return 0;
}

/* Follow the name entry of the run directory dfd (dst, its stat) as the
 * kernel would: does it lead, through any component, to a name of that
 * directory that cli_remove_temp unlinks (a temporary name, not a
 * directory: unlink leaves those)? By name, not by inode: a hard link
 * under a temporary name loses nothing when the sweep unlinks it, a path
 * through the name dangles. A loop (junk -> junk, a -> b -> a, a -> a/x)
 * that passes no such name is safe: the kernel follows a part of what the
 * walk followed (at most 40 links) and fails (ELOOP) before and after the
 * sweep alike, so an unrelated loop in the folder does not stop a
 * resume. */
static enum link_walk walk_link(int dfd, const struct stat *dst, const char *entry, struct walk *w)
{
    if (strlen(entry) >= sizeof w->rest) return WALK_LONG; /* a d_name: NAME_MAX at most; a path may be longer */
    int fd = openat(dfd, *entry == '/' ? "/" : ".", DIR_OPEN);
    if (fd < 0) return walk_failed(errno, w);
    snprintf(w->rest, sizeof w->rest, "%s", entry);
    char *r = w->rest;
    int hops = 0, depth = 0, e;
    enum link_walk res = WALK_SAFE;
    for (;;) {
        while (*r == '/') r++;
        if (!*r) break;
        char *c = r;
        r += strcspn(r, "/");
        if (*r) *r++ = '\0';
        while (*r == '/') r++;
        if (!strcmp(c, ".")) continue;
        if (!strcmp(c, "..")) {
            if ((e = enter_dir(&fd, ".."))) {
                res = walk_failed(e, w);
                break;
            }
            continue;
        }
        struct stat st;
        if (fstatat(fd, c, &st, AT_SYMLINK_NOFOLLOW) != 0) {
            res = walk_failed(errno, w);
            break;
        }
        /* at the end any name but a directory; as a step only a link (a
         * file there fails already, ENOTDIR) */
        const int swept_kind = *r ? S_ISLNK(st.st_mode) : !S_ISDIR(st.st_mode);
        if (swept_kind && w->swept(c) && is_swept_dir(fd, dst)) {
            snprintf(w->name, sizeof w->name, "%.*s", NAME_MAX, c); /* fstatat took it: NAME_MAX at most */
            w->step = *r != '\0';
            res = WALK_TEMP;
            break;
        }
        if (S_ISLNK(st.st_mode)) {
            const int loop = in_loop(fd, &st, strlen(r), w, &depth);
            if (loop > 0) break; /* WALK_SAFE */
            if (loop < 0 || ++hops > LINK_HOPS) {
                res = WALK_LOOP;
                break;
            }
            res = splice_link(fd, c, r, w);
            r = w->rest;
            if (res != WALK_SAFE || !*r) break;
            if (*r == '/' && (e = enter_dir(&fd, "/"))) {
                res = walk_failed(e, w);
                break;
            }
            continue;
        }
        /* the end, or a file as a directory step (ENOTDIR) */
        if (!*r || !S_ISDIR(st.st_mode)) break;
        if ((e = enter_dir(&fd, c))) {
            res = walk_failed(e, w);
            break;
        }
    }
    close(fd);
    return res;
}

/* s for a one-line message: each control byte (a newline or a tab in a
 * name of the folder) as \ooo, the rest as it is; into out (len bytes,
 * cut to fit). */
static const char *one_line(const char *s, char *out, size_t len)
{
    size_t k = 0;
    for (; *s && k + 5 <= len; s++) {
        const unsigned char b = (unsigned char)*s;
        if (b < 0x20 || b == 0x7f) k += (size_t)snprintf(out + k, len - k, "\\%03o", b);
        else out[k++] = (char)b;
    }
    out[k] = '\0';
    return out;
}

/* The line for a link of dir (name) that walk_link could not prove safe. */
static void refuse_link(const char *who, const char *dir_raw, const char *name_raw, enum link_walk res,
                        const struct walk *w)
{
    char dir_b[4 * PATH_MAX + 1], name_b[4 * NAME_MAX + 1], to_b[4 * NAME_MAX + 1];
    const char *const dir = one_line(dir_raw, dir_b, sizeof dir_b), *const name = one_line(name_raw, name_b,
                                                                                          sizeof name_b);
    const char *const keep = "nothing loaded or changed";
    switch (res) {
    case WALK_TEMP:
        fprintf(stderr, "%s: cannot resume: %s/%s is a symbolic link %s %s/%s, a temporary name (a killed run's) "
                "that the resume removes; %s (rename %s and point the link at the new name to resume from it)\n", who, dir,
                name, w->step ? "through" : "to", dir, one_line(w->name, to_b, sizeof to_b), keep,
                w->step ? "that link" : "that file");
        break;
    case WALK_LOOP:
        fprintf(stderr, "%s: cannot resume: %s/%s is a symbolic link that does not end within %d links (too "
                "long a chain), so it may lead to a temporary name that the resume removes; %s "
                "(shorten or remove the link)\n", who, dir, name, LINK_HOPS, keep);
        break;
    case WALK_LONG:
        fprintf(stderr, "%s: cannot resume: %s/%s is a symbolic link whose path grows past %zu bytes as it is "
                "followed, so it may lead to a temporary name that the resume removes; %s (shorten the link's "
                "target)\n", who, dir, name, sizeof w->rest - 1, keep);
        break;
    default:
        fprintf(stderr, "%s: cannot resume: cannot follow the symbolic link %s/%s: %s; %s\n", who, dir,
                name, strerror(w->err), keep);
    }
}

/* dir itself named through a name of its own that the run removes (dst:
 * its stat): 1 with the line printed, else 0. what: NULL for a resume,
 * else what a new run cannot do ("start a new run"); temp: which of those
 * names are temporary ones (the rest are an older run's). */
static int refuse_dir_path(const char *dir, const struct stat *dst, struct walk *w, const char *who,
                           const char *what, int (*temp)(const char *name))
{
    /* The sweep unlinks dir/NAME by this path, and the run then writes
     * there by it: a path that goes through a temporary name of the
     * directory itself (--resume D/.checkpoint.h5.new, a link to ".", or
     * D/.cluster.h5.new/.. with a link to a subfolder; a new run's --out
     * so named, or through the older run's checkpoint.h5, which --force
     * removes) lost its link to the sweep, and every write after it
     * failed (ENOENT). */
    const enum link_walk res = walk_link(AT_FDCWD, dst, dir, w);
    if (res == WALK_SAFE) return 0;
    char dir_b[4 * PATH_MAX + 1], name_b[4 * NAME_MAX + 1];
    one_line(dir, dir_b, sizeof dir_b);
    const int resume = what == NULL;
    const char *const verb = resume ? "resume" : what, *const kept = resume ? "loaded or changed" : "written or removed";
    if (res == WALK_TEMP)
        fprintf(stderr, "%s: cannot %s: the run directory %s is named through its own %s, %s that the %s "
                "removes; nothing %s (name the run directory by a path without it)\n", who, verb, dir_b,
                one_line(w->name, name_b, sizeof name_b),
                temp(w->name) ? "a temporary name (a killed run's)" : "a name of the older run's",
                resume ? "resume" : "run", kept);
    else
        fprintf(stderr, "%s: cannot %s: cannot follow the run directory's path %s: %s; nothing %s\n", who, verb,
                dir_b, res == WALK_ERR ? strerror(w->err) : res == WALK_LOOP ? "too many links"
                : "it grows past 8191 bytes as its links are followed", kept);
    return 1;
}

int cli_refuse_links_through(const char *dir, int (*swept)(const char *name), const char *who)
{
    struct stat dst;
    DIR *d = stat(dir, &dst) == 0 ? opendir(dir) : NULL;
    if (!d) return 0; /* the sweep cannot read it either; the load says why */
    struct walk w;
    w.swept = swept;
    if (refuse_dir_path(dir, &dst, &w, who, NULL, swept)) {
        closedir(d);
        return 1;
    }
    enum link_walk res = WALK_SAFE;
    const struct dirent *de;
    while (res == WALK_SAFE && (de = readdir(d))) {
        if (swept(de->d_name)) continue; /* swept itself: a killed run's, not the user's */
        res = walk_link(dirfd(d), &dst, de->d_name, &w);
        if (res != WALK_SAFE) refuse_link(who, dir, de->d_name, res, &w);
    }
    closedir(d); /* opened to read names only */
    return res != WALK_SAFE;
}

int cli_refuse_temp_links(const char *dir)
{
    return cli_refuse_links_through(dir, cli_is_temp_name, "pdla");
}

int cli_refuse_out_through(const char *dir, int (*swept)(const char *name), int (*temp)(const char *name),
                           const char *who)
{
    struct stat dst;
    if (stat(dir, &dst) != 0) return 0; /* the run's own checks say why */
    struct walk w;
    w.swept = swept;
    return refuse_dir_path(dir, &dst, &w, who, "start a new run", temp);
}

/* What a new run removes in its run directory: the temporary names, and
 * with --force the older run's (pdla_rundir_remove_old_run). */
static int new_run_swept(const char *name)
{
    return cli_is_temp_name(name) || pdla_rundir_old_run_name(name);
}

int cli_refuse_temp_out(const char *dir)
{
    return cli_refuse_out_through(dir, new_run_swept, cli_is_temp_name, "pdla");
}
