/*
 * params_h5.h - reading one row of a parameter table (params.h) back from a
 * /parameters group, for every model's checkpoint and file readers: the
 * inverse of h5u_write_param_table (h5util.h). Internal to libpdla.
 */
#ifndef PDLA_PARAMS_H5_H
#define PDLA_PARAMS_H5_H

#include <hdf5.h>

#include "pdla/params.h"

/* The attribute of row d in group g into the struct s, with exactly the
 * type the writer gives it (a BOX: as many uint64 lengths as the row's
 * count field, read before, says). A row with absent_default whose
 * attribute is missing reads as its default. 0, or -1 if missing or not as
 * written. */
int pdla_param_read_h5(hid_t g, const pdla_param_desc *d, void *s);

#endif
