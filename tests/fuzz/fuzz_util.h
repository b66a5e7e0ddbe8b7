/*
 * fuzz_util.h - what the fuzz targets share: the one-line rule for error
 * messages, an empty scratch directory per process, a reader of the
 * fuzzer's input as a stream of bytes, and the DLA checkpoint check (load;
 * if it loads, grow a little, write back and load again). Header-only:
 * each target is one file built by scripts/fuzz.
 */
#ifndef PDLA_TESTS_FUZZ_UTIL_H
#define PDLA_TESTS_FUZZ_UTIL_H

#include <dirent.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* A message is one non-empty line. */
static inline void fuzz_one_line(const char *err)
{
    if (!err[0] || strchr(err, '\n')) abort();
}

/* /tmp/pdla-fuzz-TAG-PID, made if need be and emptied (no system(): a
 * shell per run is slow). */
static inline void fuzz_scratch_dir(char *dir, size_t n, const char *tag)
{
    snprintf(dir, n, "/tmp/pdla-fuzz-%s-%ld", tag, (long)getpid());
    if (mkdir(dir, 0700) != 0 && errno != EEXIST) abort();
    DIR *d = opendir(dir);
    if (!d) abort();
    struct dirent *de;
    while ((de = readdir(d))) {
        if (de->d_name[0] == '.') continue;
        char f[512];
        snprintf(f, sizeof f, "%s/%s", dir, de->d_name);
        unlink(f);
    }
    closedir(d);
}

/* The input as a stream: past its end every byte reads 0. */
typedef struct {
    const uint8_t *p;
    size_t n;
} fuzz_in;

static inline unsigned fuzz_byte(fuzz_in *in)
{
    if (!in->n) return 0;
    in->n--;
    return *in->p++;
}

static inline uint64_t fuzz_bytes(fuzz_in *in, int k)
{
    uint64_t v = 0;
    for (int i = 0; i < k; i++) v = v << 8 | fuzz_byte(in);
    return v;
}

#ifdef PDLA_PDLA_H
/* pdla_checkpoint_load of path: a refusal is one line and no engine; what
 * loads must grow a little, write a checkpoint and load it again with the
 * same count. */
static inline void fuzz_dla_check(const char *path)
{
    pdla_engine *e = NULL;
    char err[1024] = "";
    if (pdla_checkpoint_load(&e, path, NULL, 0, NULL, err, sizeof err) != PDLA_OK) {
        fuzz_one_line(err);
        if (e) abort();
        return;
    }
    char dir[64];
    fuzz_scratch_dir(dir, sizeof dir, "dla");
    const pdla_params *p = pdla_engine_params(e);
    if (pdla_engine_count(e) < p->target && pdla_engine_count(e) < 5000)
        pdla_engine_grow(e, pdla_engine_count(e) + 10, NULL, 1000, NULL, err, sizeof err);
    if (pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) != PDLA_OK) abort();
    pdla_engine *r = NULL;
    if (pdla_checkpoint_load(&r, dir, NULL, 0, NULL, err, sizeof err) != PDLA_OK) abort();
    if (pdla_engine_count(r) != pdla_engine_count(e)) abort();
    pdla_engine_destroy(r);
    pdla_engine_destroy(e);
}
#endif

#endif
