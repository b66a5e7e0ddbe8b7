/*
 * ens_record.c - what defines an ensemble (its config and the seed of each
 * cluster) and a finished cluster's record as bytes: the journal's payload,
 * and what a distributed scheduler ships between processes
 * (include/pdla/ensemble.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/ensemble.h"

int pdla_ens_config_check(const pdla_ens_config *c, char *err, size_t errlen)
{
    if (c->clusters < 1) return pdla_errorf(PDLA_EINVAL, err, errlen, "the number of clusters must be at least 1, got 0");
    if (c->clusters > PDLA_ENS_MAX_CLUSTERS)
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "%llu clusters: an ensemble holds at most %llu (ensemble.h5 is written from memory)",
                           (unsigned long long)c->clusters, (unsigned long long)PDLA_ENS_MAX_CLUSTERS);
    if (c->params.seed > UINT64_MAX - (c->clusters - 1))
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "seed range overflows: seeds %llu + 0..%llu pass 2^64 - 1 (lower --seed or --clusters)",
                           (unsigned long long)c->params.seed, (unsigned long long)(c->clusters - 1));
    if (c->deflate_level < 0 || c->deflate_level > 9)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "deflate_level must be in 0..9, got %d", c->deflate_level);
    if (c->keep_positions != 0 && c->keep_positions != 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "keep_positions must be 0 or 1, got %d", c->keep_positions);
    /* ensemble.h5 holds every cluster's R_g(N): with no samples its
     * rg_diam had no columns, HDF5 refused the chunking, and every run and
     * resume failed at the write after growing everything (found by an
     * adversarial test) */
    if (c->params.rg_per_decade < 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "an ensemble records R_g(N): rg samples per decade must be at "
                                                     "least 1, got %d", c->params.rg_per_decade);
    if (c->params.threads != 1 || c->params.bind != PDLA_BIND_NONE)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "each cluster of an ensemble grows serially: threads must be 1 "
                                                     "and bind none in its parameters");
    return pdla_params_validate(&c->params, err, errlen);
}

uint64_t pdla_ens_rg_samples_max(const pdla_ens_config *c)
{
    const uint64_t n = c->params.target;
    const int pd = c->params.rg_per_decade;
    double kd = pd > 0 && n > 0 ? pd * log10((double)n) + 2.0 : 0.0;
    if (kd > (double)n) kd = (double)n;
    return kd >= 0x1p60 ? UINT64_C(1) << 60 : (uint64_t)kd;
}

void pdla_ens_cluster_params(const pdla_ens_config *c, uint64_t i, pdla_params *out)
{
    *out = c->params;
    out->seed = c->params.seed + i;
    out->threads = 1;
    out->bind = PDLA_BIND_NONE;
}

void pdla_ens_record_free(pdla_ens_record *r)
{
    if (!r) return;
    free(r->rg_n);
    free(r->rg);
    free(r->positions);
    r->rg_n = NULL;
    r->rg = NULL;
    r->positions = NULL;
}

/* ---- records as bytes ----------------------------------------------------
 * Native byte order (the journal's header records it), fixed fields first:
 * u64 index seed particles walkers jumps; f64 rg_diam r_ext_diam df df_err
 * prefactor; u64 n_lo n_hi; i32 points dim; f64 cpu wall; u64 rg_count npos;
 * then u64 rg_n[rg_count], f64 rg[rg_count], i32 positions[npos * dim]. */

#define REC_FIXED (5 * 8 + 5 * 8 + 2 * 8 + 2 * 4 + 2 * 8 + 2 * 8)
_Static_assert(REC_FIXED == PDLA_ENS_RECORD_FIXED, "the record's fixed part");

static uint8_t *put(uint8_t *p, const void *v, size_t n)
{
    memcpy(p, v, n);
    return p + n;
}

static const uint8_t *get(const uint8_t *p, void *v, size_t n)
{
    memcpy(v, p, n);
    return p + n;
}

uint64_t pdla_ens_record_max_bytes(const pdla_ens_config *c)
{
    const uint64_t cap = UINT64_C(1) << 60, k = pdla_ens_rg_samples_max(c);
    const uint64_t pos = c->keep_positions ? c->params.target : 0, dim = (uint64_t)c->params.dim;
    if (k > cap / 64 || pos > cap / 16) return cap;
    /* Twice the samples and 64 more: a slack, as a valid record refused
     * here would be grown again. */
    return REC_FIXED + (2 * k + 64) * 16 + pos * dim * 4;
}

int pdla_ens_record_encode(const pdla_ens_record *r, uint8_t **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    if (r->dim < 2 || r->dim > 3 || r->rg_count > (SIZE_MAX / 32) || r->npos > SIZE_MAX / 32)
        return PDLA_EINVAL;
    const size_t n = REC_FIXED + (size_t)r->rg_count * 16 + (size_t)r->npos * (size_t)r->dim * 4;
    uint8_t *b = malloc(n), *p = b;
    if (!b) return PDLA_ENOMEM;
    const uint64_t u[5] = {r->index, r->seed, r->particles, r->walkers, r->jumps};
    const double d[5] = {r->rg_diam, r->r_ext_diam, r->fit.df, r->fit.df_err, r->fit.prefactor_diam};
    const uint64_t nr[2] = {r->fit.n_lo, r->fit.n_hi};
    const int32_t ii[2] = {r->fit.points, r->dim};
    const double t[2] = {r->cpu_seconds, r->wall_seconds};
    const uint64_t cnt[2] = {r->rg_count, r->npos};
    p = put(p, u, sizeof u);
    p = put(p, d, sizeof d);
    p = put(p, nr, sizeof nr);
    p = put(p, ii, sizeof ii);
    p = put(p, t, sizeof t);
    p = put(p, cnt, sizeof cnt);
    if (r->rg_count) {
        p = put(p, r->rg_n, (size_t)r->rg_count * 8);
        p = put(p, r->rg, (size_t)r->rg_count * 8);
    }
    if (r->npos) p = put(p, r->positions, (size_t)r->npos * (size_t)r->dim * 4);
    *buf = b;
    *len = (size_t)(p - b);
    return PDLA_OK;
}

/* The fixed part's fields into r, and whether the counts it declares add up
 * to len: shared by the peek (the journal scan reads only the fixed part of
 * a candidate first) and the full decode. */
static int fixed_decode(const uint8_t *p, uint64_t len, pdla_ens_record *r)
{
    memset(r, 0, sizeof *r);
    if (len < REC_FIXED) return -1;
    uint64_t u[5], nr[2], cnt[2];
    double d[5], t[2];
    int32_t ii[2];
    p = get(p, u, sizeof u);
    p = get(p, d, sizeof d);
    p = get(p, nr, sizeof nr);
    p = get(p, ii, sizeof ii);
    p = get(p, t, sizeof t);
    (void)get(p, cnt, sizeof cnt);
    if (ii[1] < 2 || ii[1] > 3 || cnt[0] > len / 16 || cnt[1] > len / 8 ||
        len != REC_FIXED + cnt[0] * 16 + cnt[1] * (uint64_t)ii[1] * 4)
        return -1;
    r->index = u[0];
    r->seed = u[1];
    r->particles = u[2];
    r->walkers = u[3];
    r->jumps = u[4];
    r->rg_diam = d[0];
    r->r_ext_diam = d[1];
    r->fit.df = d[2];
    r->fit.df_err = d[3];
    r->fit.prefactor_diam = d[4];
    r->fit.n_lo = nr[0];
    r->fit.n_hi = nr[1];
    r->fit.points = ii[0];
    r->dim = ii[1];
    r->cpu_seconds = t[0];
    r->wall_seconds = t[1];
    r->rg_count = cnt[0];
    r->npos = cnt[1];
    return 0;
}

int pdla_ens_record_peek(const uint8_t *fixed, uint64_t len, pdla_ens_record *r)
{
    return fixed_decode(fixed, len, r);
}

int pdla_ens_record_decode(const uint8_t *buf, size_t len, pdla_ens_record *r, char *err, size_t errlen)
{
    if (len < REC_FIXED) {
        memset(r, 0, sizeof *r);
        return pdla_errorf(PDLA_EIO, err, errlen, "a cluster record of %zu bytes is too short", len);
    }
    if (fixed_decode(buf, len, r))
        return pdla_errorf(PDLA_EIO, err, errlen, "a cluster record's lengths do not add up (%zu bytes)", len);
    const uint8_t *p = buf + REC_FIXED;
    const size_t k = (size_t)r->rg_count, np = (size_t)r->npos * (size_t)r->dim;
    r->rg_n = malloc((k ? k : 1) * 8);
    r->rg = malloc((k ? k : 1) * 8);
    r->positions = np ? malloc(np * 4) : NULL;
    if (!r->rg_n || !r->rg || (np && !r->positions)) {
        pdla_ens_record_free(r);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory reading a cluster record");
    }
    if (k) {
        p = get(p, r->rg_n, k * 8);
        p = get(p, r->rg, k * 8);
    }
    if (np) get(p, r->positions, np * 4);
    return PDLA_OK;
}
