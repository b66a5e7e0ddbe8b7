/*
 * dlca_start.c - a DLCA start from a file (`--start FILE`): the monomers'
 * lattice coordinates from a text file (one monomer a line, d integers
 * separated by blanks (spaces or tabs; nothing else, not even commas), '#'
 * starts a comment) or from an HDF5 file holding
 * /monomers/position [N][d] (a DLCA cluster.h5). Every coordinate must lie
 * in the box and no two monomers on one site; the first fault is refused
 * with one line naming the file and the line (or monomer).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dlca_h5.h"
#include "dlca_internal.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"

typedef struct start_buf {
    uint32_t *site;
    uint64_t *where; /* the line of each (text); NULL for HDF5, whose monomer m is row m */
    uint64_t n, cap;
    uint64_t *seen; /* one bit a site of the box: a shared site is refused at its second monomer */
    const char *path, *unit; /* "line" or "monomer" */
} start_buf;

static int grow(start_buf *b)
{
    const uint64_t cap = b->cap ? 2 * b->cap : 1024;
    uint32_t *s = realloc(b->site, cap * sizeof *s);
    if (!s) return -1;
    b->site = s;
    if (b->where) {
        uint64_t *w = realloc(b->where, cap * sizeof *w);
        if (!w) return -1;
        b->where = w;
    }
    b->cap = cap;
    return 0;
}

/* Site k of the monomer at `where` (its line or number), unless another
 * monomer holds it: then PDLA_EINVAL naming both, as soon as the second is
 * read (a gzip'ed file of 1e8 rows of zeros once was read whole, 2.4 GB,
 * before the check). */
static int push(start_buf *b, uint32_t k, uint64_t where, char *err, size_t errlen)
{
    const uint64_t bit = UINT64_C(1) << (k & 63);
    if (b->seen[k >> 6] & bit) {
        uint64_t i = 0;
        while (b->site[i] != k) i++;
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %ss %llu and %llu put two monomers on one site", b->path,
                           b->unit, (unsigned long long)(b->where ? b->where[i] : i + 1), (unsigned long long)where);
    }
    b->seen[k >> 6] |= bit;
    if (b->n == b->cap && grow(b)) return pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", b->path);
    b->site[b->n] = k;
    if (b->where) b->where[b->n] = where;
    b->n++;
    return 0;
}

/* The site of coordinates x, or PDLA_EINVAL naming the axis outside. */
static int site_of(const dlca_params *p, const long long *x, uint32_t *k, const char *path, const char *unit,
                   uint64_t where, char *err, size_t errlen)
{
    uint64_t s = 0, stride = 1;
    for (int a = 0; a < p->dim; a++) {
        if (x[a] < 0 || x[a] >= (long long)p->box[a])
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %s %llu: coordinate %lld on axis %d is outside the box [0, %u)",
                               path, unit, (unsigned long long)where, x[a], a + 1, p->box[a]);
        s += (uint64_t)x[a] * stride;
        stride *= p->box[a];
    }
    *k = (uint32_t)s;
    return 0;
}

/* Did the fgets that began at offset `at` read a NUL byte (fewer
 * characters in line than it read)? fgets gives no count, and the NUL
 * ended the line silently. 0 where f cannot tell its offset (a FIFO). */
static int nul_read(FILE *f, long at, const char *line)
{
    const long now = ftell(f);
    return at >= 0 && now >= at && (size_t)(now - at) != strlen(line);
}

/* The box's sites: a start holds fewer monomers (N < V), so a file of
 * more is refused as soon as it passes them, not read to its end (an
 * endless stream grew without bound). */
static uint64_t box_sites(const dlca_params *p)
{
    uint64_t V = 1;
    for (int a = 0; a < p->dim; a++) V *= p->box[a];
    return V;
}

static int too_many(const start_buf *b, const dlca_params *p, const char *path, char *err, size_t errlen)
{
    const uint64_t V = box_sites(p);
    if (b->n + 1 < V) return 0;
    return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: more monomers than the box of %llu sites can hold (N < V)", path,
                       (unsigned long long)V);
}

/* Did fgets stop inside a line longer than the buffer (no newline, and
 * more to read)? Its tail would be read as a line of its own: the end of
 * a long comment became a monomer. */
static int line_too_long(FILE *f, const char *line, size_t size)
{
    const size_t len = strlen(line);
    if (len + 1 < size || line[len - 1] == '\n') return 0;
    const int ch = fgetc(f);
    return ch != EOF && ch != '\n'; /* a newline right after: the line fitted */
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

/* The integers of one line (its comment already cut) into x (room for
 * DLCA_MAX_DIM + 1): their count, or -1 when something else is there. Each
 * must end at a blank or the end of the line: strtoll stopped at the '+'
 * of "1+2" and read it as the two coordinates 1 and 2, and commas were
 * taken as blanks, which no documentation said. */
static int line_coords(const char *line, long long *x)
{
    int n = 0;
    const char *q = line;
    for (;;) {
        while (is_blank(*q)) q++;
        if (!*q) return n;
        char *end;
        errno = 0;
        const long long v = strtoll(q, &end, 10);
        if (end == q || errno || n > DLCA_MAX_DIM || (*end && !is_blank(*end))) return -1;
        x[n++] = v;
        q = end;
    }
}

static int read_text(FILE *f, const char *path, const dlca_params *p, start_buf *b, char *err, size_t errlen)
{
    char line[4096];
    long at = ftell(f);
    for (uint64_t ln = 1; fgets(line, sizeof line, f); ln++, at = ftell(f)) {
        if (nul_read(f, at, line))
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: line %llu: a NUL byte in the line", path,
                               (unsigned long long)ln);
        if (line_too_long(f, line, sizeof line))
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: line %llu: longer than %zu bytes", path,
                               (unsigned long long)ln, sizeof line - 1);
        char *h = strchr(line, '#');
        if (h) *h = '\0';
        long long x[DLCA_MAX_DIM + 1];
        const int n = line_coords(line, x);
        if (n < 0)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: line %llu: expected %d integer coordinates separated by "
                               "spaces or tabs", path, (unsigned long long)ln, p->dim);
        if (n == 0) continue;
        if (n != p->dim)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: line %llu: %d coordinates, --dim %d needs %d", path,
                               (unsigned long long)ln, n, p->dim, p->dim);
        uint32_t k = 0;
        if (site_of(p, x, &k, path, "line", ln, err, errlen)) return PDLA_EINVAL;
        if (too_many(b, p, path, err, errlen)) return PDLA_EINVAL;
        const int rc = push(b, k, ln, err, errlen);
        if (rc) return rc;
    }
    if (ferror(f)) return pdla_errorf(PDLA_EIO, err, errlen, "%s: read error", path);
    return 0;
}

/* Rows [0, rows) of d in slabs: each row's site checked and pushed, so a
 * fault stops the read at its row, within a slab's memory. */
static int read_rows(const pdla_h5_dset *d, const dlca_params *p, start_buf *b, char *err, size_t errlen)
{
    enum { SLAB = 65536 };
    int32_t *pos = malloc((size_t)SLAB * (size_t)p->dim * sizeof *pos);
    if (!pos) return pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", b->path);
    int rc = 0;
    for (uint64_t r0 = 0; r0 < d->dims[0] && rc == 0; r0 += SLAB) {
        const uint64_t nr = d->dims[0] - r0 < SLAB ? d->dims[0] - r0 : SLAB;
        if (pdla_h5_dset_read(d, PDLA_H5_I32, r0, nr, pos) < 0) {
            rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot read /monomers/position", b->path);
            break;
        }
        for (uint64_t i = 0; i < nr && rc == 0; i++) {
            long long x[DLCA_MAX_DIM];
            for (int a = 0; a < p->dim; a++) x[a] = pos[i * (uint64_t)p->dim + (uint64_t)a];
            uint32_t k = 0;
            rc = site_of(p, x, &k, b->path, "monomer", r0 + i + 1, err, errlen);
            if (rc == 0) rc = push(b, k, r0 + i + 1, err, errlen);
        }
    }
    free(pos);
    return rc;
}

static int read_h5(const char *path, const dlca_params *p, start_buf *b, char *err, size_t errlen)
{
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "cannot silence HDF5");
    int rc = PDLA_EINVAL;
    double gib = 0;
    /* Through the checked reader (pdla/h5check.h): the shape and type first,
     * then whether the file stores what it declares and the run would fit
     * in memory, before anything is sized. */
    pdla_h5_dset d = {.id = H5I_INVALID_HID};
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    const int stored = f >= 0 && pdla_h5_dset_open(f, "monomers/position", &d) == 0 && d.rank == 2
                           ? pdla_h5_dset_stored(&d, sizeof(int32_t))
                           : -1;
    if (stored < 0 || !pdla_h5_dset_is(&d, PDLA_H5_I32))
        pdla_errorf(PDLA_EINVAL, err, errlen, "%s: no /monomers/position [N][d] of 32-bit integers to start from", path);
    else if (d.dims[1] != (uint64_t)p->dim)
        pdla_errorf(PDLA_EINVAL, err, errlen, "%s: its monomers have %llu coordinates, --dim %d needs %d", path,
                    (unsigned long long)d.dims[1], p->dim, p->dim);
    else if (d.dims[0] >= box_sites(p))
        pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %llu monomers, more than the box of %llu sites can hold (N < V)",
                    path, (unsigned long long)d.dims[0], (unsigned long long)box_sites(p));
    else if (stored != PDLA_H5_STORED)
        pdla_errorf(PDLA_EINVAL, err, errlen, "%s: /monomers/position declares %llu rows, more than the file stores",
                    path, (unsigned long long)d.dims[0]);
    else if (!dlca_memory_fits((double)box_sites(p), d.dims[0], &gib))
        pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %llu monomers in this box need about %.3g GiB, more than half of "
                    "this machine's memory", path, (unsigned long long)d.dims[0], gib);
    /* one chunk of a single-chunk gzip start decompressed once, not once
     * per slab (the memory check above bounds the chunk the cache keeps) */
    else if (pdla_h5_dset_cache_chunk(f, "monomers/position", &d) < 0)
        pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot reopen /monomers/position with a chunk cache", path);
    else
        rc = read_rows(&d, p, b, err, errlen);
    /* A close that fails after a good read fails the start: HDF5 went wrong. */
    if (pdla_h5_dset_close(&d) < 0 && rc == 0)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close /monomers/position", path);
    if (f >= 0 && H5Fclose(f) < 0 && rc == 0) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close it", path);
    if (h5u_restore(&q) < 0 && rc == 0) rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot restore HDF5's error printing");
    return rc;
}

/* One bit a site of the box (seen, or bits of its own for the call): O(n),
 * where a sort took minutes for 40 snapshots of 10^8 monomers. */
int dlca_shared_site(const uint32_t *site, uint64_t n, uint64_t V, uint64_t *seen, uint64_t *a, uint64_t *b)
{
    if (V > UINT64_C(1) << 32) return PDLA_EINVAL; /* sites are 32-bit */
    uint64_t *own = seen ? NULL : calloc((size_t)((V + 63) / 64) + 1, sizeof *own);
    if (!seen && !own) return PDLA_ENOMEM;
    uint64_t *bits = seen ? seen : own;
    uint64_t m = 0;
    int rc = 0;
    for (; m < n && !rc; m++) {
        const uint64_t k = site[m], bit = UINT64_C(1) << (k & 63);
        if (k >= V) {
            rc = PDLA_EINVAL;
            break;
        }
        rc = (bits[k >> 6] & bit) != 0;
        bits[k >> 6] |= bit;
    }
    if (rc == 1) {
        *b = m - 1;
        for (*a = 0; site[*a] != site[*b]; ++*a) continue;
    }
    if (seen)
        for (uint64_t j = 0; j < m; j++) seen[site[j] >> 6] = 0; /* only these sites' bits were set */
    free(own);
    return rc;
}

int dlca_read_start(const char *path, const dlca_params *p, uint32_t **sites, uint64_t *n, char *err, size_t errlen)
{
    *sites = NULL;
    *n = 0;
    /* Regular files only: opening a FIFO blocked for ever, and a directory
     * read as "read error", exit 1 (found by an adversarial test). */
    struct stat st;
    if (stat(path, &st) != 0)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot read start file %s: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "start file %s is not a regular file", path);
    FILE *f = fopen(path, "rb");
    if (!f) return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot read start file %s: %s", path, strerror(errno));
    unsigned char magic[8] = {0};
    const int is_h5 = fread(magic, 1, 8, f) == 8 && memcmp(magic, "\x89HDF\r\n\x1a\n", 8) == 0;
    rewind(f);
    /* The bit lattice first: the run's own size (dlca_params_validate_start
     * has held the box against the memory); where only for text lines. */
    start_buf b = {.path = path, .unit = is_h5 ? "monomer" : "line"};
    b.seen = calloc((size_t)((box_sites(p) + 63) / 64), sizeof *b.seen);
    b.where = is_h5 ? NULL : malloc(sizeof *b.where);
    int rc = !b.seen || (!is_h5 && !b.where) ? pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path) : 0;
    if (rc == 0) rc = is_h5 ? read_h5(path, p, &b, err, errlen) : read_text(f, path, p, &b, err, errlen);
    fclose(f);
    if (rc == 0 && b.n == 0) rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: no monomers in it", path);
    if (rc == 0 && b.n >= UINT32_MAX) rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: too many monomers", path);
    free(b.where);
    free(b.seen);
    if (rc) {
        free(b.site);
        return rc;
    }
    *sites = b.site;
    *n = b.n;
    return 0;
}
