/*
 * dlca_h5.h - /parameters of a DLCA file, written and read through the
 * model's descriptor table (dlca_output.c). Internal to libpdla.
 */
#ifndef PDLA_DLCA_H5_H
#define PDLA_DLCA_H5_H
#include "h5util.h"
#include "pdla/dlca.h"

int dlca_write_parameters_h5(const h5u_writer *w, hid_t file, const dlca_params *p);
/* 0, or -1 if an attribute is missing or refused by the table's parser. */
int dlca_read_parameters_h5(hid_t file, dlca_params *p);

#endif
