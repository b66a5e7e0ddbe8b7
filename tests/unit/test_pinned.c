/*
 * test_pinned.c - serial clusters are bit-identical to those of a pinned
 * revision. Each case grows a small serial cluster through the public API
 * and hashes its particle positions (FNV-1a 64 over the int32 coordinates,
 * tree order and arrival order); the expected hashes were taken from the
 * build of commit 3133031 (main before the issue-9 restructuring), the 2D
 * ones re-pinned in session 10 (branch sp10), whose 2D jump and return
 * samplers draw the random stream differently (same laws: tests/sampling,
 * test_sample; runs/bench-serial/issue12-sp10-2026-11-25.md), the 3D ones
 * re-pinned in session 10 (branch s3d10), whose 3D jump direction takes one
 * draw per try (sample_step3; runs/bench-serial/issue12-s3d10-2026-11-25.md),
 * and the 3D ones with the map re-pinned again in session 22, whose 3D map
 * bound also reads the face neighbours' cells and answers near the
 * cluster from 4 diameters (distmap_faces3: other jumps, the same law;
 * runs/bench-serial/issue12-near22-2026-11-30.md; exact search, case 3 5,
 * reads no map and kept its hashes). Each case
 * also grows half-way, writes a checkpoint, resumes from it and must reach
 * the same hashes: checkpoint -> resume is bit-identical too.
 * A change of the walk, the search, the random stream or the tree's order
 * fails here; a deliberate physics change must re-pin and say so.
 */
#include "check.h"

#include <pdla/pdla.h>

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct pin_case {
    int dim;
    uint64_t seed, target;
    int variant;          /* 0 defaults, 1 kill mode + no snap, 2 exact search, D = 16 */
    uint64_t tree_hash, arrival_hash;
} pin_case;

static const pin_case pin_cases[] = {
    {2, 1, 30000, 0, UINT64_C(0xdd90d502da6361db), UINT64_C(0x3cfc8b7c04377b8f)},
    {2, 2, 4000, 0, UINT64_C(0xd9210bfaf1bd9908), UINT64_C(0x3e3bb3d51a5d3b74)},
    {2, 7, 3000, 1, UINT64_C(0x9ee4690a48ca6c4b), UINT64_C(0x58816638457f7e6f)},
    {2, 9, 3000, 2, UINT64_C(0xad3351d6759b3206), UINT64_C(0x83a4b18507dfd662)},
    {3, 1, 15000, 0, UINT64_C(0xb770914d8ad4fb67), UINT64_C(0xf67ac5dc180716b3)},
    {3, 3, 2000, 1, UINT64_C(0x77efd6ecb1dc887f), UINT64_C(0x58c7a1c746455003)},
    {3, 5, 1500, 2, UINT64_C(0x8317a965eb63ee1a), UINT64_C(0x950cd9ca884a05e2)},
};

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *b = data;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= UINT64_C(0x100000001b3);
    }
    return h;
}

static int hash_visit(const int32_t *xyz, size_t n, void *user)
{
    uint64_t *h = user;
    const int dim = (int)h[1];
    for (size_t i = 0; i < n * (size_t)dim; i++) {
        const uint32_t v = (uint32_t)xyz[i];
        const unsigned char le[4] = {v & 0xff, (v >> 8) & 0xff, (v >> 16) & 0xff, v >> 24};
        h[0] = fnv1a(h[0], le, 4);
    }
    return 0;
}

static void hashes(const pdla_engine *e, uint64_t *tree, uint64_t *arrival)
{
    const int dim = pdla_engine_params(e)->dim;
    uint64_t h[2] = {UINT64_C(0xcbf29ce484222325), (uint64_t)dim};
    pdla_engine_visit(e, hash_visit, h);
    *tree = h[0];
    uint64_t n = 0;
    const int32_t *a = pdla_engine_arrival(e, &n);
    uint64_t ha[2] = {UINT64_C(0xcbf29ce484222325), (uint64_t)dim};
    if (a) hash_visit(a, (size_t)n, ha);
    *arrival = ha[0];
}

static void case_params(const pin_case *c, pdla_params *p)
{
    pdla_params_default(p);
    p->dim = c->dim;
    p->seed = c->seed;
    p->target = c->target;
    p->record_arrival = 1;
    if (c->variant == 1) {
        p->return_mode = PDLA_RETURN_KILL;
        p->snap_contact = 0;
    } else if (c->variant == 2) {
        p->exact_search = 1;
        p->resolution = 16;
    }
}

static void run_case(const pin_case *c, const char *dir, int print)
{
    char err[512];
    pdla_params p;
    case_params(c, &p);
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == 0, "%s", err);
    if (!e) return;
    CHECK(pdla_engine_grow(e, c->target, NULL, 0, NULL, err, sizeof err) == 0, "%s", err);
    uint64_t th, ah;
    hashes(e, &th, &ah);
    pdla_engine_destroy(e);
    if (print)
        printf("    {%d, %" PRIu64 ", %" PRIu64 ", %d, UINT64_C(0x%016" PRIx64
               "), UINT64_C(0x%016" PRIx64 ")},\n",
               c->dim, c->seed, c->target, c->variant, th, ah);
    CHECK(th == c->tree_hash, "dim %d seed %" PRIu64 " variant %d: tree hash %016" PRIx64
          " != pinned %016" PRIx64, c->dim, c->seed, c->variant, th, c->tree_hash);
    CHECK(ah == c->arrival_hash, "dim %d seed %" PRIu64 " variant %d: arrival hash %016" PRIx64
          " != pinned %016" PRIx64, c->dim, c->seed, c->variant, ah, c->arrival_hash);

    /* Half-way checkpoint, then resume to the target: same cluster. */
    e = NULL;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == 0, "%s", err);
    if (!e) return;
    CHECK(pdla_engine_grow(e, c->target / 2, NULL, 0, NULL, err, sizeof err) == 0, "%s", err);
    const pdla_checkpoint_opts opts = {.command_line = "test_pinned"};
    CHECK(pdla_checkpoint_write(e, dir, &opts, NULL, err, sizeof err) == 0, "%s", err);
    pdla_engine_destroy(e);
    e = NULL;
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, PDLA_CHECKPOINT_NAME);
    CHECK(pdla_checkpoint_load(&e, path, NULL, 0, NULL, err, sizeof err) == 0, "%s", err);
    if (!e) return;
    CHECK(pdla_engine_grow(e, c->target, NULL, 0, NULL, err, sizeof err) == 0, "%s", err);
    uint64_t rth, rah;
    hashes(e, &rth, &rah);
    pdla_engine_destroy(e);
    CHECK(rth == th && rah == ah, "dim %d seed %" PRIu64 " variant %d: resumed cluster differs",
          c->dim, c->seed, c->variant);
    for (int g = 0; g < PDLA_CHECKPOINT_GENERATIONS; g++) {
        char f[4300];
        if (g == 0) snprintf(f, sizeof f, "%s/%s", dir, PDLA_CHECKPOINT_NAME);
        else snprintf(f, sizeof f, "%s/checkpoint.%d.h5", dir, g);
        unlink(f);
    }
}

int main(int argc, char **argv)
{
    /* --print: write the table rows with the hashes of this build (to re-pin). */
    const int print = argc > 1 && strcmp(argv[1], "--print") == 0;
    pdla_hdf5_quiet();
    char dir[] = "/tmp/pdla-pinned-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    for (size_t i = 0; i < sizeof pin_cases / sizeof pin_cases[0]; i++)
        run_case(&pin_cases[i], dir, print);
    rmdir(dir);
    return check_finish();
}
