/*
 * dlca_check_pos.c - the reader of each snapshot's /snapshots/<i>/position
 * for `pdla check` of DLCA files (dlca_check.h, dck_pos_*). dlca_check.c
 * compares what it reads with the coordinates the writer derives from the
 * snapshot's sites; the resume reads no position, so nothing else reads
 * them. Each dataset is opened through the checked readers (pdla/h5check.h)
 * and held to what pdla writes (dlca_output.c, write_snapshot) before a row
 * is read: int32, N rows of d, chunks of at most 65536 rows of d (so a
 * forged chunk of 2^22 rows, which HDF5 decompresses whole to read any row
 * of it, is refused, not held), and storing what it declares. Its own file
 * because it uses nothing of the check's core, which uses it.
 */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "dlca_check.h"

/* The rows of a chunk pdla writes (h5u_dataset: at most 65536 rows). */
#define POS_CHUNK_MAX 65536

int dck_pos_open(dck_pos *p, const char *path, char *why, size_t len)
{
    memset(p, 0, sizeof *p);
    p->f = H5I_INVALID_HID;
    if (h5u_silence(&p->q)) {
        snprintf(why, len, "cannot silence HDF5 to read the snapshots' positions");
        return -1;
    }
    p->f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (p->f >= 0) return 0;
    snprintf(why, len, "cannot open the file again to read the snapshots' positions%s",
             h5u_restore(&p->q) < 0 ? " (nor restore HDF5's error printing)" : "");
    return -1;
}

static int pos_close_dset(dck_pos *p)
{
    if (!p->open) return 0;
    p->open = 0;
    return pdla_h5_dset_close(&p->d);
}

/* Why d (the dataset name, of snapshot N rows of dims columns) is not as
 * pdla writes it, into why; 0 when it is. */
static int pos_fault(const pdla_h5_dset *d, const char *name, uint64_t N, int dims, char *why, size_t len)
{
    uint64_t cd[PDLA_H5_MAX_RANK] = {0};
    int stored, crank;
    if (!pdla_h5_dset_is(d, PDLA_H5_I32) || d->rank != 2 || d->dims[0] != N || d->dims[1] != (uint64_t)dims)
        snprintf(why, len, "%s is not int32 of %" PRIu64 " x %d, as pdla writes it (rank %d, %" PRIu64 " rows)", name,
                 N, dims, d->rank, d->rank ? d->dims[0] : 0);
    else if ((stored = pdla_h5_dset_stored(d, sizeof(int32_t))) != PDLA_H5_STORED)
        snprintf(why, len, "%s declares %" PRIu64 " elements, more than the file stores (damaged or forged)", name,
                 d->elems);
    else if ((crank = pdla_h5_dset_chunk(d, cd)) < 0)
        snprintf(why, len, "cannot read how %s is stored", name);
    else if (crank == 2 && (cd[0] > POS_CHUNK_MAX || cd[1] > (uint64_t)dims))
        snprintf(why, len, "%s is stored in chunks of %" PRIu64 " rows of %" PRIu64 ", more than the %d of %d pdla "
                 "writes", name, cd[0], cd[1], POS_CHUNK_MAX, dims);
    else
        return 0;
    return -1;
}

int dck_pos_snapshot(dck_pos *p, size_t i, uint64_t N, int dims, char *why, size_t len)
{
    char name[48];
    snprintf(name, sizeof name, "/snapshots/%zu/position", i);
    if (pos_close_dset(p) < 0) {
        snprintf(why, len, "cannot close the position dataset before %s", name);
        return -1;
    }
    /* no such link, or not a dataset whose type and space read back: the
     * writer makes one in every snapshot */
    if (pdla_h5_dset_open(p->f, name + 1, &p->d) < 0) {
        snprintf(why, len, "%s is missing or not a dataset (pdla writes one in every snapshot)", name);
        return -1;
    }
    p->open = 1;
    return pos_fault(&p->d, name, N, dims, why, len);
}

int dck_pos_read(const dck_pos *p, uint64_t r0, uint64_t n, int32_t *buf)
{
    return p->open ? pdla_h5_dset_read(&p->d, PDLA_H5_I32, r0, n, buf) : -1;
}

int dck_pos_close(dck_pos *p)
{
    int rc = pos_close_dset(p);
    if (p->f >= 0 && H5Fclose(p->f) < 0) rc = -1;
    p->f = H5I_INVALID_HID;
    if (h5u_restore(&p->q) < 0) rc = -1;
    return rc;
}
