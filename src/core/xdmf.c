/*
 * xdmf.c - XDMF 2 sidecars for particle files (see xdmf.h for what ParaView
 * 5.11 reads and why the items look as they do).
 */
#include "pdla/xdmf.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "h5util.h"

/* The suffix of each kind of sidecar (enum xdmf_sidecar_kind): the one
 * list the models' writers name their sidecars by and xdmf_remove_sidecars
 * removes from. */
static const char *const sidecar_suffix[XDMF_SIDECAR_KINDS] = {".xdmf2", "-free.xdmf2"};

int xdmf_sidecar_name(const char *h5_path, int kind, char *out, size_t len)
{
    if (kind < 0 || kind >= XDMF_SIDECAR_KINDS) return -1;
    const size_t n = strlen(h5_path);
    const size_t stem = n >= 3 && strcmp(h5_path + n - 3, ".h5") == 0 ? n - 3 : n;
    const int w = snprintf(out, len, "%.*s%s", (int)stem, h5_path, sidecar_suffix[kind]);
    return w < 0 || (size_t)w >= len ? -1 : 0;
}

int xdmf_sidecar_path(const char *h5_path, char *out, size_t len)
{
    return xdmf_sidecar_name(h5_path, XDMF_SIDECAR_MAIN, out, len);
}

/* The folder of path (malloc'ed; "." for a bare name), or NULL. */
static char *dir_of(const char *path)
{
    const char *const ds = strrchr(path, '/');
    if (!ds) return strdup(".");
    const size_t dl = ds == path ? 1 : (size_t)(ds - path);
    char *const dir = malloc(dl + 1);
    if (dir) {
        memcpy(dir, path, dl);
        dir[dl] = '\0';
    }
    return dir;
}

/* Removes path, a sidecar that would describe another file, and syncs its
 * folder as the writers sync theirs after the rename, so that a crash does
 * not bring it back beside the new file. Missing is fine. 0 or -1 with err. */
static int remove_stale(const char *path, char *err, size_t errlen)
{
    if (unlink(path) != 0)
        return errno == ENOENT ? 0 : pdla_errorf(-1, err, errlen, "cannot remove the stale sidecar %s: %s", path,
                                                 strerror(errno));
    char *const dir = dir_of(path);
    int rc = 0;
    if (!dir || h5u_fsync_dir(dir) != 0)
        rc = pdla_errorf(-1, err, errlen, "removed the stale sidecar %s, but cannot sync its directory: %s", path,
                         dir ? strerror(errno) : "out of memory");
    free(dir);
    return rc;
}

int xdmf_remove_sidecars(const char *h5_path, unsigned written, char *err, size_t errlen)
{
    const size_t len = strlen(h5_path) + 32;
    char *const p = malloc(len);
    if (!p) return pdla_errorf(-1, err, errlen, "out of memory for the sidecars' names");
    int rc = 0;
    for (int k = 0; k < XDMF_SIDECAR_KINDS && !rc; k++) {
        if (written & XDMF_SIDECAR_BIT(k)) continue;
        (void)xdmf_sidecar_name(h5_path, k, p, len); /* len always fits */
        rc = remove_stale(p, err, errlen);
    }
    free(p);
    return rc;
}

/* The sidecar's text, streamed to its file through a buffer of SB_CAP bytes
 * written with write(2) whenever it fills: memory stays the same for any
 * length of text (an ensemble's is about 2.6 kB a cluster: 2.6 GB for 10^6
 * clusters, which the whole text in memory took, twice over while it grew),
 * and the run's one stdio file stays summary.txt. */
#define SB_CAP 65536

struct xdmf_out {
    int fd;
    char *p;
    size_t n, cap;
    int err; /* errno of the first failure (ENOMEM too); nothing more is written after one */
};
typedef struct xdmf_out sbuf;

/* Writes out what b holds. */
static void sb_flush(sbuf *b)
{
    for (size_t done = 0; done < b->n && !b->err;) {
        const ssize_t w = write(b->fd, b->p + done, b->n - done);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) b->err = w < 0 ? errno : EIO;
        else done += (size_t)w;
    }
    b->n = 0;
}

static void sb_vprintf(sbuf *b, const char *fmt, va_list ap0)
{
    while (!b->err) {
        va_list ap;
        va_copy(ap, ap0);
        const int w = vsnprintf(b->p + b->n, b->cap - b->n, fmt, ap);
        va_end(ap);
        if (w < 0) {
            b->err = EINVAL;
            return;
        }
        if ((size_t)w < b->cap - b->n) {
            b->n += (size_t)w;
            return;
        }
        /* It did not fit: out with what is there, then again; a piece
         * larger than the buffer (a long file name) gets a buffer of its
         * size, so memory follows the longest piece, not the text. */
        sb_flush(b);
        if (b->err || (size_t)w < b->cap) continue;
        char *const q = realloc(b->p, (size_t)w + 1);
        if (!q) b->err = ENOMEM;
        else {
            b->p = q;
            b->cap = (size_t)w + 1;
        }
    }
}

static void sb_printf(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sb_vprintf(b, fmt, ap);
    va_end(ap);
}

void xdmf_printf(xdmf_out *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sb_vprintf(o, fmt, ap);
    va_end(ap);
}

/* s with the XML special characters escaped (it goes into element text). */
static void put_escaped(sbuf *fp, const char *s)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': sb_printf(fp, "&amp;"); break;
        case '<': sb_printf(fp, "&lt;"); break;
        case '>': sb_printf(fp, "&gt;"); break;
        case '"': sb_printf(fp, "&quot;"); break;
        default: sb_printf(fp, "%c", *s);
        }
    }
}

void xdmf_escaped(xdmf_out *o, const char *s)
{
    put_escaped(o, s);
}

/* The HDF5 reference "file.h5:/dataset", file relative to the sidecar. */
static void put_ref(sbuf *fp, const char *base, const char *dataset)
{
    put_escaped(fp, base);
    sb_printf(fp, ":");
    put_escaped(fp, dataset);
}

/* The whole positions dataset, converted to reals by HDF5 on reading. */
static void put_positions(sbuf *fp, const xdmf_points *p, const char *base, const char *indent)
{
    sb_printf(fp, "%s<DataItem Dimensions=\"%" PRIu64 " %d\" NumberType=\"Float\" Precision=\"8\" "
                "Format=\"HDF\">", indent, p->n, p->dim);
    put_ref(fp, base, p->positions);
    sb_printf(fp, "</DataItem>\n");
}

/* Rows [row0, row0 + n) of a [rows][dim] positions dataset: the points of
 * one grid (all rows of a cluster file, one cluster of an ensemble). */
typedef struct slab_src {
    const char *base, *dataset;
    uint64_t rows, row0, n;
    int dim;
} slab_src;

/* Columns [col, col + ncols) of s's rows, as a HyperSlab item (start,
 * stride, count), depth spaces in. */
static void put_slab(sbuf *fp, const slab_src *s, int col, int ncols, int depth)
{
    sb_printf(fp, "%*s<DataItem ItemType=\"HyperSlab\" Type=\"HyperSlab\" Dimensions=\"%" PRIu64 " %d\">\n"
                  "%*s <DataItem Dimensions=\"3 2\" Format=\"XML\">%" PRIu64 " %d 1 1 %" PRIu64 " %d</DataItem>\n"
                  "%*s <DataItem Dimensions=\"%" PRIu64 " %d\" NumberType=\"Float\" Precision=\"8\" "
                  "Format=\"HDF\">",
              depth, "", s->n, ncols, depth, "", s->row0, col, s->n, ncols, depth, "", s->rows, s->dim);
    put_ref(fp, s->base, s->dataset);
    sb_printf(fp, "</DataItem>\n%*s</DataItem>\n", depth, "");
}

/* Column c of a one-point grid as a [2][1] item: its row stacked on itself
 * (";" in XDMF 2 concatenates) and column c of that taken. The XDMF 2
 * reader (ParaView 5.11) puts an argument of one element into a Function as
 * a number, printed with 6 digits (1e+06 and up crash the parse); a
 * Function whose every argument is one element is a scalar expression it
 * cannot evaluate ("XdmfExpr : syntax error", the array comes out empty).
 * Two copies of the point keep every argument an array. */
static void put_column2(sbuf *fp, const slab_src *s, int c, int depth)
{
    sb_printf(fp, "%*s<DataItem ItemType=\"HyperSlab\" Type=\"HyperSlab\" Dimensions=\"2 1\">\n"
                  "%*s <DataItem Dimensions=\"3 2\" Format=\"XML\">0 %d 1 1 2 1</DataItem>\n"
                  "%*s <DataItem ItemType=\"Function\" Function=\"$0 ; $0\" Dimensions=\"2 %d\">\n",
              depth, "", depth, "", c, depth, "", s->dim);
    put_slab(fp, s, 0, s->dim, depth + 2);
    sb_printf(fp, "%*s </DataItem>\n%*s</DataItem>\n", depth, "", depth, "");
}

/* "distance": |position| / units_per_diameter at every point. */
static void put_distance(sbuf *fp, const slab_src *s, int units_per_diameter, int depth)
{
    /* Lower-case sqrt: the XDMF 2 parser reads SQRT as no function. */
    const char *const sum = s->dim == 3 ? "$0 * $0 + $1 * $1 + $2 * $2" : "$0 * $0 + $1 * $1";
    sb_printf(fp, "%*s<Attribute Name=\"distance\" AttributeType=\"Scalar\" Center=\"Node\">\n", depth, "");
    if (s->n > 1) {
        sb_printf(fp, "%*s<DataItem ItemType=\"Function\" Function=\"sqrt(%s) / %d\" Dimensions=\"%" PRIu64 "\">\n",
                  depth + 1, "", sum, units_per_diameter, s->n);
        for (int c = 0; c < s->dim; c++) put_slab(fp, s, c, 1, depth + 2);
        sb_printf(fp, "%*s</DataItem>\n", depth + 1, "");
    } else {
        /* One point: the distance of its two copies (put_column2), the
         * first of them taken. */
        sb_printf(fp, "%*s<DataItem ItemType=\"HyperSlab\" Type=\"HyperSlab\" Dimensions=\"1\">\n"
                      "%*s <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 1</DataItem>\n"
                      "%*s <DataItem ItemType=\"Function\" Function=\"sqrt(%s) / %d\" Dimensions=\"2\">\n",
                  depth + 1, "", depth + 1, "", depth + 1, "", sum, units_per_diameter);
        for (int c = 0; c < s->dim; c++) put_column2(fp, s, c, depth + 3);
        sb_printf(fp, "%*s </DataItem>\n%*s</DataItem>\n", depth + 1, "", depth + 1, "");
    }
    sb_printf(fp, "%*s</Attribute>\n", depth, "");
}

/* The attribute name (escaped) holding 0..n-1 at s's points. */
static void put_row_index(sbuf *fp, const slab_src *s, const char *name, int depth)
{
    sb_printf(fp, "%*s<Attribute Name=\"", depth, "");
    put_escaped(fp, name);
    sb_printf(fp, "\" AttributeType=\"Scalar\" Center=\"Node\">\n");
    if (s->n > 1) {
        /* XDMF 2 has no "range" item; WHERE over a test every row passes
         * gives the row numbers 0..n-1 in order (64-bit integers). */
        sb_printf(fp, "%*s<DataItem ItemType=\"Function\" Function=\"WHERE($0 * $0 &gt;= 0)\" "
                      "Dimensions=\"%" PRIu64 "\">\n",
                  depth + 1, "", s->n);
        put_slab(fp, s, 0, 1, depth + 2);
        sb_printf(fp, "%*s</DataItem>\n", depth + 1, "");
    } else {
        /* One point: its index written out (a Function over one element
         * fails, see put_column2). */
        sb_printf(fp, "%*s<DataItem Dimensions=\"1\" NumberType=\"Int\" Precision=\"8\" Format=\"XML\">0</DataItem>\n",
                  depth + 1, "");
    }
    sb_printf(fp, "%*s</Attribute>\n", depth, "");
}

/* The sidecar of the xdmf_points at arg. */
static void put_body(sbuf *fp, const void *arg)
{
    const xdmf_points *const p = arg;
    const char *const slash = strrchr(p->h5_path, '/');
    const char *const base = slash ? slash + 1 : p->h5_path;
    sb_printf(fp, "<?xml version=\"1.0\" ?>\n"
                "<!-- pdla: particles of ");
    put_escaped(fp, base);
    /* "diameters" only where the file has a resolution; the event and
     * DLCA models pass 1 and keep their own length unit (model length,
     * lattice spacing). */
    if (p->units_per_diameter > 1)
        sb_printf(fp, " for ParaView's \"XDMF Reader\" (XDMF 2); positions in diameters -->\n");
    else
        sb_printf(fp, " for ParaView's \"XDMF Reader\" (XDMF 2); positions in the file's length unit -->\n");
    sb_printf(fp,
                "<Xdmf Version=\"2.0\">\n <Domain>\n  <Grid Name=\"particles\" GridType=\"Uniform\">\n"
                "   <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%" PRIu64
                "\" NodesPerElement=\"1\"/>\n"
                "   <Geometry GeometryType=\"%s\">\n"
                "    <DataItem ItemType=\"Function\" Function=\"$0 / %d\" Dimensions=\"%" PRIu64
                " %d\">\n",
            p->n, p->dim == 3 ? "XYZ" : "XY", p->units_per_diameter, p->n, p->dim);
    put_positions(fp, p, base, "     ");
    sb_printf(fp, "    </DataItem>\n   </Geometry>\n");

    const slab_src s = {base, p->positions, p->n, 0, p->n, p->dim};
    if (p->distance) put_distance(fp, &s, p->units_per_diameter, 3);
    if (p->row_index) put_row_index(fp, &s, p->row_index, 3);
    for (size_t i = 0; i < p->narrays; i++) {
        const xdmf_array *const a = &p->arrays[i];
        sb_printf(fp, "   <Attribute Name=\"");
        put_escaped(fp, a->name);
        sb_printf(fp, "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                    "    <DataItem Dimensions=\"%" PRIu64 "\" NumberType=\"%s\" Precision=\"%d\" "
                    "Format=\"HDF\">",
                p->n, a->number_type, a->precision);
        put_ref(fp, base, a->dataset);
        sb_printf(fp, "</DataItem>\n   </Attribute>\n");
    }
    sb_printf(fp, "  </Grid>\n </Domain>\n</Xdmf>\n");
}

static int check(const xdmf_points *p, char *err, size_t errlen)
{
    if (!p || !p->h5_path || !p->positions || p->positions[0] != '/')
        return pdla_errorf(-1, err, errlen, "xdmf: no HDF5 file or no absolute positions dataset given");
    if (p->dim != 2 && p->dim != 3) return pdla_errorf(-1, err, errlen, "xdmf: dim %d, want 2 or 3", p->dim);
    if (p->units_per_diameter < 1)
        return pdla_errorf(-1, err, errlen, "xdmf: units per diameter %d, want >= 1", p->units_per_diameter);
    for (size_t i = 0; i < p->narrays; i++) {
        const xdmf_array *const a = &p->arrays[i];
        const int pr = a->precision;
        if (!a->name || !a->dataset || a->dataset[0] != '/' || !a->number_type ||
            (pr != 1 && pr != 2 && pr != 4 && pr != 8))
            return pdla_errorf(-1, err, errlen, "xdmf: array %zu is incomplete", i);
    }
    return 0;
}

/* Every sidecar's one way to its file (xdmf.h). */
int xdmf_write_text(const char *xmf_path, void (*body)(xdmf_out *, const void *), const void *arg, char *err,
                    size_t errlen)
{
    const size_t len = strlen(xmf_path);
    char *const tmp = malloc(len + 32), *const dir = dir_of(xmf_path);
    sbuf b = {-1, malloc(SB_CAP), 0, SB_CAP, 0};
    int rc = -1, renamed = 0;
    if (!tmp || !dir || !b.p) {
        pdla_errorf(-1, err, errlen, "out of memory for the sidecar %s", xmf_path);
        goto out;
    }
    snprintf(tmp, len + 32, "%s.tmp.%ld", xmf_path, (long)getpid());
    b.fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (b.fd < 0) {
        pdla_errorf(-1, err, errlen, "cannot create %s: %s", tmp, strerror(errno));
        goto out;
    }
    body(&b, arg);
    sb_flush(&b);
    int bad = b.err;
    if (!bad && fsync(b.fd) != 0) bad = errno;
    if (close(b.fd) != 0 && !bad) bad = errno;
    if (bad) {
        pdla_errorf(-1, err, errlen, "cannot write %s: %s", tmp, strerror(bad));
        unlink(tmp);
        goto out;
    }
    if (rename(tmp, xmf_path) != 0) {
        pdla_errorf(-1, err, errlen, "cannot rename %s to %s: %s", tmp, xmf_path, strerror(errno));
        unlink(tmp);
        goto out;
    }
    renamed = 1;
    if (h5u_fsync_dir(dir) != 0) {
        pdla_errorf(-1, err, errlen, "written, but cannot sync directory %s: %s", dir, strerror(errno));
        goto out;
    }
    rc = 0;
out:
    /* An older sidecar left in place would describe the previous HDF5
     * file (another N): none is better than a stale one. */
    if (rc < 0 && !renamed && unlink(xmf_path) != 0 && errno != ENOENT && err && errlen) {
        const size_t used = strlen(err);
        snprintf(err + used, errlen - used, "; the old %s is left", xmf_path);
    }
    free(tmp);
    free(dir);
    free(b.p);
    return rc;
}

int xdmf_write_points(const char *xmf_path, const xdmf_points *p, char *err, size_t errlen)
{
    if (check(p, err, errlen) < 0) return -1;
    if (!xmf_path || !xmf_path[0]) return pdla_errorf(-1, err, errlen, "xdmf: no sidecar path given");
    if (p->n == 0) return remove_stale(xmf_path, err, errlen); /* no points: an older one is another file's */
    return xdmf_write_text(xmf_path, put_body, p, err, errlen);
}

int xdmf_write_cluster(const char *h5_path, uint64_t n, int dim, int units_per_diameter,
                       int arrival, char *err, size_t errlen)
{
    const size_t len = strlen(h5_path) + 8;
    char *const xmf = malloc(len);
    if (!xmf) return pdla_errorf(-1, err, errlen, "out of memory for the sidecar's name");
    (void)xdmf_sidecar_path(h5_path, xmf, len); /* len always fits */
    const xdmf_points p = {h5_path, "/cluster/positions", n, dim, units_per_diameter, 1,
                           arrival ? "arrival" : NULL, NULL, 0};
    int rc = xdmf_write_points(xmf, &p, err, errlen);
    free(xmf);
    /* A DLA file has no free particles: an event run's -free sidecar of an
     * older cluster.h5 goes, also when the first failed (its message kept). */
    char rerr[512];
    if (xdmf_remove_sidecars(h5_path, XDMF_SIDECAR_BIT(XDMF_SIDECAR_MAIN), rerr, sizeof rerr) && !rc)
        rc = pdla_errorf(-1, err, errlen, "%s", rerr);
    return rc;
}

/* ---- ensembles --------------------------------------------------------------- */

/* One cluster's grid: rows [i n, i n + n). */
static void put_cluster(sbuf *fp, const xdmf_ensemble *e, const char *base, uint64_t i)
{
    const slab_src s = {base, e->positions, e->clusters * e->n, i * e->n, e->n, e->dim};
    sb_printf(fp, "   <Grid Name=\"cluster %" PRIu64 "\" GridType=\"Uniform\">\n"
                  "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%" PRIu64
                  "\" NodesPerElement=\"1\"/>\n"
                  "    <Geometry GeometryType=\"%s\">\n"
                  "     <DataItem ItemType=\"Function\" Function=\"$0 / %d\" Dimensions=\"%" PRIu64 " %d\">\n",
              i, e->n, e->dim == 3 ? "XYZ" : "XY", e->units_per_diameter, e->n, e->dim);
    put_slab(fp, &s, 0, e->dim, 6);
    sb_printf(fp, "     </DataItem>\n    </Geometry>\n");
    /* The cluster id on every point, so that the merged blocks can still be
     * told apart (colour by it, or Threshold it). */
    sb_printf(fp, "    <Attribute Name=\"cluster\" AttributeType=\"Scalar\" Center=\"Node\">\n");
    if (e->n > 1) {
        sb_printf(fp, "     <DataItem ItemType=\"Function\" Function=\"0 * $0 + %" PRIu64 "\" Dimensions=\"%" PRIu64
                      "\">\n",
                  i, e->n);
        put_slab(fp, &s, 0, 1, 6);
        sb_printf(fp, "     </DataItem>\n");
    } else {
        /* One point: the id written out (a Function over one element
         * fails, see put_column2), a real like the Function's. */
        sb_printf(fp, "     <DataItem Dimensions=\"1\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">%" PRIu64
                      "</DataItem>\n",
                  i);
    }
    sb_printf(fp, "    </Attribute>\n");
    put_distance(fp, &s, e->units_per_diameter, 4);
    /* 0..n-1 within the cluster. */
    if (e->arrival) put_row_index(fp, &s, "arrival", 4);
    sb_printf(fp, "   </Grid>\n");
}

/* The sidecar of the xdmf_ensemble at arg, a cluster at a time. */
static void put_ensemble(sbuf *fp, const void *arg)
{
    const xdmf_ensemble *const e = arg;
    const char *const slash = strrchr(e->h5_path, '/');
    const char *const base = slash ? slash + 1 : e->h5_path;
    sb_printf(fp, "<?xml version=\"1.0\" ?>\n<!-- pdla: the clusters of ");
    put_escaped(fp, base);
    sb_printf(fp, " for ParaView's \"XDMF Reader\" (XDMF 2): one block per cluster, positions in %s -->\n"
                  "<Xdmf Version=\"2.0\">\n <Domain>\n"
                  "  <Grid Name=\"clusters\" GridType=\"Collection\" CollectionType=\"Spatial\">\n",
              e->units_per_diameter > 1 ? "diameters" : "the file's length unit");
    for (uint64_t i = 0; i < e->clusters && !fp->err; i++) put_cluster(fp, e, base, i);
    sb_printf(fp, "  </Grid>\n </Domain>\n</Xdmf>\n");
}

int xdmf_write_ensemble(const char *xmf_path, const xdmf_ensemble *e, char *err, size_t errlen)
{
    if (!xmf_path || !xmf_path[0] || !e || !e->h5_path || !e->positions || e->positions[0] != '/')
        return pdla_errorf(-1, err, errlen, "xdmf: no sidecar, HDF5 file or absolute positions dataset given");
    if (e->dim != 2 && e->dim != 3) return pdla_errorf(-1, err, errlen, "xdmf: dim %d, want 2 or 3", e->dim);
    if (e->units_per_diameter < 1)
        return pdla_errorf(-1, err, errlen, "xdmf: units per diameter %d, want >= 1", e->units_per_diameter);
    if (e->clusters == 0 || e->n == 0 || e->n > UINT64_MAX / e->clusters)
        return pdla_errorf(-1, err, errlen, "xdmf: %" PRIu64 " clusters of %" PRIu64 " points: nothing to show",
                    e->clusters, e->n);
    return xdmf_write_text(xmf_path, put_ensemble, e, err, errlen);
}
