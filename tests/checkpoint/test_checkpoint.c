/*
 * test_checkpoint.c - pdla_checkpoint_write/load.
 *
 *   test_checkpoint basic          bit-identical serial resume (2D, 3D, with a
 *                                  raised target), generations, parameter
 *                                  refusals, foreign and non-HDF5 files,
 *                                  fall-back to the previous generation,
 *                                  write failures (RLIMIT_FSIZE, a path under
 *                                  a regular file) leaving the old one intact
 *   test_checkpoint corrupt N      N random bit flips (fixed seed) and N/4
 *                                  truncations: each is refused, or (a flip in
 *                                  bytes nothing reads) loads the very same state
 *   test_checkpoint kill N         N times: a writer process (this program,
 *                                  mode `writer`) is SIGKILLed at a random
 *                                  moment; the directory must then load the
 *                                  last generation it finished, or the next
 *   test_checkpoint threads        resume with more threads than the writer
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <hdf5.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "pdla/pdla.h"

static char tmpdir[256];

static void make_tmpdir(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/pdla-ckpt-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        exit(1);
    }
}

static void rm_rf(const char *p)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", p);
    if (system(cmd) != 0) fprintf(stderr, "cannot remove %s\n", p);
}

/* ---- a digest of everything that must survive a checkpoint --------------- */

typedef struct digest {
    uint64_t h;
    uint64_t n;
} digest;

static void mix(digest *d, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++) d->h = (d->h ^ b[i]) * UINT64_C(0x100000001b3);
}

static int visit_mix(const int32_t *xyz, size_t n, void *user)
{
    digest *d = user;
    mix(d, xyz, n * sizeof *xyz); /* dim is mixed in by the caller */
    d->n += n;
    return 0;
}

static digest engine_digest(const pdla_engine *e)
{
    digest d = {UINT64_C(0xcbf29ce484222325), 0};
    const pdla_params *p = pdla_engine_params(e);
    mix(&d, &p->dim, sizeof p->dim);
    pdla_engine_visit(e, visit_mix, &d);
    const uint64_t *n;
    const double *rg;
    size_t k;
    pdla_engine_rg_series(e, &n, &rg, &k);
    mix(&d, n, k * sizeof *n);
    mix(&d, rg, k * sizeof *rg);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    mix(&d, &s.particles, sizeof s.particles);
    mix(&d, &s.walkers, sizeof s.walkers);
    mix(&d, &s.jumps, sizeof s.jumps);
    mix(&d, &s.r_ext, sizeof s.r_ext);
    mix(&d, &s.rg_diam, sizeof s.rg_diam);
    mix(&d, &s.inner_nodes, sizeof s.inner_nodes);
    mix(&d, &s.chunks, sizeof s.chunks);
    return d;
}

static pdla_engine *grown(int dim, uint64_t target, uint64_t n, int threads)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = target;
    p.seed = 7;
    p.threads = threads;
    p.serial_until = threads > 1 ? 500 : p.serial_until;
    pdla_engine *e = NULL;
    char err[256];
    if (pdla_engine_create(&e, &p, err, sizeof err) ||
        pdla_engine_grow(e, n, NULL, 1000, NULL, err, sizeof err)) {
        fprintf(stderr, "grow: %s\n", err);
        exit(1);
    }
    return e;
}

static uint64_t file_generation(const char *path)
{
    pdla_engine *e = NULL;
    pdla_checkpoint_info info;
    char err[1024];
    if (pdla_checkpoint_load(&e, path, NULL, 0, &info, err, sizeof err)) return 0;
    pdla_engine_destroy(e);
    return info.generation;
}

/* ---- basic --------------------------------------------------------------- */

static void resume_identical(int dim, uint64_t n)
{
    char dir[300], err[1024];
    snprintf(dir, sizeof dir, "%s/resume%d", tmpdir, dim);
    mkdir(dir, 0777);
    pdla_engine *full = grown(dim, n, n, 1);
    const digest want = engine_digest(full);

    /* Half-way, stop, write, destroy, load, finish. */
    pdla_engine *half = grown(dim, n, n / 2, 1);
    pdla_checkpoint_info wi;
    CHECK(pdla_checkpoint_write(half, dir, NULL, &wi, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(wi.generation == 1 && wi.particles == n / 2 && wi.bytes > 0, "info %llu %llu",
          (unsigned long long)wi.generation, (unsigned long long)wi.particles);
    const digest mid = engine_digest(half);
    pdla_engine_destroy(half);
    pdla_engine *e = NULL;
    pdla_checkpoint_info li;
    CHECK(pdla_checkpoint_load(&e, dir, NULL, 0, &li, err, sizeof err) == PDLA_OK, "%s", err);
    if (!e) return;
    const digest got_mid = engine_digest(e);
    CHECK(got_mid.h == mid.h && got_mid.n == n / 2, "%dD: the loaded state differs", dim);
    CHECK(!li.note[0], "note: %s", li.note);
    CHECK(pdla_engine_grow(e, n, NULL, 1000, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    const digest got = engine_digest(e);
    CHECK(got.h == want.h && got.n == n, "%dD: the resumed run differs from the straight one", dim);
    pdla_engine_destroy(e);

    /* A run that finished at n/2, resumed with a raised target. */
    pdla_engine *small = grown(dim, n / 2, n / 2, 1);
    char dir2[320];
    snprintf(dir2, sizeof dir2, "%s/raised%d", tmpdir, dim);
    mkdir(dir2, 0777);
    CHECK(pdla_checkpoint_write(small, dir2, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    pdla_engine_destroy(small);
    pdla_params asked;
    pdla_params_default(&asked);
    asked.target = n;
    asked.dim = dim;
    CHECK(pdla_checkpoint_load(&e, dir2, &asked, PDLA_PARAM_TARGET | PDLA_PARAM_DIM, NULL, err,
                               sizeof err) == PDLA_OK,
          "%s", err);
    if (!e) return;
    CHECK(pdla_engine_params(e)->target == n, "target not raised");
    CHECK(pdla_engine_grow(e, n, NULL, 1000, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    const digest got2 = engine_digest(e);
    CHECK(got2.h == want.h, "%dD: raised-target resume differs from the straight run", dim);
    pdla_engine_destroy(e);
    pdla_engine_destroy(full);
}

static void write_text(const char *path, const char *s)
{
    FILE *f = fopen(path, "w");
    if (!f) return;
    fputs(s, f);
    fclose(f);
}

static void expect_refused(const char *path, const char *needle, int code)
{
    pdla_engine *e = NULL;
    char err[1024] = "";
    const int rc = pdla_checkpoint_load(&e, path, NULL, 0, NULL, err, sizeof err);
    CHECK(rc == code && e == NULL, "%s: rc %d, want %d", path, rc, code);
    CHECK(strstr(err, needle) != NULL && strchr(err, '\n') == NULL, "%s: message '%s', want '%s'",
          path, err, needle);
    pdla_engine_destroy(e);
}

static void copy_file(const char *from, const char *to)
{
    char cmd[1000];
    snprintf(cmd, sizeof cmd, "cp '%s' '%s'", from, to);
    CHECK(system(cmd) == 0, "%s", cmd);
}

/* Checkpoints written before --reference-walkers existed have no
 * /parameters/reference_walkers: they load with 0 (its table row's
 * absent_default). Any other missing parameter still means a damaged file. */
static void absent_parameter(void)
{
    char dir[300], path[400], err[1024];
    snprintf(dir, sizeof dir, "%s/absent", tmpdir);
    mkdir(dir, 0777);
    pdla_params p;
    pdla_params_default(&p);
    p.target = 1000;
    p.seed = 7;
    p.serial_until = 200;
    p.reference_walkers = 2;
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(pdla_engine_grow(e, 400, NULL, 1000, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    pdla_engine_destroy(e);
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    pdla_engine *r = NULL;
    CHECK(pdla_checkpoint_load(&r, path, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(r && pdla_engine_params(r)->reference_walkers == 2, "reference_walkers not stored");
    pdla_engine_destroy(r);
    r = NULL;
    const char *const drop[] = {"reference_walkers", "eps"};
    for (int k = 0; k < 2; k++) {
        const hid_t f = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
        const hid_t g = f < 0 ? -1 : H5Gopen2(f, "parameters", H5P_DEFAULT);
        CHECK(g >= 0 && H5Adelete(g, drop[k]) >= 0, "cannot delete /parameters/%s", drop[k]);
        if (g >= 0) H5Gclose(g);
        if (f >= 0) H5Fclose(f);
        if (k == 0) {
            CHECK(pdla_checkpoint_load(&r, path, NULL, 0, NULL, err, sizeof err) == PDLA_OK,
                  "without reference_walkers: %s", err);
            CHECK(r && pdla_engine_params(r)->reference_walkers == 0, "absent reference_walkers not 0");
            pdla_engine_destroy(r);
            r = NULL;
        } else {
            expect_refused(path, "parameter eps", PDLA_EIO);
        }
    }
}

static void basic(void)
{
    absent_parameter();
    resume_identical(2, 6000);
    resume_identical(3, 3000);

    char dir[300], path[400], err[1024];
    snprintf(dir, sizeof dir, "%s/gens", tmpdir);
    mkdir(dir, 0777);
    pdla_engine *e = grown(2, 100000, 500, 1);
    for (int g = 1; g <= 4; g++) {
        CHECK(pdla_engine_grow(e, 500 + 200 * (uint64_t)g, NULL, 1000, NULL, err, sizeof err) == PDLA_OK, "%s", err);
        CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    }
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    CHECK(file_generation(path) == 4, "newest generation %llu", (unsigned long long)file_generation(path));
    snprintf(path, sizeof path, "%s/checkpoint.1.h5", dir);
    CHECK(file_generation(path) == 3, "generation 1 back");
    snprintf(path, sizeof path, "%s/checkpoint.2.h5", dir);
    CHECK(file_generation(path) == 2, "generation 2 back");
    snprintf(path, sizeof path, "%s/checkpoint.3.h5", dir);
    CHECK(access(path, F_OK) != 0, "a fourth generation is kept");
    /* pdla_checkpoint_peek: the root's numbers; a missing output is
     * refused (it wrote through NULL), as are a directory and no path */
    uint64_t pg = 0, pn = 0;
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    CHECK(pdla_checkpoint_peek(path, &pg, &pn) == PDLA_OK && pg == 4 && pn == 1300, "peek: generation %llu, %llu",
          (unsigned long long)pg, (unsigned long long)pn);
    CHECK(pdla_checkpoint_peek(path, NULL, &pn) == PDLA_EINVAL, "peek without a generation");
    CHECK(pdla_checkpoint_peek(path, &pg, NULL) == PDLA_EINVAL, "peek without a particle count");
    CHECK(pdla_checkpoint_peek(NULL, &pg, &pn) == PDLA_EINVAL, "peek without a path");
    CHECK(pdla_checkpoint_peek(dir, &pg, &pn) == PDLA_EIO, "peek of a directory");

    /* Parameters: physics may not change, the target not drop. */
    pdla_params asked = *pdla_engine_params(e);
    pdla_engine *r = NULL;
    asked.eps = 3;
    CHECK(pdla_checkpoint_load(&r, dir, &asked, PDLA_PARAM_EPS, NULL, err, sizeof err) == PDLA_EINVAL,
          "eps change accepted");
    CHECK(strstr(err, "eps is 2 in the checkpoint, 3 asked") != NULL, "%s", err);
    asked = *pdla_engine_params(e);
    asked.seed = 8;
    CHECK(pdla_checkpoint_load(&r, dir, &asked, PDLA_PARAM_SEED, NULL, err, sizeof err) == PDLA_EINVAL,
          "seed change accepted");
    asked = *pdla_engine_params(e);
    asked.target = 10;
    CHECK(pdla_checkpoint_load(&r, dir, &asked, PDLA_PARAM_TARGET, NULL, err, sizeof err) == PDLA_EINVAL,
          "lower target accepted");
    CHECK(strstr(err, "below") != NULL, "%s", err);
    asked = *pdla_engine_params(e);
    asked.threads = 3;
    asked.eps = 2; /* asked but equal: fine */
    CHECK(pdla_checkpoint_load(&r, dir, &asked, PDLA_PARAM_THREADS | PDLA_PARAM_EPS, NULL, err,
                               sizeof err) == PDLA_OK, "%s", err);
    CHECK(r && pdla_engine_params(r)->threads == 3, "threads not applied");
    pdla_engine_destroy(r);

    /* A damaged newest generation: the previous one loads, with a note. */
    char fb[320], p0[400];
    snprintf(fb, sizeof fb, "%s/fallback", tmpdir);
    mkdir(fb, 0777);
    snprintf(p0, sizeof p0, "%s/checkpoint.h5", dir);
    snprintf(path, sizeof path, "%s/checkpoint.1.h5", fb);
    copy_file(p0, path);
    snprintf(path, sizeof path, "%s/checkpoint.h5", fb);
    copy_file(p0, path);
    truncate(path, 3000);
    pdla_checkpoint_info li;
    CHECK(pdla_checkpoint_load(&r, fb, NULL, 0, &li, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(strstr(li.note, "checkpoint.h5") && strstr(li.note, "damaged"), "note '%s'", li.note);
    CHECK(strstr(li.path, "checkpoint.1.h5") != NULL, "loaded %s", li.path);
    pdla_engine_destroy(r);
    truncate(path, 0);
    snprintf(path, sizeof path, "%s/checkpoint.1.h5", fb);
    truncate(path, 5000);
    /* Both generations fail: the one line gives each file with its reason. */
    expect_refused(fb, "/checkpoint.h5: ", PDLA_EIO);
    expect_refused(fb, "; ", PDLA_EIO);
    expect_refused(fb, "/checkpoint.1.h5: ", PDLA_EIO);

    /* Foreign and non-HDF5 files, each with its own message. */
    snprintf(path, sizeof path, "%s/cluster.h5", tmpdir);
    CHECK(pdla_output_write(e, NULL, path, err, sizeof err) == PDLA_OK, "%s", err);
    expect_refused(path, "not a pdla checkpoint (format 'pdla-cluster')", PDLA_EIO);
    snprintf(path, sizeof path, "%s/other.h5", tmpdir);
    const hid_t f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    H5Fclose(f);
    expect_refused(path, "not a pdla checkpoint (no format attribute)", PDLA_EIO);
    snprintf(path, sizeof path, "%s/notes.txt", tmpdir);
    write_text(path, "not hdf5 at all\n");
    expect_refused(path, "not an HDF5 file", PDLA_EIO);
    snprintf(path, sizeof path, "%s/missing.h5", tmpdir);
    expect_refused(path, "cannot open", PDLA_EIO);
    snprintf(path, sizeof path, "%s/empty", tmpdir);
    mkdir(path, 0777);
    expect_refused(path, "no checkpoint in this directory", PDLA_EIO);
    snprintf(path, sizeof path, "%s/.checkpoint.h5.tmp.123", dir);
    copy_file(p0, path);
    expect_refused(path, "unfinished temporary", PDLA_EIO);
    CHECK(pdla_checkpoint_remove_stale(dir) == 1, "stale temporary not removed");
    CHECK(access(path, F_OK) != 0, "stale temporary still there");

    /* Write failures: the old checkpoint stays as it was. */
    struct stat before, after;
    stat(p0, &before);
    struct rlimit old;
    getrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = {20000, old.rlim_max};
    setrlimit(RLIMIT_FSIZE, &small);
    pdla_engine_grow(e, 3000, NULL, 1000, NULL, err, sizeof err);
    const int wrc = pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err);
    setrlimit(RLIMIT_FSIZE, &old);
    CHECK(wrc == PDLA_EIO, "write past RLIMIT_FSIZE: rc %d", wrc);
    CHECK(strstr(err, "cannot write") && strstr(err, "ulimit -f") && strchr(err, '\n') == NULL,
          "message '%s'", err);
    stat(p0, &after);
    CHECK(before.st_ino == after.st_ino && before.st_size == after.st_size, "old checkpoint replaced");
    CHECK(file_generation(p0) == 4, "old checkpoint does not load");
    CHECK(pdla_checkpoint_remove_stale(dir) == 0, "a temporary file was left");
    snprintf(path, sizeof path, "%s/notes.txt/sub", tmpdir);
    CHECK(pdla_checkpoint_write(e, path, NULL, NULL, err, sizeof err) == PDLA_EIO, "under a file");
    CHECK(strstr(err, "Not a directory") != NULL, "message '%s'", err);
    /* ... and then it works again. */
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(file_generation(p0) == 5, "generation after the failure");

    /* Compressed checkpoints load the same. */
    char cz[320];
    snprintf(cz, sizeof cz, "%s/compressed", tmpdir);
    mkdir(cz, 0777);
    const pdla_checkpoint_opts zo = {.compress = 1, .command_line = "test"};
    CHECK(pdla_checkpoint_write(e, cz, &zo, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    CHECK(pdla_checkpoint_load(&r, cz, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    if (r) CHECK(engine_digest(r).h == engine_digest(e).h, "compressed round trip differs");
    pdla_engine_destroy(r);

    /* The run-directory lock: a second lock is refused. */
    int fd1 = -1, fd2 = -1;
    CHECK(pdla_rundir_lock(dir, &fd1, err, sizeof err) == PDLA_OK, "%s", err);
    const pid_t pid = fork();
    if (pid == 0) _exit(pdla_rundir_lock(dir, &fd2, err, sizeof err) == PDLA_EEXIST ? 0 : 1);
    int st = 0;
    waitpid(pid, &st, 0);
    CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0, "second lock not refused");
    pdla_rundir_unlock(fd1);
    pdla_engine_destroy(e);
}

/* ---- corruption ------------------------------------------------------------ */

static uint64_t lcg(uint64_t *s)
{
    *s = *s * UINT64_C(6364136223846793005) + UINT64_C(1442695040888963407);
    return *s >> 33;
}

static void corrupt(int flips)
{
    char dir[300], p0[400], bad[400], err[1024];
    snprintf(dir, sizeof dir, "%s/corrupt", tmpdir);
    mkdir(dir, 0777);
    pdla_engine *e = grown(2, 100000, 3000, 1);
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    const digest want = engine_digest(e);
    pdla_engine_destroy(e);
    snprintf(p0, sizeof p0, "%s/checkpoint.h5", dir);
    snprintf(bad, sizeof bad, "%s/bad.h5", tmpdir);
    FILE *f = fopen(p0, "rb");
    fseek(f, 0, SEEK_END);
    const long size = ftell(f);
    rewind(f);
    uint8_t *orig = malloc((size_t)size);
    CHECK(fread(orig, 1, (size_t)size, f) == (size_t)size, "read");
    fclose(f);
    uint64_t seed = 20261123;
    int detected = 0, harmless = 0;
    for (int i = 0; i < flips; i++) {
        const long off = (long)(lcg(&seed) % (uint64_t)size);
        const int bit = (int)(lcg(&seed) % 8);
        orig[off] ^= (uint8_t)(1u << bit);
        f = fopen(bad, "wb");
        fwrite(orig, 1, (size_t)size, f);
        fclose(f);
        orig[off] ^= (uint8_t)(1u << bit);
        pdla_engine *r = NULL;
        err[0] = '\0';
        const int rc = pdla_checkpoint_load(&r, bad, NULL, 0, NULL, err, sizeof err);
        const ssize_t open_ids = H5Fget_obj_count((hid_t)H5F_OBJ_ALL, H5F_OBJ_ALL);
        CHECK(open_ids == 0, "flip at byte %ld bit %d: %zd HDF5 objects left open (rc %d: %s)", off, bit,
              open_ids, rc, err);
        if (rc != PDLA_OK) {
            detected++;
            CHECK(err[0] && strstr(err, bad) == err && !strchr(err, '\n'), "flip %ld.%d: message '%s'",
                  off, bit, err);
        } else {
            /* Accepted: then it must be the very same state. */
            const digest got = engine_digest(r);
            CHECK(got.h == want.h && got.n == want.n, "flip at byte %ld bit %d loaded silently", off, bit);
            harmless++;
        }
        pdla_engine_destroy(r);
    }
    /* Every bit of the superblock (and what follows it). */
    for (long off = 0; off < 64; off++)
        for (int bit = 0; bit < 8; bit++) {
            orig[off] ^= (uint8_t)(1u << bit);
            f = fopen(bad, "wb");
            fwrite(orig, 1, (size_t)size, f);
            fclose(f);
            orig[off] ^= (uint8_t)(1u << bit);
            pdla_engine *r = NULL;
            const int rc = pdla_checkpoint_load(&r, bad, NULL, 0, NULL, err, sizeof err);
            CHECK(rc != PDLA_OK || engine_digest(r).h == want.h, "superblock flip %ld.%d loaded", off, bit);
            pdla_engine_destroy(r);
        }
    int truncs = 0;
    for (int i = 0; i < flips / 4; i++) {
        const long len = (long)(lcg(&seed) % (uint64_t)size);
        f = fopen(bad, "wb");
        fwrite(orig, 1, (size_t)len, f);
        fclose(f);
        pdla_engine *r = NULL;
        const int rc = pdla_checkpoint_load(&r, bad, NULL, 0, NULL, err, sizeof err);
        CHECK(rc == PDLA_EIO && !r, "truncated to %ld of %ld bytes: loaded", len, size);
        truncs++;
        pdla_engine_destroy(r);
    }
    fprintf(stderr, "corruption: %d flips in %ld bytes: %d detected, %d in bytes nothing reads "
                    "(state identical); %d truncations detected\n",
            flips, size, detected, harmless, truncs);
    free(orig);
}

/* ---- kill -9 during writes -------------------------------------------------- */

static int writer(const char *dir, int report_fd)
{
    char err[1024];
    pdla_engine *e = NULL;
    pdla_checkpoint_remove_stale(dir);
    if (pdla_checkpoint_load(&e, dir, NULL, 0, NULL, err, sizeof err) != PDLA_OK) {
        pdla_params p;
        pdla_params_default(&p);
        p.target = 1u << 30;
        if (pdla_engine_create(&e, &p, err, sizeof err)) return 1;
    }
    for (;;) {
        if (pdla_engine_grow(e, pdla_engine_count(e) + 200, NULL, 1000, NULL, err, sizeof err))
            return 1;
        pdla_checkpoint_info info;
        if (pdla_checkpoint_write(e, dir, NULL, &info, err, sizeof err)) {
            fprintf(stderr, "writer: %s\n", err);
            return 1;
        }
        if (write(report_fd, &info.generation, sizeof info.generation) != sizeof info.generation)
            return 1;
    }
}

/* README: "at every instant each of these names is a complete
 * checkpoint": after a kill, the generations before the newest load too
 * (each file itself, no fallback). Returns how many were there. */
static int kill_older_ok(const char *dir, int round)
{
    int n = 0;
    for (int k = 1; k <= 2; k++) {
        char path[400], err[1024];
        struct stat sb;
        snprintf(path, sizeof path, "%s/checkpoint.%d.h5", dir, k);
        if (stat(path, &sb) != 0) continue;
        pdla_engine *e = NULL;
        pdla_checkpoint_info info;
        const int rc = pdla_checkpoint_load(&e, path, NULL, 0, &info, err, sizeof err);
        CHECK(rc == PDLA_OK && !info.note[0], "round %d: checkpoint.%d.h5: %s%s", round, k, rc ? err : "fell back: ",
              rc ? "" : info.note);
        pdla_engine_destroy(e);
        n++;
    }
    return n;
}

static void kill_test(const char *self, int rounds)
{
    char dir[300], err[1024];
    snprintf(dir, sizeof dir, "%s/kill", tmpdir);
    mkdir(dir, 0777);
    uint64_t seed = 99, last = 0;
    int loaded_newer = 0, older = 0;
    for (int i = 0; i < rounds; i++) {
        int pfd[2];
        if (pipe(pfd)) return;
        const pid_t pid = fork();
        if (pid == 0) {
            close(pfd[0]);
            char fdarg[16];
            snprintf(fdarg, sizeof fdarg, "%d", pfd[1]);
            execl(self, self, "writer", dir, fdarg, (char *)NULL);
            _exit(127);
        }
        close(pfd[1]);
        /* Wait for the first write of this round (the load of the last one
         * takes a while), then a random moment. */
        uint64_t g;
        int got = 0;
        if (read(pfd[0], &g, sizeof g) == sizeof g) {
            last = g;
            got = 1;
        }
        const long us = (long)(lcg(&seed) % 40000);
        struct timespec ts = {0, us * 1000};
        nanosleep(&ts, NULL);
        kill(pid, SIGKILL);
        int st;
        waitpid(pid, &st, 0);
        while (read(pfd[0], &g, sizeof g) == sizeof g) last = g;
        close(pfd[0]);
        CHECK(got, "round %d: the writer never finished a checkpoint", i);
        pdla_engine *e = NULL;
        pdla_checkpoint_info info;
        const int rc = pdla_checkpoint_load(&e, dir, NULL, 0, &info, err, sizeof err);
        CHECK(rc == PDLA_OK, "round %d: %s", i, err);
        if (rc == PDLA_OK) {
            CHECK(info.generation == last || info.generation == last + 1,
                  "round %d: loaded generation %llu, last finished %llu", i,
                  (unsigned long long)info.generation, (unsigned long long)last);
            CHECK(!info.note[0], "round %d: fell back: %s", i, info.note);
            loaded_newer += info.generation == last + 1;
            last = info.generation;
        }
        pdla_engine_destroy(e);
        older += kill_older_ok(dir, i);
    }
    fprintf(stderr, "kill: %d rounds, last generation %llu, %d loaded one renamed but not yet reported, "
            "%d older generations loaded\n", rounds, (unsigned long long)last, loaded_newer, older);
    CHECK(older > 0, "no checkpoint.1.h5 or checkpoint.2.h5 was ever there to load");
}

/* ---- threads ----------------------------------------------------------------- */

static int stop_now(const pdla_engine *e, void *user)
{
    (void)e;
    ++*(int *)user;
    return 1; /* every call (20 ms): pause the workers */
}

static void threads_test(void)
{
    char dir[300], err[1024];
    snprintf(dir, sizeof dir, "%s/threads", tmpdir);
    mkdir(dir, 0777);
    pdla_engine *e = grown(2, 4000, 2000, 2);
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    pdla_engine_destroy(e);
    pdla_params asked;
    pdla_params_default(&asked);
    asked.threads = 4;
    asked.target = 20000;
    CHECK(pdla_checkpoint_load(&e, dir, &asked, PDLA_PARAM_THREADS | PDLA_PARAM_TARGET, NULL, err,
                               sizeof err) == PDLA_OK,
          "%s", err);
    if (!e) return;
    /* Pause (workers joined), checkpoint, restart: as the CLI's triggers do. */
    int calls = 0, pauses = 0;
    for (;;) {
        const int rc = pdla_engine_grow(e, 20000, stop_now, 100, &calls, err, sizeof err);
        if (rc != PDLA_ESTOPPED) {
            CHECK(rc == PDLA_OK, "%s", err);
            break;
        }
        pauses++;
        CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    }
    fprintf(stderr, "threads: %d pauses with a checkpoint each\n", pauses);
    CHECK(pdla_engine_count(e) == 20000, "count %llu", (unsigned long long)pdla_engine_count(e));
    pdla_stats s;
    pdla_engine_stats(e, &s);
    CHECK(s.threads == 4, "threads %d", s.threads);
    /* Writing and loading again re-checks every invariant of the tree. */
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    pdla_engine *r = NULL;
    CHECK(pdla_checkpoint_load(&r, dir, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "%s", err);
    if (r) CHECK(engine_digest(r).h == engine_digest(e).h, "threaded state round trip differs");
    pdla_engine_destroy(r);
    pdla_engine_destroy(e);
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "writer")) return writer(argv[2], atoi(argv[3]));
    if (argc >= 3 && !strcmp(argv[1], "load")) { /* for debugging: load paths */
        int rc = 0;
        for (int i = 2; i < argc; i++) {
            pdla_engine *e = NULL;
            char err[1024] = "";
            rc = pdla_checkpoint_load(&e, argv[i], NULL, 0, NULL, err, sizeof err);
            printf("%d %s\n", rc, err);
            pdla_engine_destroy(e);
        }
        return rc ? 1 : 0;
    }
    if (argc < 2) {
        fprintf(stderr, "usage: test_checkpoint basic|corrupt N|kill N|threads\n");
        return 2;
    }
    make_tmpdir();
    if (!strcmp(argv[1], "basic")) basic();
    else if (!strcmp(argv[1], "corrupt")) corrupt(argc > 2 ? atoi(argv[2]) : 200);
    else if (!strcmp(argv[1], "kill")) kill_test("/proc/self/exe", argc > 2 ? atoi(argv[2]) : 50);
    else if (!strcmp(argv[1], "threads")) threads_test();
    else {
        fprintf(stderr, "unknown mode %s\n", argv[1]);
        return 2;
    }
    rm_rf(tmpdir);
    return check_finish();
}
