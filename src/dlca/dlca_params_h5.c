/*
 * dlca_params_h5.c - a DLCA run's /parameters group, written and read
 * through the shared parameter machinery (h5u_write_param_table,
 * pdla_param_read_h5) from the model's rows. Its own file because both the
 * checkpoint (dlca.c) and cluster.h5 (dlca_output.c) use it, and
 * dlca_output.c reads the simulation (dlca.c): in dlca_output.c it made the
 * two files depend on each other (scripts/check-layers).
 */
#include "dlca_h5.h"
#include "h5util.h"
#include "params_h5.h"
#include "pdla/dlca.h"

int dlca_write_parameters_h5(const h5u_writer *w, hid_t file, const dlca_params *p)
{
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    return h5u_write_param_table(w, file, t, n, p);
}

int dlca_read_parameters_h5(hid_t file, dlca_params *p, int monomers)
{
    const hid_t g = H5Gopen2(file, "parameters", H5P_DEFAULT);
    if (g < 0) return -1;
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) rc = pdla_param_read_h5(g, &t[i], p);
    if (H5Gclose(g) < 0) rc = -1;
    if (rc) return -1;
    return (monomers ? dlca_params_validate(p, NULL, 0) : dlca_params_validate_start(p, NULL, 0)) == 0 ? 0 : -1;
}
