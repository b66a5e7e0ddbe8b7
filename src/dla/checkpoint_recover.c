/*
 * checkpoint_recover.c - pdla_checkpoint_recover() (pdla.h): after a resume
 * from a run directory fell back past damaged newer generations, those go
 * aside as checkpoint.damaged*.h5 (pdla_rundir_set_aside) and the good
 * generations move to the front, so that the rotation of the next writes
 * (checkpoint_write.c, shift_generations) shifts only complete checkpoints.
 * Without it the first write after such a resume hard-linked the damaged
 * checkpoint.h5 as checkpoint.1.h5, the second pushed the file the run had
 * resumed from out and kept the damaged one as checkpoint.2.h5, and the new
 * file took the damaged one's generation number.
 *
 * pdla_checkpoint_place() does the same for a checkpoint FILE named
 * (`--resume DIR/checkpoint.1.h5`), whose resume writes into DIR's
 * generations too: every generation name ahead of the file must be damaged
 * or absent (those go aside as above), and a valid one there refuses the
 * resume, since its writes would rotate it out. Until session 31 a named
 * file's folder was left as it was, and the writes rotated a damaged
 * checkpoint.h5 into the generations and pushed out good ones.
 */
#define _GNU_SOURCE

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "checkpoint_fmt.h"
#include "engine.h"
#include "h5util.h"

/* peek's generation when the root of path reads (its check refuses the
 * numbers from CKPT_GENERATION_MAX up: no run's, a forged root). */
static int peek(const char *path, uint64_t *g)
{
    return ckpt_peek_generation(path, g);
}

/* The generation the next write must come after: the loaded file's, each
 * generation name's own where its root reads (a checksum error in a
 * dataset leaves it readable), and each kept file's (checkpoint.damaged*:
 * a resume killed after the set-aside, or refused after it, finds the
 * damaged file only there). A skipped name j whose root does not read (a
 * truncated file) counts as the generation it had by its place, the loaded
 * one's plus slot - j, since each write moves every name one place on. The
 * caller silences HDF5's error stack. */
static uint64_t generation_past(const char *dir, const pdla_checkpoint_info *info)
{
    uint64_t past = info->generation, g = 0;
    char name[4400];
    for (int k = 0; k < PDLA_CHECKPOINT_GENERATIONS; k++) {
        ckpt_gen_name(name, sizeof name, dir, k);
        struct stat st;
        if (lstat(name, &st) != 0) continue;
        if (peek(name, &g) != 0) {
            if (k >= info->slot) continue; /* an older one: the loaded one is past it */
            g = info->generation + (uint64_t)(info->slot - k);
        }
        if (g > past) past = g;
    }
    DIR *d = opendir(dir);
    if (!d) return past; /* the set-aside that follows reports what is wrong */
    const struct dirent *de;
    const size_t plen = strlen(PDLA_CHECKPOINT_ASIDE_PREFIX);
    while ((de = readdir(d)))
        if (!strncmp(de->d_name, PDLA_CHECKPOINT_ASIDE_PREFIX, plen)) {
            snprintf(name, sizeof name, "%s/%s", dir, de->d_name);
            if (peek(name, &g) == 0 && g > past) past = g;
        }
    (void)closedir(d); /* opened to read names only: a failed close loses nothing */
    return past;
}

/* The loaded generation (name slot) and the older ones move to the front:
 * name slot + i becomes name i. The names before slot are free (set aside,
 * or never there) and each rename frees the next target, so none replaces a
 * file. The directory is synced after each rename: on a power loss a later
 * one must not land without the earlier (checkpoint.2.h5 renamed over
 * checkpoint.1.h5 before that had become checkpoint.h5 would lose the file
 * the run resumed from). */
static int to_front(const char *dir, int slot, char *err, size_t errlen)
{
    char from[4200], to[4200];
    for (int i = 0; slot + i < PDLA_CHECKPOINT_GENERATIONS; i++) {
        ckpt_gen_name(from, sizeof from, dir, slot + i);
        ckpt_gen_name(to, sizeof to, dir, i);
        if (rename(from, to) != 0) {
            if (errno == ENOENT && i > 0) continue; /* no older generation there */
            return pdla_errorf(PDLA_EIO, err, errlen, "cannot rename %s to %s: %s", from, to, strerror(errno));
        }
        if (h5u_fsync_dir(dir) != 0)
            return pdla_errorf(PDLA_EIO, err, errlen, "cannot sync directory %s: %s", dir, strerror(errno));
    }
    return PDLA_OK;
}

/* Appends "; " (unless first) and a, b, c to line; a line too long for it
 * (names of 4000 bytes) is cut, which only shortens a note. */
static void add_clause(char *line, size_t len, const char *a, const char *b, const char *c)
{
    const size_t used = strlen(line);
    if (used + 1 >= len) return;
    const int n = snprintf(line + used, len - used, "%s%s%s%s", used ? "; " : "", a, b, c);
    if (n < 0) line[used] = '\0';
}

/* The skipped names (before slot) go aside, synced, then the generations to
 * the front (none when slot is PDLA_CHECKPOINT_GENERATIONS: a file named
 * that is no generation name); line gets what moved. A crash between the
 * steps leaves the skipped names free or still damaged (the next resume
 * falls back again), never a damaged file under a name the good one left. */
static int move_generations(const char *dir, int slot, char *line, size_t linelen, char *err, size_t errlen)
{
    char name[4200], kept[4200];
    int moved = 0;
    for (int j = 0; j < slot; j++) {
        ckpt_gen_name(name, sizeof name, dir, j);
        const int rc = pdla_rundir_set_aside(dir, name, kept, sizeof kept, err, errlen);
        if (rc) return rc;
        if (kept[0]) add_clause(line, linelen, name, " set aside as ", kept);
        moved += kept[0] != '\0';
    }
    if (slot == PDLA_CHECKPOINT_GENERATIONS && !moved) return PDLA_OK; /* nothing there */
    if (h5u_fsync_dir(dir) != 0)
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot sync directory %s: %s", dir, strerror(errno));
    if (slot == PDLA_CHECKPOINT_GENERATIONS) return PDLA_OK;
    const int rc = to_front(dir, slot, err, errlen);
    if (rc) return rc;
    ckpt_gen_name(kept, sizeof kept, dir, slot);
    ckpt_gen_name(name, sizeof name, dir, 0);
    add_clause(line, linelen, kept, " is now ", name);
    return PDLA_OK;
}

int pdla_checkpoint_recover(pdla_engine *e, const char *dir, const pdla_checkpoint_info *info,
                            char *done, size_t donelen, char *err, size_t errlen)
{
    char line[2048] = "";
    if (err && errlen) err[0] = '\0';
    if (done && donelen) done[0] = '\0';
    if (!e || !dir || !info || strlen(dir) > 4000 || info->slot > PDLA_CHECKPOINT_GENERATIONS)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "checkpoint recovery: no engine, directory or load");
    if (info->slot < 0) return PDLA_OK; /* a file named, not placed (pdla_checkpoint_place): left alone */
    h5u_quiet q;
    if (h5u_silence(&q) < 0) return pdla_errorf(PDLA_EIO, err, errlen, "cannot silence the HDF5 error stack");
    const uint64_t past = generation_past(dir, info);
    if (h5u_restore(&q) < 0) return pdla_errorf(PDLA_EIO, err, errlen, "cannot restore the HDF5 error handler");
    if (info->slot > 0) {
        const int rc = move_generations(dir, info->slot, line, sizeof line, err, errlen);
        if (rc) return rc;
    }
    if (past > e->ckpt_generation) e->ckpt_generation = past;
    if (done && donelen && line[0])
        snprintf(done, donelen, "%s; the next checkpoint is generation %llu", line,
                 (unsigned long long)e->ckpt_generation + 1);
    return PDLA_OK;
}

/* ---- a checkpoint file named: its place among the generation names ---- */

/* The generation name of dir that is the file st describes (the first when
 * a kill inside a write left one file under two names), or
 * PDLA_CHECKPOINT_GENERATIONS when none is. */
static int slot_of(const char *dir, const struct stat *st)
{
    char name[4200];
    for (int k = 0; k < PDLA_CHECKPOINT_GENERATIONS; k++) {
        struct stat sk;
        ckpt_gen_name(name, sizeof name, dir, k);
        if (lstat(name, &sk) == 0 && sk.st_dev == st->st_dev && sk.st_ino == st->st_ino) return k;
    }
    return PDLA_CHECKPOINT_GENERATIONS;
}

/* Each generation name of dir before slot, loaded as a directory resume
 * loads it, one at a time (never two engines at once): absent or damaged
 * is PDLA_OK (note gets the first one's reason), a valid checkpoint
 * PDLA_EEXIST, with err naming it, what it holds and the two ways on. The
 * caller silences HDF5's error stack. */
static int check_ahead(const char *path, const char *dir, int slot, char *note, size_t notelen, char *err,
                       size_t errlen)
{
    char name[4200], why[1024];
    for (int k = 0; k < slot; k++) {
        ckpt_gen_name(name, sizeof name, dir, k);
        struct stat st;
        if (lstat(name, &st) != 0) {
            if (errno == ENOENT) continue;
            return pdla_errorf(PDLA_EIO, err, errlen, "cannot look at %s: %s", name, strerror(errno));
        }
        pdla_engine *e = NULL;
        pdla_checkpoint_info in;
        memset(&in, 0, sizeof in);
        why[0] = '\0';
        const int rc = ckpt_load_name(name, NULL, 0, &e, &in, why, sizeof why);
        pdla_engine_destroy(e);
        if (rc == PDLA_EIO) { /* damaged: pdla_checkpoint_recover sets it aside */
            if (note && notelen && !note[0]) snprintf(note, notelen, "skipped %s", why);
            continue;
        }
        if (rc != PDLA_OK) return pdla_errorf(rc, err, errlen, "%s", why);
        return pdla_errorf(PDLA_EEXIST, err, errlen,
                           "%s: %s is a %svalid checkpoint (generation %llu, %llu particles) that the "
                           "checkpoints of this resume would rotate out; resume the newest with --resume %s, "
                           "or move %s out of %s to go on from %s",
                           path, name, slot < PDLA_CHECKPOINT_GENERATIONS ? "newer " : "",
                           (unsigned long long)in.generation, (unsigned long long)in.particles, dir, name, dir,
                           path);
    }
    return PDLA_OK;
}

int pdla_checkpoint_place(const char *path, const char *dir, int *slot, char *note, size_t notelen, char *err,
                          size_t errlen)
{
    if (err && errlen) err[0] = '\0';
    if (note && notelen) note[0] = '\0';
    if (!slot || !path || !dir || strlen(path) > 4000 || strlen(dir) > 4000)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "checkpoint place: no slot, file or directory");
    *slot = -1;
    struct stat st;
    /* not a regular checkpoint file: the load that follows says why */
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode) || ckpt_is_tmp_name(path)) return PDLA_OK;
    h5u_quiet q;
    if (h5u_silence(&q) < 0) return pdla_errorf(PDLA_EIO, err, errlen, "cannot silence the HDF5 error stack");
    uint64_t g;
    int rc = ckpt_foreign_names(dir, err, errlen), k = -1;
    if (rc == PDLA_OK && ckpt_peek_generation(path, &g) == 0) { /* its root reads: a checkpoint, perhaps whole */
        k = slot_of(dir, &st);
        rc = check_ahead(path, dir, k, note, notelen, err, errlen);
    }
    if (h5u_restore(&q) < 0 && rc == PDLA_OK)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot restore the HDF5 error handler");
    if (rc == PDLA_OK) *slot = k;
    else if (note && notelen) note[0] = '\0';
    if (err && errlen) h5u_one_line(err);
    return rc;
}
