/*
 * dlca_h5.h - /parameters of a DLCA file, written and read through the
 * model's descriptor table (dlca_output.c). Internal to libpdla.
 */
#ifndef PDLA_DLCA_H5_H
#define PDLA_DLCA_H5_H
#include "h5util.h"
#include "pdla/dlca.h"

int dlca_write_parameters_h5(const h5u_writer *w, hid_t file, const dlca_params *p);
/* 0, or -1 if an attribute is missing or refused by the table's parser,
 * or the parameters by dlca_params_validate (monomers 1: a checkpoint,
 * whose count or fill gives N) or dlca_params_validate_start (0: a
 * cluster.h5, whose run may have had its monomers from a --start file, so
 * that count and fill need not give them). */
int dlca_read_parameters_h5(hid_t file, dlca_params *p, int monomers);
#endif
