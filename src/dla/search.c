/*
 * search.c - variable-precision distance search (VPDIST, Listing 1 of
 * Sosa-Herrera & Rodriguez-Romo) on the bucket quadtree/octree.
 *
 * One descent along the query's own path, then a climb that searches the
 * siblings of each node on the path (branch and bound, nearest child first,
 * explicit stack) until the ball of the current bound fits inside a node. For each non-empty node the squared distance from the
 * query point to the node's box is a lower bound for every particle inside:
 *  - boxes no nearer than the best bound so far are pruned;
 *  - boxes farther than far2[level] are not opened: their box distance is
 *    accepted as the bound (the "approximate" answer of VPDIST, off by at
 *    most one box diagonal, i.e. relative error <= sqrt(dim)/far_factor);
 *  - leaves near the query are scanned exactly.
 * So the result never exceeds the true distance, and it is exact whenever it
 * is below the smallest far threshold. Every update of the bound is a
 * minimum (a scanned particle, or a far node's box distance below the bound)
 * and a box is pruned only when nothing in it can go below the bound, so
 * the answer is the minimum over a set fixed by the geometry alone (the
 * particles of leaves with no far ancestor, and the far nodes with no far
 * ancestor): the order of the visits changes the work, never the answer. All arithmetic is on 64-bit integers;
 * the coordinate limits (pdla.h) keep every squared sum below 2^64.
 * The per-dimension code is one always-inlined body instantiated for dim 2
 * and 3, so a 2D run pays nothing for 3D.
 */
#include "tree.h"
#include "search.h"

#include <math.h>
#include <string.h>

#include "distmap.h"

void search_config_init(search_config *c, double far_factor, int resolution, int eps)
{
    const double floor_dist = 2.0 * (resolution + eps);
    for (int level = 0; level < TREE_MAX_LEVEL + 2; level++) {
        if (far_factor <= 0) {
            c->far2[level] = UINT64_MAX;
            continue;
        }
        double d = far_factor * (double)((int64_t)TREE_LEAF_SIDE << level);
        if (d < floor_dist) d = floor_dist;
        const double d2 = d * d;
        c->far2[level] = d2 >= 0x1p63 ? UINT64_MAX : (uint64_t)d2;
    }
}

/* Seeding pays in 3D (callgrind, seed 1, 3D 3e4: 4.295e9 -> 4.199e9 Ir)
 * but not in 2D, where the block search prunes well by itself (2D 1e5:
 * 2.651e9 -> 2.670e9 Ir with it), so there it is off. */
#define SEARCH_SEEDED(dim) ((dim) == 3)

/* Squared distance from p to the integer box [lo, lo + side - 1]. */
static inline __attribute__((always_inline)) uint64_t box_dist2(const int64_t *p, const int64_t *lo,
                                                                int64_t side, int dim)
{
    uint64_t d2 = 0;
    for (int a = 0; a < dim; a++) {
        int64_t d = lo[a] - p[a];
        if (d < 0) {
            d = p[a] - (lo[a] + side - 1);
            if (d < 0) d = 0;
        }
        d2 += (uint64_t)d * (uint64_t)d;
    }
    return d2;
}

#if defined(__SSE2__)
#include <emmintrin.h>

/* Ten slots of one coordinate as 16-bit lanes: lo = slots 0..7, hi = 8..9.
 * The chunk record is laid out so the 16-byte load at `at` stays inside it. */
static inline __attribute__((always_inline)) void load_coord(const uint8_t *chunk, int at,
                                                             int shift, __m128i *lo, __m128i *hi)
{
    __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(chunk + at));
    if (shift == 2) v = _mm_srli_si128(v, 2);
    if (shift == 4) v = _mm_srli_si128(v, 4);
    const __m128i zero = _mm_setzero_si128();
    *lo = _mm_unpacklo_epi8(v, zero);
    *hi = _mm_unpackhi_epi8(v, zero);
}

/* Signed 32-bit minimum in SSE2 (pminsd is SSE4.1). */
static inline __attribute__((always_inline)) __m128i min_epi32(__m128i a, __m128i b)
{
    const __m128i a_gt_b = _mm_cmpgt_epi32(a, b);
    return _mm_or_si128(_mm_and_si128(a_gt_b, b), _mm_andnot_si128(a_gt_b, a));
}

#endif

/* min(best2, the smallest squared distance from q (leaf-relative,
 * |q| <= 2^14) to the first m particles of a chunk). SSE2 (baseline on
 * x86-64): coordinates as 16-bit differences, squares summed by pmaddwd
 * into 32 bits (below 3 (2^14 + 255)^2 < 2^31). In 3D most chunks hold
 * nothing below best2 (3D 3e4: 3 in 4), so the lanes are first compared
 * with it and the minimum is reduced only when one is below (3D 3e4 Ir
 * -3.5%; 2D, whose block scan starts from no bound, keeps the plain
 * reduction). The vector loads also
 * read the unused slots and the link, so while workers append it runs only
 * on full chunks that link to a next one (scan_leaf). */
static inline __attribute__((always_inline)) uint64_t chunk_min_below(const uint8_t *chunk,
                                                                      const int64_t *q,
                                                                      uint32_t m, uint64_t best2,
                                                                      const int dim)
{
#if defined(__SSE2__)
    __m128i xl, xh, yl, yh, zl = _mm_setzero_si128(), zh = _mm_setzero_si128();
    /* 2D record: x[10] y[10] link; 3D: x[10] y[10] z[10] pad[2] link. */
    load_coord(chunk, 0, 0, &xl, &xh);
    load_coord(chunk, dim == 2 ? 8 : 10, dim == 2 ? 2 : 0, &yl, &yh);
    if (dim == 3) load_coord(chunk, 16, 4, &zl, &zh);
    const __m128i qx = _mm_set1_epi16((int16_t)q[0]), qy = _mm_set1_epi16((int16_t)q[1]);
    const __m128i dxl = _mm_sub_epi16(qx, xl), dxh = _mm_sub_epi16(qx, xh);
    const __m128i dyl = _mm_sub_epi16(qy, yl), dyh = _mm_sub_epi16(qy, yh);
    const __m128i p0 = _mm_unpacklo_epi16(dxl, dyl), p1 = _mm_unpackhi_epi16(dxl, dyl);
    const __m128i p2 = _mm_unpacklo_epi16(dxh, dyh);
    __m128i d0 = _mm_madd_epi16(p0, p0), d1 = _mm_madd_epi16(p1, p1), d2 = _mm_madd_epi16(p2, p2);
    if (dim == 3) {
        const __m128i qz = _mm_set1_epi16((int16_t)q[2]), zero = _mm_setzero_si128();
        const __m128i dzl = _mm_sub_epi16(qz, zl), dzh = _mm_sub_epi16(qz, zh);
        const __m128i z0 = _mm_unpacklo_epi16(dzl, zero), z1 = _mm_unpackhi_epi16(dzl, zero);
        const __m128i z2 = _mm_unpacklo_epi16(dzh, zero);
        d0 = _mm_add_epi32(d0, _mm_madd_epi16(z0, z0));
        d1 = _mm_add_epi32(d1, _mm_madd_epi16(z1, z1));
        d2 = _mm_add_epi32(d2, _mm_madd_epi16(z2, z2));
    }
    if (m == TREE_CHUNK_CAP) {
        /* Slots 10 and 11 are not particles: lanes 2, 3 repeat slots 8, 9. */
        d2 = _mm_shuffle_epi32(d2, _MM_SHUFFLE(1, 0, 1, 0));
    } else {
        /* Slots past the fill count become INT32_MAX. */
        const __m128i mm = _mm_set1_epi32((int32_t)m), big = _mm_set1_epi32(INT32_MAX);
        const __m128i k0 = _mm_cmpgt_epi32(mm, _mm_setr_epi32(0, 1, 2, 3));
        const __m128i k1 = _mm_cmpgt_epi32(mm, _mm_setr_epi32(4, 5, 6, 7));
        const __m128i k2 = _mm_cmpgt_epi32(mm, _mm_setr_epi32(8, 9, 10, 11));
        d0 = _mm_or_si128(_mm_and_si128(k0, d0), _mm_andnot_si128(k0, big));
        d1 = _mm_or_si128(_mm_and_si128(k1, d1), _mm_andnot_si128(k1, big));
        d2 = _mm_or_si128(_mm_and_si128(k2, d2), _mm_andnot_si128(k2, big));
    }
    if (dim == 3) {
        const __m128i vb = _mm_set1_epi32(best2 > INT32_MAX ? INT32_MAX : (int32_t)best2);
        const __m128i lt = _mm_or_si128(_mm_or_si128(_mm_cmplt_epi32(d0, vb), _mm_cmplt_epi32(d1, vb)),
                                        _mm_cmplt_epi32(d2, vb));
        if (!_mm_movemask_epi8(lt)) return best2;
    }
    __m128i mn = min_epi32(min_epi32(d0, d1), d2);
    mn = min_epi32(mn, _mm_shuffle_epi32(mn, _MM_SHUFFLE(1, 0, 3, 2)));
    mn = min_epi32(mn, _mm_shuffle_epi32(mn, _MM_SHUFFLE(2, 3, 0, 1)));
    const uint64_t local = (uint32_t)_mm_cvtsi128_si32(mn);
    return dim == 3 || local < best2 ? local : best2; /* 3D: local < best2 is known */
#else
    for (uint32_t j = 0; j < m; j++) {
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = q[a] - (int64_t)chunk[a * TREE_CHUNK_CAP + (int)j];
            d2 += (uint64_t)(d * d);
        }
        best2 = d2 < best2 ? d2 : best2;
    }
    return best2;
#endif
}

#if defined(__SSE2__)
/* Squared lengths of the 10 (+2 padding) 3D differences whose x, y, z
 * components sit in 16-bit lanes (lo: slots 0-7, hi: 8-11), as three vectors
 * of 32-bit lanes (slots 0-3, 4-7, 8-11); shared by the chunk scans below. */
static inline __attribute__((always_inline)) void
sq3_lanes(__m128i dxl, __m128i dxh, __m128i dyl, __m128i dyh, __m128i dzl, __m128i dzh,
          __m128i *d0, __m128i *d1, __m128i *d2)
{
    const __m128i zero = _mm_setzero_si128();
    const __m128i p0 = _mm_unpacklo_epi16(dxl, dyl), p1 = _mm_unpackhi_epi16(dxl, dyl);
    const __m128i p2 = _mm_unpacklo_epi16(dxh, dyh);
    const __m128i z0 = _mm_unpacklo_epi16(dzl, zero), z1 = _mm_unpackhi_epi16(dzl, zero);
    const __m128i z2 = _mm_unpacklo_epi16(dzh, zero);
    *d0 = _mm_add_epi32(_mm_madd_epi16(p0, p0), _mm_madd_epi16(z0, z0));
    *d1 = _mm_add_epi32(_mm_madd_epi16(p1, p1), _mm_madd_epi16(z1, z1));
    *d2 = _mm_add_epi32(_mm_madd_epi16(p2, p2), _mm_madd_epi16(z2, z2));
}

/* The first of the m slots of a 3D chunk at squared distance d2 from q
 * (leaf-relative, |q| <= 2^14), or -1: the lanes of chunk_min_below. */
static inline __attribute__((always_inline)) int chunk_slot_at3(const uint8_t *chunk,
                                                                const int64_t *q, uint32_t m,
                                                                uint32_t d2)
{
    __m128i xl, xh, yl, yh, zl, zh;
    load_coord(chunk, 0, 0, &xl, &xh);
    load_coord(chunk, 10, 0, &yl, &yh);
    load_coord(chunk, 16, 4, &zl, &zh);
    const __m128i qx = _mm_set1_epi16((int16_t)q[0]), qy = _mm_set1_epi16((int16_t)q[1]);
    const __m128i qz = _mm_set1_epi16((int16_t)q[2]);
    __m128i d0, d1, dd;
    sq3_lanes(_mm_sub_epi16(qx, xl), _mm_sub_epi16(qx, xh), _mm_sub_epi16(qy, yl),
              _mm_sub_epi16(qy, yh), _mm_sub_epi16(qz, zl), _mm_sub_epi16(qz, zh), &d0, &d1, &dd);
    const __m128i v = _mm_set1_epi32((int32_t)d2);
    const uint32_t eq = (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(d0, v))) |
                        (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(d1, v))) << 4 |
                        (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(dd, v))) << 8;
    const uint32_t hit = eq & ((1u << m) - 1);
    return hit ? __builtin_ctz(hit) : -1;
}
#endif

#if defined(__SSE2__) && defined(__x86_64__)
/* 2D chunk lanes past a chunk's fill count m: OR-ing 0x7fffffff into a
 * squared distance (< 2^31) makes it 0x7fffffff, above every real one.
 * Row m masks lanes m..11 (lanes 10 and 11 are never particles). */
static const int32_t chunk_pad2[TREE_CHUNK_CAP + 1][12] __attribute__((aligned(16))) = {
#define P_ 0x7fffffff
    {P_, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_}, {0, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_},
    {0, 0, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_},   {0, 0, 0, P_, P_, P_, P_, P_, P_, P_, P_, P_},
    {0, 0, 0, 0, P_, P_, P_, P_, P_, P_, P_, P_},     {0, 0, 0, 0, 0, P_, P_, P_, P_, P_, P_, P_},
    {0, 0, 0, 0, 0, 0, P_, P_, P_, P_, P_, P_},       {0, 0, 0, 0, 0, 0, 0, P_, P_, P_, P_, P_},
    {0, 0, 0, 0, 0, 0, 0, 0, P_, P_, P_, P_},         {0, 0, 0, 0, 0, 0, 0, 0, 0, P_, P_, P_},
    {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, P_, P_}};
/* The same for side 1 of a half record, whose m particles are lanes 5..4+m. */
static const int32_t half1_pad2[TREE_HALF_CAP + 1][12] __attribute__((aligned(16))) = {
    {P_, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_, P_}, {P_, P_, P_, P_, P_, 0, P_, P_, P_, P_, P_, P_},
    {P_, P_, P_, P_, P_, 0, 0, P_, P_, P_, P_, P_},   {P_, P_, P_, P_, P_, 0, 0, 0, P_, P_, P_, P_},
    {P_, P_, P_, P_, P_, 0, 0, 0, 0, P_, P_, P_},     {P_, P_, P_, P_, P_, 0, 0, 0, 0, 0, P_, P_}};
#undef P_

/* 2D while workers append (PDLA). The slots past a chunk's count, and in a
 * half record the other half (another leaf's), may be written while they
 * are read, so a vector scan that reads the whole record reads them too.
 * It reads the record's first 24 bytes (slots, and padding or a link) as
 * three relaxed 64-bit atomics, plain loads on x86-64, and the writer
 * stores slots as relaxed atomic bytes (tree.c leaf_append), so those reads
 * are not data races; their lanes are masked (the pad rows above). Without
 * this the scans fell back to the scalar loop on every leaf's last chunk
 * and on every half: 2 workers from 1e6 to 1e7 spent 1.17-1.21x serial's
 * CPU per jump, 1.07-1.18x with it (runs/pdla-conc21/). rec:
 * the record (8-byte aligned: 24- and 32-byte records in calloc'd
 * segments); v0: bytes 0..15, v1: bytes 10..23 (load_coord's at 0 and at
 * 8 shifted by 2). */
typedef uint64_t __attribute__((may_alias)) search_word;
static inline __attribute__((always_inline)) void load_rec2_shared(const uint8_t *rec, __m128i *v0,
                                                                   __m128i *v1)
{
    const search_word *w = (const search_word *)(const void *)rec;
    const uint64_t w0 = __atomic_load_n(&w[0], __ATOMIC_RELAXED);
    const uint64_t w1 = __atomic_load_n(&w[1], __ATOMIC_RELAXED);
    const uint64_t w2 = __atomic_load_n(&w[2], __ATOMIC_RELAXED);
    *v0 = _mm_set_epi64x((long long)w1, (long long)w0);
    *v1 = _mm_srli_si128(_mm_set_epi64x((long long)w2, (long long)w1), 2);
}

/* min(best2, the squared distances from q (leaf-relative, |q| <= 2^14) to
 * the 2D slots whose x bytes are v0's first ten and y bytes v1's (bytes 0..15
 * and 10..23 of a record), lanes not in use masked by `pad` (a row of
 * chunk_pad2 or half1_pad2). fmin (|q| < 512, the block scan): the minimum
 * in float (squares below 2 x 511^2 < 2^24 are exact there, and minps is
 * one instruction where SSE2's signed 32-bit minimum is four). */
static inline __attribute__((always_inline)) uint64_t lanes_min2(__m128i v0, __m128i v1,
                                                                 const int64_t *q,
                                                                 const int32_t *pad_row,
                                                                 uint64_t best2, const int fmin)
{
    const __m128i zero = _mm_setzero_si128();
    const __m128i xl = _mm_unpacklo_epi8(v0, zero), xh = _mm_unpackhi_epi8(v0, zero);
    const __m128i yl = _mm_unpacklo_epi8(v1, zero), yh = _mm_unpackhi_epi8(v1, zero);
    const __m128i qx = _mm_set1_epi16((int16_t)q[0]), qy = _mm_set1_epi16((int16_t)q[1]);
    const __m128i dxl = _mm_sub_epi16(qx, xl), dxh = _mm_sub_epi16(qx, xh);
    const __m128i dyl = _mm_sub_epi16(qy, yl), dyh = _mm_sub_epi16(qy, yh);
    const __m128i p0 = _mm_unpacklo_epi16(dxl, dyl), p1 = _mm_unpackhi_epi16(dxl, dyl);
    const __m128i p2 = _mm_unpacklo_epi16(dxh, dyh);
    const __m128i *pad = (const __m128i *)(const void *)pad_row;
    const __m128i d0 = _mm_or_si128(_mm_madd_epi16(p0, p0), _mm_load_si128(pad));
    const __m128i d1 = _mm_or_si128(_mm_madd_epi16(p1, p1), _mm_load_si128(pad + 1));
    const __m128i d2 = _mm_or_si128(_mm_madd_epi16(p2, p2), _mm_load_si128(pad + 2));
    uint64_t local;
    if (fmin) {
        __m128 mn = _mm_min_ps(_mm_min_ps(_mm_cvtepi32_ps(d0), _mm_cvtepi32_ps(d1)), _mm_cvtepi32_ps(d2));
        mn = _mm_min_ps(mn, _mm_movehl_ps(mn, mn));
        mn = _mm_min_ss(mn, _mm_shuffle_ps(mn, mn, _MM_SHUFFLE(1, 1, 1, 1)));
        local = (uint64_t)_mm_cvttss_si64(mn);
    } else {
        __m128i mn = min_epi32(min_epi32(d0, d1), d2);
        mn = min_epi32(mn, _mm_shuffle_epi32(mn, _MM_SHUFFLE(1, 0, 3, 2)));
        mn = min_epi32(mn, _mm_shuffle_epi32(mn, _MM_SHUFFLE(2, 3, 0, 1)));
        local = (uint32_t)_mm_cvtsi128_si32(mn);
    }
    return local < best2 ? local : best2;
}

/* lanes_min2 over the m particles of 2D chunk or half c at `chunk`
 * (tree_chunk_at), its record read as load_rec2_shared says. */
static inline __attribute__((always_inline)) uint64_t chunk_min2_shared(const uint8_t *chunk,
                                                                        uint32_t c,
                                                                        const int64_t *q,
                                                                        uint32_t m, uint64_t best2,
                                                                        const int fmin)
{
    const uint32_t side = (c & TREE_HALF_BIT) ? (c & 1) : 0;
    __m128i v0, v1;
    load_rec2_shared(chunk - TREE_HALF_CAP * side, &v0, &v1);
    return lanes_min2(v0, v1, q, side ? half1_pad2[m] : chunk_pad2[m], best2, fmin);
}
#endif

/* Exact scan of one leaf. q = p - leaf corner. The common near case runs in
 * 16/32-bit arithmetic when `small`: |q| <= 2^14 keeps q - x in int16 and
 * dim * (2^14 + 255)^2 < 2^31 (leaf_small). */
static inline __attribute__((always_inline)) uint64_t scan_leaf(const tree *t, uint32_t head,
                                                                const int64_t *q, uint64_t best2,
                                                                int small, int dim, int concurrent,
                                                                search_state *k)
{
    for (uint32_t c = head;;) {
        const uint8_t *chunk = tree_chunk_at_d(t, c, dim);
        const uint32_t link = tree_chunk_link_d(t, c, chunk, dim);
        const uint32_t m = tree_fill_d(c, link, dim);
        k->particle_checks += m;
        /* A chunk that links to a next one is full and never written again,
         * so the vector loads (which read all ten slots and the link) are
         * safe even while workers append; only the last chunk of a leaf may
         * be filling, and then only its first m slots may be read (the
         * scalar loop in 3D). Halves then take the scalar loop too: the
         * other half of their record may be filling (tree_vector_ok). 2D
         * reads those as atomics instead (chunk_min2_shared). */
        const uint64_t before2 = best2;
        if (small && tree_vector_ok(c, link, concurrent)) {
            best2 = chunk_min_below(chunk, q, m, best2, dim);
#if defined(__SSE2__) && defined(__x86_64__)
        } else if (dim == 2 && small) {
            best2 = chunk_min2_shared(chunk, c, q, m, best2, 0);
#endif
        } else {
            for (uint32_t j = 0; j < m; j++) {
                uint64_t d2 = 0;
                for (int a = 0; a < dim; a++) {
                    const int64_t d = q[a] - (int64_t)chunk[a * TREE_CHUNK_CAP + (int)j];
                    d2 += (uint64_t)d * (uint64_t)d;
                }
                if (d2 < best2) best2 = d2;
            }
        }
        if (SEARCH_SEEDED(dim) && best2 < before2) {
            /* Where the bound came from (note_nearest reads the particle). */
            k->arg_chunk = chunk;
            k->arg_ci = c;
            for (int a = 0; a < dim; a++) k->arg_q[a] = q[a];
        }
        if (link <= TREE_CHUNK_CAP) break;
        c = link;
    }
    return best2;
}

/* |q| <= 2^14 on every axis (scan_leaf's `small`) for a leaf whose box is
 * nearer than best2: below (2^14 - 256)^2 that holds without a look (the
 * box is within 2^14 - 256 of p on every axis, and q spans the box). */
#define LEAF_SMALL_BEST2 ((uint64_t)((1 << 14) - 256) * (uint64_t)((1 << 14) - 256))
static inline __attribute__((always_inline)) int leaf_small(const int64_t *q, uint64_t best2,
                                                            const int dim)
{
    if (best2 <= LEAF_SMALL_BEST2) return 1;
    int small = 1;
    for (int a = 0; a < dim; a++)
        if (q[a] < -(1 << 14) || q[a] > (1 << 14)) small = 0;
    return small;
}

/* Children are pushed farthest first (the submasks of the axes where they
 * may lie within the bound, in decreasing order: roughly by the number of
 * axes on which a child differs from the query's own one) so the nearest is
 * popped first. */

/* Node corners fit in 32 bits: the root box is at most [-2^30, 2^30). */
typedef struct stack_entry {
    uint64_t d2;
    int32_t lo[3];
    uint32_t node;
    int32_t level;
} stack_entry;

#define SEARCH_STACK (TREE_MAX_LEVEL * 8 + 16)

/* Top-down branch and bound inside the subtree of one node, seeded with the
 * best bound found so far. A child's squared box distance is the sum over
 * axes of the distance to its lower or upper half, computed once per axis.
 * Longer than the 80-line rule on purpose: the hot branch and bound of
 * every far query, always_inline and kept whole (long-functions.allow). */
static inline __attribute__((always_inline)) uint64_t
subtree_bound(const tree *t, const search_config *c, const int64_t *p, uint32_t node, int level,
              const int64_t *lo, uint64_t d2, uint64_t best2, uint64_t *visits, search_state *k,
              const int dim)
{
    stack_entry stack[SEARCH_STACK];
    stack[0].node = node;
    stack[0].level = level;
    for (int a = 0; a < dim; a++) stack[0].lo[a] = (int32_t)lo[a];
    stack[0].d2 = d2;
    int top = 1;
    while (top > 0) {
        const stack_entry e = stack[--top];
        if (e.d2 >= best2) continue;
        (*visits)++;
        if (e.level == 0) {
            int64_t q[3];
            for (int a = 0; a < dim; a++) q[a] = p[a] - e.lo[a];
            best2 = scan_leaf(t, e.node, q, best2, leaf_small(q, best2, dim), dim, c->concurrent, k);
            continue;
        }
        if (e.d2 > c->far2[e.level]) {
            best2 = e.d2; /* not opened: the box bound stands for the node */
            continue;
        }
        const int64_t half = (int64_t)TREE_LEAF_SIDE << (e.level - 1);
        const uint64_t child_far2 = e.level > 1 ? c->far2[e.level - 1] : UINT64_MAX;
        uint32_t own = 0, near = 0;
        uint64_t half_d2[3][2];
        for (int a = 0; a < dim; a++) {
            /* The distances to the two halves [lo, mid) and [mid, mid +
             * half) from off = p - mid: p's own half (0 when p is in it)
             * and the other one, across mid. */
            const int64_t off = p[a] - (e.lo[a] + half);
            const uint32_t up = off >= 0;
            own |= up << a;
            int64_t d_own = up ? off - half + 1 : -off - half;
            if (d_own < 0) d_own = 0;
            const int64_t d_other = up ? off + 1 : -off;
            half_d2[a][up] = (uint64_t)(d_own * d_own);
            half_d2[a][up ^ 1] = (uint64_t)(d_other * d_other);
            /* The other half on this axis: within the bound, or never (the
             * bound only decreases), so children across it are skipped
             * before their index is loaded. */
            if (half_d2[a][up ^ 1] < best2) near |= 1u << a;
        }
        const _Atomic uint32_t *ch = tree_children_d(t, e.node, dim);
        if (e.level == 1) {
            /* Leaves: scanned at once, nearest first (roughly: the
             * submasks in increasing order), as the stack would pop them
             * (each pushed leaf would be popped before anything below it,
             * and re-tested against the bound then). */
            uint32_t differ = 0; /* the submasks of near, in increasing order */
            do {
                const uint32_t kidx = own ^ differ;
                differ = (differ - near) & near;
                const uint32_t child = tree_child(ch, kidx);
                if (!child) continue;
                uint64_t cd2 = 0;
                for (int a = 0; a < dim; a++) cd2 += half_d2[a][(kidx >> a) & 1];
                if (cd2 >= best2) continue;
                (*visits)++;
                int64_t q[3];
                for (int a = 0; a < dim; a++)
                    q[a] = p[a] - (e.lo[a] + (int64_t)((kidx >> a) & 1) * half);
                best2 = scan_leaf(t, child, q, best2, leaf_small(q, best2, dim), dim, c->concurrent,
                                  k);
            } while (differ);
            continue;
        }
        /* The submasks of near, in decreasing order (farthest first). */
        for (uint32_t next = near, more = 1; more;) {
            const uint32_t differ = next;
            more = differ != 0;
            next = (differ - 1) & near;
            const uint32_t kidx = own ^ differ;
            const uint32_t child = tree_child(ch, kidx);
            if (!child) continue;
            uint64_t cd2 = 0;
            for (int a = 0; a < dim; a++) cd2 += half_d2[a][(kidx >> a) & 1];
            if (cd2 >= best2) continue;
            if (cd2 > child_far2) {
                best2 = cd2; /* a far child stands for itself without a push */
                continue;
            }
            stack_entry *s = &stack[top++];
            for (int a = 0; a < dim; a++) s->lo[a] = (int32_t)(e.lo[a] + ((kidx >> a) & 1) * half);
            s->d2 = cd2;
            s->node = child;
            s->level = e.level - 1;
        }
    }
    return best2;
}

/* Squared distance from p (inside the box [lo, lo + side - 1]) to the
 * nearest integer point outside the box: every particle outside is at least
 * this far away. */
static inline __attribute__((always_inline)) uint64_t inside_margin2(const int64_t *p,
                                                                     const int64_t *lo,
                                                                     int64_t side, int dim)
{
    int64_t m = INT64_MAX;
    for (int a = 0; a < dim; a++) {
        const int64_t below = p[a] - lo[a] + 1, above = lo[a] + side - p[a];
        if (below < m) m = below;
        if (above < m) m = above;
    }
    return (uint64_t)m * (uint64_t)m;
}

/* A seed for a search's bound: one more than an upper bound on the squared
 * distance from p to the nearest particle, from the walker's last exact
 * answer (a particle at distance a from ub_p is within a + b of p, b =
 * |p - ub_p|, and (a + b)^2 <= 2 a^2 + 2 b^2), or UINT64_MAX when there is
 * none. Seeded with it, a search gives the same answer: the answer never
 * exceeds the true distance, so it stays below the seed, and the element
 * that gives it is found as before (a box is pruned only when nothing in it
 * can go below the current bound). */
static inline __attribute__((always_inline)) uint64_t seed_bound2(const search_state *k,
                                                                  const int64_t *p, const int dim)
{
    if (k->nq_valid) {
        /* The squared distance to a particle: the answer never exceeds
         * it, and when nothing lies nearer it is the answer itself. */
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = p[a] - k->nq[a];
            if (d < -(INT64_C(1) << 30) || d > (INT64_C(1) << 30)) return UINT64_MAX;
            d2 += (uint64_t)(d * d);
        }
        return d2;
    }
    if (k->ub_d2 >= (UINT64_C(1) << 60)) return UINT64_MAX;
    uint64_t b2 = 0;
    for (int a = 0; a < dim; a++) {
        const int64_t d = p[a] - k->ub_p[a];
        b2 += (uint64_t)(d * d);
    }
    if (b2 >= (UINT64_C(1) << 60)) return UINT64_MAX;
    return 2 * (k->ub_d2 + b2) + 1;
}

/* Remember an exact answer (the squared distance from p to a particle). */
static inline __attribute__((always_inline)) void note_exact(search_state *k, const int64_t *p,
                                                             uint64_t d2, const int dim)
{
    k->ub_d2 = d2;
    for (int a = 0; a < dim; a++) k->ub_p[a] = p[a];
}

/* After a search whose exact answer d2 is below its seed: the particle at
 * that distance, from the chunk where the bound last fell (scan_leaf), is
 * the walker's nearest (nq). When the answer equals the seed, nq is kept:
 * the seed was its distance. */
static inline __attribute__((always_inline)) void note_nearest(search_state *k, const tree *t,
                                                               const int64_t *p, uint64_t d2,
                                                               int concurrent, const int dim)
{
    k->nq_valid = 0;
    const uint8_t *chunk = k->arg_chunk;
    if (!chunk) return;
    const uint32_t link = tree_chunk_link_d(t, k->arg_ci, chunk, dim);
    const uint32_t m = tree_fill_d(k->arg_ci, link, dim);
#if defined(__SSE2__)
    if (dim == 3 && leaf_small(k->arg_q, d2, dim) && tree_vector_ok(k->arg_ci, link, concurrent)) {
        /* The slot whose distance is d2, from the scan's own lanes (the
         * vector loads read every slot: while workers append, only on a
         * full chunk, as in scan_leaf). */
        const int j = chunk_slot_at3(chunk, k->arg_q, m, (uint32_t)d2);
        if (j < 0) return;
        for (int a = 0; a < dim; a++)
            k->nq[a] = p[a] - k->arg_q[a] + (int64_t)chunk[a * TREE_CHUNK_CAP + j];
        k->nq_valid = 1;
        return;
    }
#endif
    for (uint32_t j = 0; j < m; j++) {
        uint64_t e2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = k->arg_q[a] - (int64_t)chunk[a * TREE_CHUNK_CAP + (int)j];
            e2 += (uint64_t)(d * d);
        }
        if (e2 != d2) continue;
        for (int a = 0; a < dim; a++)
            k->nq[a] = p[a] - k->arg_q[a] + (int64_t)chunk[a * TREE_CHUNK_CAP + (int)j];
        k->nq_valid = 1;
        return;
    }
}

/* The lowest level of the walker's cached path whose node contains p (the
 * descent restarts there), or the root's level when the cache is empty, was
 * made under another root, or no cached node contains p. Re-keys the cache
 * to the current root. */
static inline __attribute__((always_inline)) int cached_start_level(const search_state *k,
                                                                    const tree_root root,
                                                                    const int64_t *p,
                                                                    const int dim)
{
    int level = root.level;
    if (dim == 3 && k->root == root.node && k->root_level == root.level) {
        /* Below the root every node is aligned to its side, 256 << level,
         * so p lies in the cached node of level L >= depth exactly when it
         * agrees with the deepest cached corner on the bits from 8 + L up:
         * the level is read from the highest bit where they differ. */
        uint64_t x = 0;
        for (int a = 0; a < dim; a++) x |= (uint64_t)(p[a] ^ k->lo[k->depth][a]);
        const int differ = x ? 64 - __builtin_clzll(x) - TREE_LEAF_BITS : 0;
        level = differ > k->depth ? differ : k->depth;
        return level < root.level ? level : root.level;
    }
    if (k->root == root.node && k->root_level == root.level) {
        for (level = k->depth; level < root.level; level++) {
            const int64_t side = (int64_t)TREE_LEAF_SIDE << level;
            int inside = 1;
            for (int a = 0; a < dim; a++)
                inside &= (p[a] >= k->lo[level][a]) & (p[a] < k->lo[level][a] + side);
            if (inside) break;
        }
    }
    return level;
}

void search_path_start(const search_state *k, const tree *t, const int64_t *p, tree_start *out)
{
    out->node = 0;
    const tree_root root = tree_root_get(t);
    if (k->root != root.node || k->root_level != root.level) return;
    const int level = t->dim == 2 ? cached_start_level(k, root, p, 2)
                                  : cached_start_level(k, root, p, 3);
    if (level >= root.level) return;
    out->node = k->node[level];
    out->level = level;
    for (int a = 0; a < 3; a++) out->lo[a] = a < t->dim ? k->lo[level][a] : 0;
}

/* Descent of lower_bound_dim: from node (at level, corner lo) along p's own
 * path to the deepest existing node, recording each node, its own child and
 * its corner in the cache; scans p's own leaf when it exists. Returns the
 * level reached (the cache's new depth); *best2 holds the leaf's bound. */
static inline __attribute__((always_inline)) int descend_own_path(const tree *t,
                                                                  const search_config *c,
                                                                  const int64_t *p, uint32_t node,
                                                                  int level, int64_t *lo,
                                                                  uint64_t *best2,
                                                                  uint64_t *visits,
                                                                  search_state *k, const int dim)
{
    for (;;) {
        const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
        uint32_t own = 0;
        for (int a = 0; a < dim; a++)
            if (p[a] >= lo[a] + half) own |= 1u << a;
        k->node[level] = node;
        k->own[level] = own;
        for (int a = 0; a < dim; a++) k->lo[level][a] = lo[a];
        const uint32_t child = tree_child(tree_children_d(t, node, dim), own);
        (*visits)++;
        if (!child) return level;
        for (int a = 0; a < dim; a++) lo[a] += (int64_t)((own >> a) & 1) * half;
        if (level == 1) {
            int64_t q[3];
            for (int a = 0; a < dim; a++) q[a] = p[a] - lo[a];
            *best2 = scan_leaf(t, child, q, *best2, 1, dim, c->concurrent, k); /* 0 <= q < 256 */
            (*visits)++;
            return level;
        }
        node = child;
        level--;
    }
}

/* One step of the climb at `level` of the cached path: searches the
 * siblings of p's own child that can come within the bound. Returns the
 * new bound, or sets *done when the ball of the bound already lies inside
 * the own child's box (nothing outside it can lower the bound). */
static inline __attribute__((always_inline)) uint64_t climb_level(const tree *t,
                                                                  const search_config *c,
                                                                  const int64_t *p, int level,
                                                                  uint64_t best2, int *done,
                                                                  uint64_t *visits,
                                                                  search_state *k, const int dim)
{
    const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
    const int64_t *plo = k->lo[level];
    const uint32_t pown = k->own[level];
    int64_t own_lo[3];
    if (dim == 3 && level > k->depth) {
        /* The own child is the cached node one level down. */
        for (int a = 0; a < dim; a++) own_lo[a] = k->lo[level - 1][a];
    } else {
        for (int a = 0; a < dim; a++) own_lo[a] = plo[a] + (int64_t)((pown >> a) & 1) * half;
    }
    if (inside_margin2(p, own_lo, half, dim) >= best2) {
        *done = 1;
        return best2;
    }
    /* p lies in the own half on every axis: a sibling's distance comes
     * only from the axes where it lies in the other half. */
    uint64_t other_d2[3];
    uint32_t near = 0;
    for (int a = 0; a < dim; a++) {
        /* Across mid: p in the upper half is p - mid + 1 from the lower. */
        const int64_t off = p[a] - (plo[a] + half);
        const int64_t d = ((pown >> a) & 1) ? off + 1 : -off;
        other_d2[a] = (uint64_t)(d * d);
        if (other_d2[a] < best2) near |= 1u << a;
    }
    /* Only siblings that differ from the own child on near axes alone
     * can come within the bound (it only decreases below), so only
     * those are enumerated (submasks of `near`), without loading the
     * others' indices. The order does not change the answer (see the
     * top of the file), only the work: in 3D the submasks go in
     * increasing order, roughly nearest first (faces before the corner),
     * so the bound falls sooner (3D 3e4, callgrind: -2.2% Ir against the
     * decreasing order 2D keeps). */
    const _Atomic uint32_t *ch = tree_children_d(t, k->node[level], dim);
    for (uint32_t differ = dim == 3 ? (0u - near) & near : near; differ;
         differ = dim == 3 ? (differ - near) & near : (differ - 1) & near) {
        const uint32_t kidx = differ ^ pown;
        const uint32_t child = tree_child(ch, kidx);
        if (!child) continue;
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++)
            if ((differ >> a) & 1) d2 += other_d2[a];
        if (d2 >= best2) continue;
        int64_t clo[3];
        for (int a = 0; a < dim; a++) clo[a] = plo[a] + (int64_t)((kidx >> a) & 1) * half;
        best2 = subtree_bound(t, c, p, child, level - 1, clo, d2, best2, visits, k, dim);
    }
    return best2;
}

/* Bottom-up search: descend once along the query's own path to the deepest
 * existing node, search there, then climb, searching the siblings of each
 * node on the path, until the ball of the current bound lies inside the
 * node reached. Successive walker positions are close to the cluster, so
 * the climb usually stops a level or two above the leaf and the upper levels
 * cost one child lookup each. */
static inline __attribute__((always_inline)) uint64_t
lower_bound_dim(const tree *t, const search_config *c, const int64_t *p, uint64_t cap2,
                search_state *k, const int dim)
{
    if (tree_count(t) == 0) return UINT64_MAX;
    const tree_root root = tree_root_get(t);
    const int64_t root_half = tree_root_half(root.level);
    uint64_t visits = 0;
    int64_t lo[3];
    for (int a = 0; a < dim; a++) lo[a] = -root_half;
    const uint64_t root_d2 = box_dist2(p, lo, 2 * root_half, dim);
    const uint64_t seed2 = SEARCH_SEEDED(dim) ? seed_bound2(k, p, dim) : UINT64_MAX;
    uint64_t best2 = seed2 < cap2 ? seed2 : cap2;
    if (SEARCH_SEEDED(dim)) k->arg_chunk = NULL;
    if (root_d2 > 0) {
        /* Outside the root box: plain top-down search. */
        best2 = subtree_bound(t, c, p, root.node, root.level, lo, root_d2, best2, &visits, k, dim);
        k->node_visits += visits;
        return best2;
    }
    /* From the lowest node of the previous query's path that contains p. */
    int level = cached_start_level(k, root, p, dim);
    k->root = root.node;
    k->root_level = root.level;
    const uint32_t node = level == root.level ? root.node : k->node[level];
    if (level != root.level)
        for (int a = 0; a < dim; a++) lo[a] = k->lo[level][a];
    level = descend_own_path(t, c, p, node, level, lo, &best2, &visits, k, dim);
    k->depth = level;
    for (int done = 0;; level++) {
        best2 = climb_level(t, c, p, level, best2, &done, &visits, k, dim);
        if (done || level == root.level) break;
    }
    k->node_visits += visits;
    if (SEARCH_SEEDED(dim) && best2 < cap2 && best2 < c->far2[0]) {
        note_exact(k, p, best2, dim);
        if (best2 < seed2) note_nearest(k, t, p, best2, c->concurrent, dim);
    }
    return best2;
}

uint64_t search_lower_bound2(const tree *t, const search_config *c, const int64_t *p,
                             uint64_t cap2, search_state *k)
{
    return t->dim == 2 ? lower_bound_dim(t, c, p, cap2, k, 2)
                       : lower_bound_dim(t, c, p, cap2, k, 3);
}

/* Offsets of the 3^dim block, own leaf first (it usually holds the nearest
 * particle, so the rest is pruned by box distance), then faces, edges,
 * corners. Offset o is coded as its index sum (o_a + 1) 3^a. */
static const uint8_t block_order2[9] = {4, 1, 3, 5, 7, 0, 2, 6, 8};
static const uint8_t block_order3[27] = {13, 4,  10, 12, 14, 16, 22, 1,  3,  5,  7,  9,  11, 15,
                                         17, 19, 21, 23, 25, 0,  2,  6,  8,  18, 20, 24, 26};
/* Offset o's component on axis a: (o / 3^a) % 3 - 1. */
static const int8_t block_off[27][3] = {
    {-1, -1, -1}, {0, -1, -1}, {1, -1, -1}, {-1, 0, -1}, {0, 0, -1}, {1, 0, -1}, {-1, 1, -1},
    {0, 1, -1},   {1, 1, -1},  {-1, -1, 0}, {0, -1, 0},  {1, -1, 0}, {-1, 0, 0}, {0, 0, 0},
    {1, 0, 0},    {-1, 1, 0},  {0, 1, 0},   {1, 1, 0},   {-1, -1, 1}, {0, -1, 1}, {1, -1, 1},
    {-1, 0, 1},   {0, 0, 1},   {1, 0, 1},   {-1, 1, 1},  {0, 1, 1},  {1, 1, 1}};

/* tree_find_leaf, but descending from the lowest node of the cached path
 * (search_state) that contains p, and leaving p's path in the cache as
 * lower_bound_dim expects it. */
static inline __attribute__((always_inline)) uint32_t find_leaf_cached(const tree *t,
                                                                       const int64_t *p,
                                                                       search_state *k,
                                                                       const int dim)
{
    const tree_root root = tree_root_get(t);
    const int64_t root_half = tree_root_half(root.level);
    for (int a = 0; a < dim; a++)
        if (p[a] < -root_half || p[a] >= root_half) return 0;
    int level = cached_start_level(k, root, p, dim);
    k->root = root.node;
    k->root_level = root.level;
    uint32_t node = level == root.level ? root.node : k->node[level];
    int64_t lo[3];
    for (int a = 0; a < dim; a++) lo[a] = level == root.level ? -root_half : k->lo[level][a];
    for (;;) {
        const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
        uint32_t own = 0;
        for (int a = 0; a < dim; a++)
            if (p[a] >= lo[a] + half) own |= 1u << a;
        k->node[level] = node;
        k->own[level] = own;
        for (int a = 0; a < dim; a++) k->lo[level][a] = lo[a];
        const uint32_t child = tree_child(tree_children_d(t, node, dim), own);
        if (!child || level == 1) {
            k->depth = level;
            return child;
        }
        for (int a = 0; a < dim; a++) lo[a] += (int64_t)((own >> a) & 1) * half;
        node = child;
        level--;
    }
}

/* Cached heads that are not chunk indices (1..10 never are). */
#define BLK_UNKNOWN 0u
#define BLK_EMPTY 1u

/* ---- the walker's neighbour list ---------------------------------------
 *
 * Near the cluster a walker makes many short jumps in one small region
 * (walk-on-spheres slows as it nears the absorbing surface), and each tree
 * query there pays a descent, sibling boxes and scattered chunks. The list
 * copies every particle within nb_r of a centre as 16-bit offsets in three
 * arrays sorted by distance from the centre; a query at distance delta
 * from the centre scans them in that order with SSE2 until a block's
 * distance lower bound, less delta, reaches the best found. Every particle
 * not in the list is at least nb_r - delta away, so the answer is exact
 * when it is below (nb_r - delta)^2; otherwise the tree answers. */

/* When a list is made: only if the walker's last answer is below a quarter
 * of the largest radius (a larger one means long jumps, which would leave
 * the list at once), and then with a radius of 2.5 times that answer, at
 * least 64 units: measured on 3D 3e4 (callgrind, seed 1) against 4, 5 and 6;
 * 3, 4 and 2.5; 40, 48, 64 and 96, the best of those combinations. */
#define NB_SKIP_DIV 4
#define NB_RADIUS_MUL 2.5
#define NB_RADIUS_MIN 64

#if defined(__SSE2__)
/* nb_make's append of one 3D chunk: the first m particles, as offsets
 * from p (q = p - the leaf's corner, |q| < 2 SEARCH_NB_RADIUS + 256, so
 * offsets fit in int16 and squared distances in int32), those nearer than
 * r2 appended in slot order (the scalar loop's order, so the same list),
 * with their buckets. Returns the new count. */
static inline __attribute__((always_inline)) uint32_t
nb_append_chunk3(const uint8_t *chunk, const int64_t *q, uint32_t m, uint32_t r2, int shift,
                 int16_t *tx, int16_t *ty, int16_t *tz, uint8_t *tb, uint32_t n)
{
    __m128i xl, xh, yl, yh, zl, zh;
    load_coord(chunk, 0, 0, &xl, &xh);
    load_coord(chunk, 10, 0, &yl, &yh);
    load_coord(chunk, 16, 4, &zl, &zh);
    const __m128i qx = _mm_set1_epi16((int16_t)q[0]), qy = _mm_set1_epi16((int16_t)q[1]);
    const __m128i qz = _mm_set1_epi16((int16_t)q[2]);
    int16_t ox[16], oy[16], oz[16];
    int32_t od[12];
    const __m128i dxl = _mm_sub_epi16(xl, qx), dxh = _mm_sub_epi16(xh, qx);
    const __m128i dyl = _mm_sub_epi16(yl, qy), dyh = _mm_sub_epi16(yh, qy);
    const __m128i dzl = _mm_sub_epi16(zl, qz), dzh = _mm_sub_epi16(zh, qz);
    _mm_storeu_si128((__m128i *)(void *)ox, dxl);
    _mm_storeu_si128((__m128i *)(void *)(ox + 8), dxh);
    _mm_storeu_si128((__m128i *)(void *)oy, dyl);
    _mm_storeu_si128((__m128i *)(void *)(oy + 8), dyh);
    _mm_storeu_si128((__m128i *)(void *)oz, dzl);
    _mm_storeu_si128((__m128i *)(void *)(oz + 8), dzh);
    __m128i d0, d1, d2;
    sq3_lanes(dxl, dxh, dyl, dyh, dzl, dzh, &d0, &d1, &d2);
    _mm_storeu_si128((__m128i *)(void *)od, d0);
    _mm_storeu_si128((__m128i *)(void *)(od + 4), d1);
    _mm_storeu_si128((__m128i *)(void *)(od + 8), d2);
    const __m128i vr = _mm_set1_epi32((int32_t)r2);
    uint32_t in = (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(d0, vr))) |
                  (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(d1, vr))) << 4 |
                  (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(d2, vr))) << 8;
    in &= (1u << m) - 1;
    while (in) {
        const int j = __builtin_ctz(in);
        in &= in - 1;
        tx[n] = ox[j];
        ty[n] = oy[j];
        tz[n] = oz[j];
        tb[n] = (uint8_t)((uint32_t)od[j] >> shift);
        n++;
    }
    return n;
}
#endif

/* Make the list around p with radius r <= SEARCH_NB_RADIUS from the leaves
 * (found from the cached path) that the ball meets; 0 (list invalid) if
 * more than SEARCH_NB_MAX particles lie that near. Longer than the 80-line
 * rule on purpose: built in one pass inside the jump loop and always_inline,
 * split it and the 3D jump loses its registers (long-functions.allow). */
static inline __attribute__((always_inline)) int nb_make(const tree *t, const int64_t *p,
                                                         int32_t r, search_state *k,
                                                         const int dim)
{
    int16_t tx[SEARCH_NB_MAX + 16], ty[SEARCH_NB_MAX + 16], tz[SEARCH_NB_MAX + 16];
    uint8_t tb[SEARCH_NB_MAX + 16];
    const uint32_t r2 = (uint32_t)(r * r);
    int shift = 0;
    while ((r2 - 1) >> shift >= SEARCH_NB_BUCKETS) shift++;
    k->nb_made++;
    k->nb_valid = 0;
    int64_t first[3] = {0, 0, 0};
    int span[3] = {1, 1, 1};
    for (int a = 0; a < dim; a++) {
        first[a] = (p[a] - r + 1) & ~(int64_t)(TREE_LEAF_SIDE - 1);
        span[a] = (int)((((p[a] + r - 1) & ~(int64_t)(TREE_LEAF_SIDE - 1)) - first[a]) / TREE_LEAF_SIDE + 1);
    }
    uint32_t n = 0;
    for (int iz = 0; iz < span[2]; iz++)
        for (int iy = 0; iy < span[1]; iy++)
            for (int ix = 0; ix < span[0]; ix++) {
                const int64_t lo[3] = {first[0] + ix * TREE_LEAF_SIDE, first[1] + iy * TREE_LEAF_SIDE,
                                       first[2] + iz * TREE_LEAF_SIDE};
                if (box_dist2(p, lo, TREE_LEAF_SIDE, dim) >= r2) continue;
                const uint32_t head = find_leaf_cached(t, lo, k, dim);
                if (!head) continue;
                int64_t q[3] = {0, 0, 0};
                for (int a = 0; a < dim; a++) q[a] = p[a] - lo[a];
                for (uint32_t ci = head;;) {
                    const uint8_t *chunk = tree_chunk_at_d(t, ci, dim);
                    const uint32_t link = tree_chunk_link_d(t, ci, chunk, dim);
                    const uint32_t m = tree_fill_d(ci, link, dim);
#if defined(__SSE2__)
                    if (dim == 3) {
                        n = nb_append_chunk3(chunk, q, m, r2, shift, tx, ty, tz, tb, n);
                        if (n > SEARCH_NB_MAX) return 0;
                        if (link <= TREE_CHUNK_CAP) break;
                        ci = link;
                        continue;
                    }
#endif
                    for (uint32_t j = 0; j < m; j++) {
                        int32_t x[3] = {0, 0, 0};
                        uint32_t d2 = 0;
                        for (int a = 0; a < dim; a++) {
                            x[a] = (int32_t)chunk[a * TREE_CHUNK_CAP + (int)j] - (int32_t)q[a];
                            d2 += (uint32_t)(x[a] * x[a]);
                        }
                        /* Branch-free append: a particle outside the ball
                         * is written and not counted. */
                        tx[n] = (int16_t)x[0];
                        ty[n] = (int16_t)x[1];
                        tz[n] = (int16_t)x[2];
                        tb[n] = (uint8_t)(d2 >> shift);
                        n += d2 < r2;
                    }
                    if (n > SEARCH_NB_MAX) return 0;
                    if (link <= TREE_CHUNK_CAP) break;
                    ci = link;
                }
            }
    /* Counting sort by bucket (distance squared >> shift). */
    uint32_t start[SEARCH_NB_BUCKETS];
    memset(start, 0, sizeof start);
    for (uint32_t i = 0; i < n; i++) start[tb[i]]++;
    for (uint32_t b = 0, sum = 0; b < SEARCH_NB_BUCKETS; b++) {
        const uint32_t cnt = start[b];
        start[b] = sum;
        sum += cnt;
    }
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t at = start[tb[i]]++;
        k->nb_x[at] = tx[i];
        k->nb_y[at] = ty[i];
        k->nb_z[at] = tz[i];
        /* The first of each block of eight is its nearest bucket: a
         * particle in bucket b is at least sqrt(b << shift) away. */
        if ((at & 7) == 0) k->nb_rlo[at >> 3] = (int32_t)sqrt((double)((uint32_t)tb[i] << shift));
    }
    const uint32_t npad = (n + 7) & ~7u;
    for (uint32_t i = n; i < npad; i++) {
        /* Far beyond any query (|offset| < 2 r): differences stay in
         * int16 and sums of three squares in int32. */
        k->nb_x[i] = 16383;
        k->nb_y[i] = 16383;
        k->nb_z[i] = 16383;
    }
    k->nb_n = npad;
    k->nb_r = r;
    for (int a = 0; a < 3; a++) k->nb_c[a] = a < dim ? p[a] : 0;
    k->nb_count = tree_count(t);
    k->nb_valid = 1;
    return 1;
}

static inline __attribute__((always_inline)) uint64_t near_dim(const tree *t,
                                                               const search_config *c,
                                                               const int64_t *p, search_state *k,
                                                               const int dim)
{
    int64_t q[3] = {0, 0, 0};
    uint64_t delta2 = UINT64_MAX;
    if (k->nb_valid && k->nb_count == tree_count(t)) {
        delta2 = 0;
        for (int a = 0; a < dim; a++) {
            q[a] = p[a] - k->nb_c[a];
            delta2 += (uint64_t)(q[a] * q[a]);
        }
    }
    if (delta2 > (uint64_t)k->nb_r * (uint64_t)k->nb_r / 4) {
        /* A new list around p, sized for the walker's next few jumps. */
        int64_t r = SEARCH_NB_RADIUS;
        if ((uint64_t)r * (uint64_t)r > c->far2[0]) r = (int64_t)sqrt((double)c->far2[0]);
        if (NB_SKIP_DIV * NB_SKIP_DIV * k->nb_last2 > (uint64_t)r * (uint64_t)r) return UINT64_MAX;
        const int64_t want = (int64_t)(NB_RADIUS_MUL * sqrt((double)k->nb_last2));
        if (want < r) r = want < NB_RADIUS_MIN ? NB_RADIUS_MIN : want;
        if (!nb_make(t, p, (int32_t)r, k, dim)) {
            k->nb_misses++;
            return UINT64_MAX;
        }
        for (int a = 0; a < 3; a++) q[a] = 0;
        delta2 = 0;
    }
    /* delta_hi >= |q|: a particle of block j is at least nb_rlo[j] -
     * delta_hi from p, one outside the list nb_r - delta_hi. */
    const int32_t delta_hi = (int32_t)sqrt((double)delta2) + 1;
    const int32_t m = k->nb_r - delta_hi;
    uint32_t best = UINT32_MAX;
    const uint32_t nblk = k->nb_n / 8;
#if defined(__SSE2__)
    const __m128i qx = _mm_set1_epi16((int16_t)q[0]), qy = _mm_set1_epi16((int16_t)q[1]);
    const __m128i qz = _mm_set1_epi16((int16_t)q[2]), zero = _mm_setzero_si128();
    __m128i vbest = _mm_set1_epi32(INT32_MAX);
    for (uint32_t j = 0; j < nblk; j++) {
        const int32_t lb = k->nb_rlo[j] - delta_hi;
        if (lb > 0 && (uint32_t)(lb * lb) >= best) break;
        const __m128i dx = _mm_sub_epi16(qx, _mm_loadu_si128((const __m128i *)(const void *)&k->nb_x[8 * j]));
        const __m128i dy = _mm_sub_epi16(qy, _mm_loadu_si128((const __m128i *)(const void *)&k->nb_y[8 * j]));
        const __m128i xy0 = _mm_unpacklo_epi16(dx, dy), xy1 = _mm_unpackhi_epi16(dx, dy);
        __m128i d0 = _mm_madd_epi16(xy0, xy0), d1 = _mm_madd_epi16(xy1, xy1);
        if (dim == 3) {
            const __m128i dz = _mm_sub_epi16(qz, _mm_loadu_si128((const __m128i *)(const void *)&k->nb_z[8 * j]));
            const __m128i z0 = _mm_unpacklo_epi16(dz, zero), z1 = _mm_unpackhi_epi16(dz, zero);
            d0 = _mm_add_epi32(d0, _mm_madd_epi16(z0, z0));
            d1 = _mm_add_epi32(d1, _mm_madd_epi16(z1, z1));
        }
        vbest = min_epi32(vbest, min_epi32(d0, d1));
        __m128i mn = min_epi32(vbest, _mm_shuffle_epi32(vbest, _MM_SHUFFLE(1, 0, 3, 2)));
        mn = min_epi32(mn, _mm_shuffle_epi32(mn, _MM_SHUFFLE(2, 3, 0, 1)));
        best = (uint32_t)_mm_cvtsi128_si32(mn);
    }
#else
    for (uint32_t j = 0; j < nblk; j++) {
        const int32_t lb = k->nb_rlo[j] - delta_hi;
        if (lb > 0 && (uint32_t)(lb * lb) >= best) break;
        for (uint32_t i = 8 * j; i < 8 * j + 8; i++) {
            const int32_t dx = (int32_t)q[0] - k->nb_x[i], dy = (int32_t)q[1] - k->nb_y[i];
            const int32_t dz = dim == 3 ? (int32_t)q[2] - k->nb_z[i] : 0;
            const uint32_t d2 = (uint32_t)(dx * dx + dy * dy + dz * dz);
            if (d2 < best) best = d2;
        }
    }
#endif
    if (m > 0 && (uint64_t)best < (uint64_t)m * (uint64_t)m) {
        k->nb_hits++;
        if (SEARCH_SEEDED(dim)) {
            note_exact(k, p, best, dim);
            k->nq_valid = 0; /* the list does not say which particle */
        }
        return best;
    }
    k->nb_misses++;
    return UINT64_MAX;
}

uint64_t search_near2(const tree *t, const search_config *c, const int64_t *p, search_state *k)
{
    return t->dim == 2 ? near_dim(t, c, p, k, 2) : near_dim(t, c, p, k, 3);
}

/* Re-centre the block cache on the leaf with low corner lo, keeping what is
 * known of the leaves both blocks share. A head is a leaf's first chunk,
 * BLK_UNKNOWN or BLK_EMPTY. */
static inline __attribute__((always_inline)) void blk_recentre(search_state *k, const tree *t,
                                                               const int64_t *lo, const int dim)
{
    const int n = dim == 2 ? 9 : 27;
    /* A serial insertion that moved a leaf's first chunk (tree.h: a first
     * half copied out) makes every cached head suspect. */
    if (k->blk_moves != t->head_moves) {
        k->blk_valid = 0;
        k->blk_moves = t->head_moves;
    }
    int same = k->blk_valid;
    for (int a = 0; a < dim; a++) same &= k->blk_c[a] == lo[a];
    if (same) return;
    uint32_t nh[27];
    for (int o = 0; o < n; o++) nh[o] = BLK_UNKNOWN;
    if (k->blk_valid) {
        int64_t d[3];
        int near = 1;
        for (int a = 0; a < dim; a++) {
            d[a] = (lo[a] - k->blk_c[a]) / TREE_LEAF_SIDE;
            near &= d[a] >= -2 && d[a] <= 2;
        }
        if (near && dim == 2) {
            /* Unrolled: the offsets become constants (2D 1e5: ~50 Ir less
             * per re-centring). */
#pragma GCC unroll 9
            for (int o = 0; o < 9; o++) {
                const int64_t sx = block_off[o][0] + d[0], sy = block_off[o][1] + d[1];
                if (sx >= -1 && sx <= 1 && sy >= -1 && sy <= 1)
                    nh[o] = k->blk_head[(int)(sx + 1) + 3 * (int)(sy + 1)];
            }
        } else if (near)
            for (int o = 0; o < n; o++) {
                int src = 0, ok = 1, mul = 1;
                for (int a = 0; a < dim; a++) {
                    const int64_t so = block_off[o][a] + d[a];
                    ok &= so >= -1 && so <= 1;
                    src += (int)(so + 1) * mul;
                    mul *= 3;
                }
                if (ok) nh[o] = k->blk_head[src];
            }
    }
    for (int o = 0; o < n; o++) k->blk_head[o] = nh[o];
    for (int a = 0; a < dim; a++) k->blk_c[a] = lo[a];
    k->blk_valid = 1;
}

/* The first chunk of block leaf o (corner nlo, map cell nc), looked up when
 * the cache does not know it: BLK_EMPTY when the map's fine cell is not
 * marked; BLK_UNKNOWN (look again next time) when it is marked but the leaf
 * is not in the tree yet, as a worker is between the two (the map goes
 * first): the particle counts as not there yet, as for any query that
 * precedes an insertion. */
static inline __attribute__((always_inline)) uint32_t blk_lookup(const tree *t,
                                                                 const distmap_level *L,
                                                                 const int64_t *cc, uint32_t occ,
                                                                 int o, const int64_t *nlo,
                                                                 search_state *k, const int dim,
                                                                 const int bits)
{
    if (bits) { /* occ: the block's leaf bits, bit o for leaf o */
        if (!((occ >> o) & 1)) return k->blk_head[o] = BLK_EMPTY;
    } else {
        int64_t nc[3];
        for (int a = 0; a < dim; a++) nc[a] = cc[a] + block_off[o][a];
        if (distmap_level_value_k(L, nc, dim, 1) != 0) return k->blk_head[o] = BLK_EMPTY;
    }
    const uint32_t head = find_leaf_cached(t, nlo, k, dim);
    /* Leaf bits: the cache key is the tree's count (block_bits2). */
    return k->blk_head[o] = head ? head : bits ? BLK_EMPTY : BLK_UNKNOWN;
}

#if defined(__SSE2__) && defined(__x86_64__) /* _mm_cvttss_si64 */

/* chunk_min_below for the 2D block scan (|q| < 512 on both axes), with
 * plain loads (the chunk's own slots; a half's start at slot 5 of its
 * record for side 1, the layout keeping both loads inside the record): the
 * same integer answer, from lanes_min2 with the float minimum. */
static inline __attribute__((always_inline)) uint64_t chunk_min2(const uint8_t *chunk,
                                                                 const int64_t *q, uint32_t m,
                                                                 uint64_t best2)
{
    const __m128i v0 = _mm_loadu_si128((const __m128i *)(const void *)chunk);
    const __m128i v1 = _mm_srli_si128(_mm_loadu_si128((const __m128i *)(const void *)(chunk + 8)), 2);
    return lanes_min2(v0, v1, q, chunk_pad2[m], best2, 1);
}
#endif

/* scan_leaf for the 2D block scan (|q| < 512): chunk_min2, or while
 * workers append chunk_min2_shared on the chunks that may be written. */
static inline __attribute__((always_inline)) uint64_t scan_leaf2(const tree *t, uint32_t head,
                                                                 const int64_t *q, uint64_t best2,
                                                                 int concurrent, search_state *k)
{
#if defined(__SSE2__) && defined(__x86_64__)
    for (uint32_t c = head;;) {
        const uint8_t *chunk = tree_chunk_at(t, c);
        const uint32_t link = tree_chunk_link(t, c, chunk);
        const uint32_t m = tree_fill(c, link);
        k->particle_checks += m;
        best2 = tree_vector_ok(c, link, concurrent) ? chunk_min2(chunk, q, m, best2)
                                                    : chunk_min2_shared(chunk, c, q, m, best2, 1);
        if (link <= TREE_CHUNK_CAP) return best2;
        c = link;
    }
#else
    return scan_leaf(t, head, q, best2, 1, 2, concurrent, k);
#endif
}

/* One leaf of the block scan (offset o; col2: the squared distances from p
 * to the leaf columns -1, 0, +1 per axis): skipped when empty or when its
 * box is not nearer than best2, else scanned. Returns the new best2. */
static inline __attribute__((always_inline)) uint64_t
blk_visit(const tree *t, const search_config *c, const distmap_level *L, const int64_t *p,
          const int64_t *lo, const int64_t *cc, uint32_t occ, const uint64_t (*col2)[3], int o,
          uint64_t best2, search_state *k, const int dim, const int bits)
{
    uint32_t head = k->blk_head[o];
    if (head == BLK_EMPTY) return best2;
    uint64_t bd2 = 0;
    for (int a = 0; a < dim; a++) bd2 += col2[a][block_off[o][a] + 1];
    if (bd2 >= best2) return best2;
    int64_t nlo[3];
    for (int a = 0; a < dim; a++) nlo[a] = lo[a] + (int64_t)block_off[o][a] * TREE_LEAF_SIDE;
    if (head <= BLK_EMPTY) {
        head = blk_lookup(t, L, cc, occ, o, nlo, k, dim, bits);
        if (head <= BLK_EMPTY) return best2;
    }
    int64_t q[3];
    for (int a = 0; a < dim; a++) q[a] = p[a] - nlo[a];
    k->node_visits++;
    if (dim == 2) return scan_leaf2(t, head, q, best2, c->concurrent, k);
    return scan_leaf(t, head, q, best2, 1, dim, c->concurrent, k); /* |q| < 512 */
}

/* Exact scan of the block's leaves around p (own leaf corner lo, map cell
 * cc), nearest first, each pruned by its box distance; best2: the bound to
 * start from. 2D unrolls the nine leaves, so each leaf's offsets are
 * constants (the loop's table look-ups were ~200 Ir a query at 2D 1e5). */
static inline __attribute__((always_inline)) uint64_t blk_scan(const tree *t,
                                                               const search_config *c,
                                                               const distmap_level *L,
                                                               const int64_t *p, const int64_t *lo,
                                                               const int64_t *cc, uint32_t occ,
                                                               uint64_t best2, search_state *k,
                                                               const int dim, const int bits)
{
    const int n = dim == 2 ? 9 : 27;
    const uint8_t *order = dim == 2 ? block_order2 : block_order3;
    /* Squared distance from p to the leaf columns -1, 0, +1 on each axis:
     * a leaf's box distance is a sum of three table entries. */
    uint64_t col2[3][3];
    for (int a = 0; a < dim; a++) {
        const int64_t below = p[a] - lo[a] + 1, above = lo[a] + TREE_LEAF_SIDE - p[a];
        col2[a][0] = (uint64_t)(below * below);
        col2[a][1] = 0;
        col2[a][2] = (uint64_t)(above * above);
    }
    if (dim == 2) {
        /* Own leaf, faces, corners (block_order2). A face's box is at least
         * the nearest face column away, a corner's at least the nearest
         * corner: when best2 is not above that, every leaf of the group
         * would be pruned by its own box, so the group is skipped whole
         * (same answer, fewer compares). */
        const uint64_t mx = col2[0][0] < col2[0][2] ? col2[0][0] : col2[0][2];
        const uint64_t my = col2[1][0] < col2[1][2] ? col2[1][0] : col2[1][2];
        best2 = blk_visit(t, c, L, p, lo, cc, occ, (const uint64_t(*)[3])col2, 4, best2, k, 2, bits);
        if (best2 <= (mx < my ? mx : my)) return best2;
#pragma GCC unroll 4
        for (int i = 1; i < 5; i++)
            best2 = blk_visit(t, c, L, p, lo, cc, occ, (const uint64_t(*)[3])col2,
                              block_order2[i], best2, k, 2, bits);
        if (best2 <= mx + my) return best2;
#pragma GCC unroll 4
        for (int i = 5; i < 9; i++)
            best2 = blk_visit(t, c, L, p, lo, cc, occ, (const uint64_t(*)[3])col2,
                              block_order2[i], best2, k, 2, bits);
        return best2;
    }
    for (int i = 0; i < n; i++)
        best2 = blk_visit(t, c, L, p, lo, cc, occ, (const uint64_t(*)[3])col2, order[i], best2, k,
                          dim, bits);
    return best2;
}

/* The walker's leaf-bit rows (search_state lb_row) for the LB_WORDS^2 words
 * around word (wx, wy), as of cache key `key` (read before the grid). */
static void lb_fill(search_state *k, const distmap *m, const distmap_grid *g, int64_t wx,
                    int64_t wy, uint64_t key)
{
    int unknown = 0;
    uint64_t nz = 0;
    for (int j = 0; j < LB_WORDS; j++) {
        uint64_t w[LB_WORDS], any = 0;
        for (int i = 0; i < LB_WORDS; i++)
            any |= w[i] = distmap_leaf_word(m, g, wx - LB_RING + i, wy - LB_RING + j, &unknown);
#if defined(__SSE2__) && defined(__x86_64__) && LB_WORDS == 3
        /* Row r is byte r of each word side by side: two byte and two
         * word interleaves give it in a 32-bit lane (a tenth of the scalar
         * loop's instructions; a fill follows most moves to a new word). */
        const __m128i z = _mm_setzero_si128();
        /* Rows with a bit set: bytes of the OR of the words that are not 0. */
        nz |= (uint64_t)(~_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_cvtsi64_si128((long long)any), z)) & 255)
              << (8 * j);
        const __m128i ab = _mm_unpacklo_epi8(_mm_cvtsi64_si128((long long)w[0]),
                                             _mm_cvtsi64_si128((long long)w[1]));
        const __m128i c = _mm_unpacklo_epi8(_mm_cvtsi64_si128((long long)w[2]), z);
        const __m128i lo = _mm_unpacklo_epi16(ab, c), hi = _mm_unpackhi_epi16(ab, c);
        __m128i *out = (__m128i *)(void *)&k->lb_row[8 * j];
        _mm_storeu_si128(out, _mm_unpacklo_epi32(lo, z));
        _mm_storeu_si128(out + 1, _mm_unpackhi_epi32(lo, z));
        _mm_storeu_si128(out + 2, _mm_unpacklo_epi32(hi, z));
        _mm_storeu_si128(out + 3, _mm_unpackhi_epi32(hi, z));
#else
        for (int r = 0; r < 8; r++) {
            uint64_t row = 0;
            if (any)
                for (int i = 0; i < LB_WORDS; i++) row |= ((w[i] >> (8 * r)) & 255) << (8 * i);
            k->lb_row[8 * j + r] = row;
            nz |= (uint64_t)(row != 0) << (8 * j + r);
        }
#endif
    }
    k->lb_w[0] = wx;
    k->lb_w[1] = wy;
    k->lb_leaves = key;
    k->lb_valid = 1;
    k->lb_unknown = unknown;
    k->lb_nz = nz;
}

/* The squared x gap in units from p (offset ox in its leaf, at column x
 * of the rows, 8 LB_RING <= x < 8 LB_RING + 8) to the nearest leaf with its
 * bit set in row w, 0 when that is p's own column; above every cap of
 * leaf_bound2 when there is none. A leaf k columns right of p's is
 * k * 256 - ox away, one k columns left (k - 1) * 256 + ox + 1: ctz and
 * clz give k, branch-free, with sentinel bits 40 and 64 columns out (the
 * cap is at most 4 LB_WORDS leaves, <= 28). */
_Static_assert(DISTMAP_LEAF_REACH >= 8 && DISTMAP_LEAF_REACH <= 24 && 8 * LB_WORDS - 8 * LB_RING <= 40,
               "row_gap2's sentinels must lie beyond the rows, and p's column must be >= 8 (no shift by 64)");
static inline __attribute__((always_inline)) uint64_t row_gap2(uint64_t w, int x, int64_t ox)
{
    const int64_t right = ((int64_t)__builtin_ctzll((w >> x) | UINT64_C(1) << 40) << TREE_LEAF_BITS) - ox;
    const int64_t left = ((int64_t)__builtin_clzll((w << (64 - x)) | 1) << TREE_LEAF_BITS) + ox + 1;
    int64_t g = right < left ? right : left;
    g = g > 0 ? g : 0;
    return (uint64_t)(g * g);
}

/* The leaf bound (block_bits2, when the 3 x 3 leaves around p's are
 * empty): the squared Euclidean distance from p to the box of the nearest
 * leaf with its bit set in the rows (the 8 LB_WORDS leaves square around
 * p's leaf, which is at column x, row y), or to the outside of that square
 * if nearer. Every particle lies in a marked leaf or outside the square,
 * so it is a lower bound, and at least one leaf. Rows are taken outwards
 * from p's on each side until a row's own y gap is no nearer than the
 * best so far. The chessboard rings of leaves before gave up to 41% less
 * on diagonals and more than a leaf less where p sits off-centre in its
 * leaf: forced-coarse 2D 1e5 (seed 1) took 40.65 jumps/particle with
 * them, 28.47 with this (runs/bench-serial/issue12-far13-2026-11-25.md). */
static inline __attribute__((always_inline)) uint64_t leaf_bound2(const uint64_t *row, uint64_t nz,
                                                                 int x, int y, const int64_t *p)
{
    const int n = 8 * LB_WORDS;
    const int64_t ox = p[0] & (TREE_LEAF_SIDE - 1), oy = p[1] & (TREE_LEAF_SIDE - 1);
    /* The square's edges: x + 1 columns left, n - x right (as row_gap2). */
    int64_t cap = ((int64_t)x << TREE_LEAF_BITS) + ox + 1;
    const int64_t c1 = ((int64_t)(n - x) << TREE_LEAF_BITS) - ox;
    const int64_t c2 = ((int64_t)y << TREE_LEAF_BITS) + oy + 1;
    const int64_t c3 = ((int64_t)(n - y) << TREE_LEAF_BITS) - oy;
    if (c1 < cap) cap = c1;
    if (c2 < cap) cap = c2;
    if (c3 < cap) cap = c3;
    uint64_t best2 = (uint64_t)(cap * cap);
    uint64_t g2 = row_gap2(row[y], x, ox);
    if (g2 < best2) best2 = g2;
    /* Rows d above p's: y gap d * 256 - oy; d below: (d - 1) * 256 + oy + 1.
     * Only rows with a bit set (nz) are read; rows outside the square are
     * not in nz (the cap covers them). */
    for (uint64_t m = nz >> (y + 1); m; m &= m - 1) {
        const int d = __builtin_ctzll(m) + 1;
        const int64_t gy = ((int64_t)d << TREE_LEAF_BITS) - oy;
        const uint64_t gy2 = (uint64_t)(gy * gy);
        if (gy2 >= best2) break;
        g2 = gy2 + row_gap2(row[y + d], x, ox);
        if (g2 < best2) best2 = g2;
    }
    for (uint64_t m = nz << (64 - y); m; m &= ~(UINT64_C(1) << 63 >> __builtin_clzll(m))) {
        const int d = __builtin_clzll(m) + 1;
        const int64_t gy = ((int64_t)(d - 1) << TREE_LEAF_BITS) + oy + 1;
        const uint64_t gy2 = (uint64_t)(gy * gy);
        if (gy2 >= best2) break;
        g2 = gy2 + row_gap2(row[y - d], x, ox);
        if (g2 < best2) best2 = g2;
    }
    return best2;
}

/* The 2D block search on the map's leaf bits (coarsened fine cells; see
 * search_block2). `key`: the cache key, read before g: the tree's count
 * (with the top bit set, so it never equals a key of the leaf-cell mode),
 * which changes after every particle is published. A leaf the tree does
 * not have is then empty until the key changes, whether or not its bit is
 * set. */
static uint64_t block_bits2(const tree *t, const search_config *c, const distmap *m,
                            const distmap_grid *g, const int64_t *p, uint64_t key,
                            search_state *k)
{
    const int64_t lx = p[0] >> DISTMAP_LEAFBIT_SHIFT, ly = p[1] >> DISTMAP_LEAFBIT_SHIFT;
    if (!k->lb_valid || k->lb_w[0] != lx >> 3 || k->lb_w[1] != ly >> 3 || k->lb_leaves != key)
        lb_fill(k, m, g, lx >> 3, ly >> 3, key);
    if (k->lb_unknown) return UINT64_MAX; /* dropped interior tiles: the tree */
    /* p's leaf in the rows: x, y in 8 LB_RING.. + 7, so every square of
     * up to DISTMAP_LEAF_REACH leaves around it lies in them. */
    const int x = (int)(lx & 7) + 8 * LB_RING, y = (int)(ly & 7) + 8 * LB_RING;
    const uint64_t *row = k->lb_row;
    const uint32_t r0 = (uint32_t)(row[y - 1] >> (x - 1)) & 7, r1 = (uint32_t)(row[y] >> (x - 1)) & 7,
                   r2 = (uint32_t)(row[y + 1] >> (x - 1)) & 7;
    if (!(r0 | r1 | r2)) return leaf_bound2(row, k->lb_nz, x, y, p);
    /* The 3 x 3 leaves around p's leaf (bit o = (dx + 1) + 3 (dy + 1), as
     * block_off). */
    const uint32_t occ = r0 | r1 << 3 | r2 << 6;
    int64_t lo[3] = {lx * TREE_LEAF_SIDE, ly * TREE_LEAF_SIDE, 0};
    blk_recentre(k, t, lo, 2);
    if (key != k->blk_leaves) {
        for (int o = 0; o < 9; o++)
            if (k->blk_head[o] == BLK_EMPTY) k->blk_head[o] = BLK_UNKNOWN;
        k->blk_leaves = key;
    }
    const uint64_t out2 = inside_margin2(p, (const int64_t[3]){lo[0] - TREE_LEAF_SIDE,
                                                              lo[1] - TREE_LEAF_SIDE, 0},
                                         3 * TREE_LEAF_SIDE, 2);
    const uint64_t best2 = blk_scan(t, c, NULL, p, lo, NULL, occ, UINT64_MAX, k, 2, 1);
    return best2 < out2 ? best2 : out2;
}

static inline __attribute__((always_inline)) uint64_t block_dim(const tree *t,
                                                                const search_config *c,
                                                                const distmap *m, const int64_t *p,
                                                                search_state *k, const int dim)
{
    /* The counts before the grid: a grid replaced after a particle counted
     * here was seen is then the new one (or newer), which has its marks. */
    const uint64_t leaves = atomic_load_explicit(&m->leaves, memory_order_acquire);
    const uint64_t key = tree_count(t) | UINT64_C(1) << 63;
    const distmap_grid *g = atomic_load_explicit(&m->grid, memory_order_acquire);
    if (!g) return UINT64_MAX;
    const distmap_level *L = &g->lv[0];
    if (L->bits != TREE_LEAF_BITS) /* coarsened: not the leaves */
        return dim == 2 && g->tix ? block_bits2(t, c, m, g, p, key, k) : UINT64_MAX;
    const int64_t w = L->width;
    int64_t cc[3];
    for (int a = 0; a < dim; a++) {
        /* 1 <= cc < w - 1 (p + half < 0 gives cc < 0: the shift is
         * arithmetic), in one unsigned compare; w >= 8, as half is whole
         * coarse cells. */
        cc[a] = (p[a] + g->half) >> TREE_LEAF_BITS;
        if ((uint64_t)(cc[a] - 1) >= (uint64_t)(w - 2)) return UINT64_MAX;
    }
    /* The cache is keyed by the own leaf's absolute corner, not by grid
     * cells: the grid's origin moves when it grows. */
    int64_t lo[3];
    for (int a = 0; a < dim; a++) lo[a] = p[a] & ~(int64_t)(TREE_LEAF_SIDE - 1);
    blk_recentre(k, t, lo, dim);
    /* A leaf made since (by an earlier walker's particle) may be one seen
     * empty: look at those again. */
    if (leaves != k->blk_leaves) {
        for (int o = 0; o < (dim == 2 ? 9 : 27); o++)
            if (k->blk_head[o] == BLK_EMPTY) k->blk_head[o] = BLK_UNKNOWN;
        k->blk_leaves = leaves;
    }
    /* Every other particle is outside the block: the answer is at most
     * out2, so the scan may start from there (or from the seed, below it). */
    const uint64_t out2 = inside_margin2(p, (const int64_t[3]){lo[0] - TREE_LEAF_SIDE,
                                                              lo[1] - TREE_LEAF_SIDE,
                                                              lo[2] - TREE_LEAF_SIDE},
                                         3 * TREE_LEAF_SIDE, dim);
    const uint64_t seed2 = SEARCH_SEEDED(dim) ? seed_bound2(k, p, dim) : UINT64_MAX;
    /* 2D starts from no bound: starting from out2 saved 0.8% of Ir at 2D
     * 1e5 but was slower in user CPU time in paired runs (runs/bench-serial/
     * issue12-speed3-2026-11-24.md). */
    const uint64_t start2 = SEARCH_SEEDED(dim) ? (seed2 < out2 ? seed2 : out2) : UINT64_MAX;
    const uint64_t best2 = blk_scan(t, c, L, p, lo, cc, 0, start2, k, dim, 0);
    if (best2 < out2) {
        if (SEARCH_SEEDED(dim)) note_exact(k, p, best2, dim);
        return best2;
    }
    return out2;
}

uint64_t search_block2(const tree *t, const search_config *c, const distmap *m, const int64_t *p,
                       search_state *k)
{
    return t->dim == 2 ? block_dim(t, c, m, p, k, 2) : block_dim(t, c, m, p, k, 3);
}

/* The first chunk of the leaf with low corner `corner` when the walker's 2D
 * block cache knows it (snapping runs right after the block query that
 * stopped the walker, at most a contact distance from its point, so the
 * leaves it needs are that block's): saves a tree walk per leaf. 0 when not
 * known (or seen empty: a leaf may have been made since; the tree decides).
 * A leaf's first chunk changes only with the tree's head_moves (checked).
 * Skipping find_leaf_cached leaves the cached path as it was, which changes
 * no search's answer (descend_own_path reaches the same deepest node from
 * any level that contains p). */
static inline __attribute__((always_inline)) uint32_t blk_known_head2(const search_state *k,
                                                                     const tree *t,
                                                                     const int64_t *corner)
{
    if (!k->blk_valid || k->blk_moves != t->head_moves) return 0;
    const int64_t dx = corner[0] - k->blk_c[0], dy = corner[1] - k->blk_c[1];
    if (dx < -TREE_LEAF_SIDE || dx > TREE_LEAF_SIDE || dy < -TREE_LEAF_SIDE || dy > TREE_LEAF_SIDE)
        return 0;
    const uint32_t head = k->blk_head[(dx / TREE_LEAF_SIDE + 1) + 3 * (dy / TREE_LEAF_SIDE + 1)];
    return head > BLK_EMPTY ? head : 0;
}

static inline __attribute__((always_inline)) int nearest_point(const tree *t, const int64_t *p,
                                                             uint64_t radius2, int64_t *q,
                                                             uint64_t *d2_out, search_state *k)
{
    const int dim = t->dim;
    const int64_t r = tree_ceil_sqrt(radius2);
    /* The ball spans up to three leaves per axis (r < 256; two when
     * r <= 128). The leaves of the first two columns come first, in the
     * order that decides ties between equally near particles. */
    int64_t first[3], span[3];
    for (int a = 0; a < dim; a++) {
        first[a] = (p[a] - r) & ~(int64_t)(TREE_LEAF_SIDE - 1);
        span[a] = (((p[a] + r) & ~(int64_t)(TREE_LEAF_SIDE - 1)) - first[a]) / TREE_LEAF_SIDE + 1;
    }
    uint64_t best2 = radius2;
    int found = 0;
    const int ncorner = 1 << dim, nall = dim == 2 ? 9 : 27;
    /* A third column exists only where the ball spans three leaves. */
    int three = 0;
    for (int a = 0; a < dim; a++) three |= span[a] > 2;
    const int nvisit = three ? ncorner + nall : ncorner;
    for (int i = 0; i < nvisit; i++) {
        int64_t corner[3] = {0, 0, 0};
        int skip = 0, has2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t step = i < ncorner ? (i >> a) & 1 : block_off[i - ncorner][a] + 1;
            has2 |= step == 2;
            if (step >= span[a]) skip = 1;
            corner[a] = first[a] + step * TREE_LEAF_SIDE;
        }
        if (skip || (i >= ncorner && !has2)) continue;
        int64_t lo[3];
        uint32_t leaf_idx;
        if (k) { /* from the walker's cached path: the leaves are its neighbours */
            leaf_idx = dim == 2 ? blk_known_head2(k, t, corner) : 0;
            if (!leaf_idx)
                leaf_idx = dim == 2 ? find_leaf_cached(t, corner, k, 2) : find_leaf_cached(t, corner, k, 3);
            for (int a = 0; a < dim; a++) lo[a] = corner[a];
        } else {
            leaf_idx = tree_find_leaf(t, corner, lo);
        }
        if (!leaf_idx) continue;
        int64_t ql[3] = {0, 0, 0};
        for (int a = 0; a < dim; a++) ql[a] = p[a] - lo[a]; /* |ql| < 512: chunk_min_below applies */
        for (uint32_t ci = leaf_idx;;) {
            const uint8_t *chunk = tree_chunk_at_d(t, ci, dim);
            const uint32_t link = tree_chunk_link_d(t, ci, chunk, dim);
            const uint32_t m = tree_fill_d(ci, link, dim);
            /* A full chunk that links on is never written again, so its
             * vector minimum may be read while workers append: when it is
             * not below the best, the scalar pass (which keeps the first of
             * equally near particles) would change nothing. 3D only: in 2D
             * it saved 0.6% of Ir but no user CPU time in paired runs. */
            if (dim == 3 && tree_vector_ok(ci, link, 1) && chunk_min_below(chunk, ql, m, best2, dim) >= best2) {
                ci = link;
                continue;
            }
            for (uint32_t j = 0; j < m; j++) {
                uint64_t d2 = 0;
                int64_t x[3];
                for (int a = 0; a < dim; a++) {
                    x[a] = lo[a] + chunk[a * TREE_CHUNK_CAP + (int)j];
                    const int64_t d = p[a] - x[a];
                    d2 += (uint64_t)(d * d);
                }
                if (d2 < best2) {
                    best2 = d2;
                    found = 1;
                    for (int a = 0; a < dim; a++) q[a] = x[a];
                }
            }
            if (link <= TREE_CHUNK_CAP) break;
            ci = link;
        }
    }
    if (found) *d2_out = best2;
    return found;
}

/* Appends the particles of the 2D leaf with corner `corner` whose squared
 * distance from p is below far2 to pts[n..]; returns the new count, or -1
 * past cap. Leaves as nearest_point finds them (the walker's block cache,
 * else its cached tree path), chunks in the same order. */
static int ball_leaf2(const tree *t, const int64_t *p, const int64_t *corner, uint64_t far2,
                      search_point *pts, int n, int cap, search_state *k)
{
    uint32_t ci = blk_known_head2(k, t, corner);
    if (!ci) ci = find_leaf_cached(t, corner, k, 2);
    if (!ci) return n;
    for (;;) {
        const uint8_t *chunk = tree_chunk_at_d(t, ci, 2);
        const uint32_t link = tree_chunk_link_d(t, ci, chunk, 2);
        const uint32_t m = tree_fill(ci, link);
        for (uint32_t j = 0; j < m; j++) {
            const int64_t x = corner[0] + chunk[j], y = corner[1] + chunk[TREE_CHUNK_CAP + (int)j];
            const uint64_t d2 = (uint64_t)((p[0] - x) * (p[0] - x)) + (uint64_t)((p[1] - y) * (p[1] - y));
            if (d2 >= far2) continue;
            if (n == cap) return -1;
            pts[n++] = (search_point){{x, y}, d2};
        }
        if (link <= TREE_CHUNK_CAP) return n;
        ci = link;
    }
}

int search_ball_points2(const tree *t, const int64_t *p, uint64_t near2, uint64_t far2,
                        search_point *pts, int cap, search_state *k)
{
    const int64_t r0 = tree_ceil_sqrt(near2), r1 = tree_ceil_sqrt(far2);
    if (r1 >= TREE_LEAF_SIDE || r0 > r1) return -1;
    int64_t f0[2], s0[2], f1[2], s1[2];
    for (int a = 0; a < 2; a++) {
        f0[a] = (p[a] - r0) & ~(int64_t)(TREE_LEAF_SIDE - 1);
        s0[a] = (((p[a] + r0) & ~(int64_t)(TREE_LEAF_SIDE - 1)) - f0[a]) / TREE_LEAF_SIDE + 1;
        f1[a] = (p[a] - r1) & ~(int64_t)(TREE_LEAF_SIDE - 1);
        s1[a] = (((p[a] + r1) & ~(int64_t)(TREE_LEAF_SIDE - 1)) - f1[a]) / TREE_LEAF_SIDE + 1;
    }
    int n = 0;
    /* The leaves of the near ball in nearest_point's order: the 2 x 2 from
     * the low corner, then those two leaves over on some axis. */
    const int nvisit = s0[0] > 2 || s0[1] > 2 ? 4 + 9 : 4;
    for (int i = 0; i < nvisit && n >= 0; i++) {
        int64_t corner[2];
        int skip = 0, has2 = 0;
        for (int a = 0; a < 2; a++) {
            const int64_t step = i < 4 ? (i >> a) & 1 : block_off[i - 4][a] + 1;
            has2 |= step == 2;
            if (step >= s0[a]) skip = 1;
            corner[a] = f0[a] + step * TREE_LEAF_SIDE;
        }
        if (skip || (i >= 4 && !has2)) continue;
        n = ball_leaf2(t, p, corner, far2, pts, n, cap, k);
    }
    /* Then the leaves only the far ball reaches. */
    for (int64_t sy = 0; sy < s1[1] && n >= 0; sy++)
        for (int64_t sx = 0; sx < s1[0] && n >= 0; sx++) {
            const int64_t corner[2] = {f1[0] + sx * TREE_LEAF_SIDE, f1[1] + sy * TREE_LEAF_SIDE};
            int inside = 1;
            for (int a = 0; a < 2; a++)
                inside &= corner[a] >= f0[a] && corner[a] < f0[a] + s0[a] * TREE_LEAF_SIDE;
            if (!inside) n = ball_leaf2(t, p, corner, far2, pts, n, cap, k);
        }
    return n;
}

int search_nearest_point(const tree *t, const int64_t *p, uint64_t radius2, int64_t *q,
                         uint64_t *d2_out)
{
    return nearest_point(t, p, radius2, q, d2_out, NULL);
}

int search_nearest_point_cached(const tree *t, const int64_t *p, uint64_t radius2, int64_t *q,
                                uint64_t *d2_out, search_state *k)
{
    return nearest_point(t, p, radius2, q, d2_out, k);
}

typedef struct brute_ctx {
    const int64_t *p;
    int dim;
    uint64_t best2;
} brute_ctx;

static int brute_visit(const int64_t *q, void *user)
{
    brute_ctx *b = user;
    uint64_t d2 = 0;
    for (int a = 0; a < b->dim; a++) {
        const int64_t d = b->p[a] - q[a];
        d2 += (uint64_t)d * (uint64_t)d;
    }
    if (d2 < b->best2) b->best2 = d2;
    return 0;
}

uint64_t search_brute2(const tree *t, const int64_t *p)
{
    brute_ctx b = {p, t->dim, UINT64_MAX};
    tree_visit(t, brute_visit, &b);
    return b.best2;
}
