/*
 * dlca_params_h5.c - a DLCA run's /parameters group, written and read from
 * the model's descriptor table. Its own file because both the checkpoint
 * (dlca.c) and cluster.h5 (dlca_output.c) use it, and dlca_output.c reads
 * the simulation (dlca.c): in dlca_output.c it made the two files depend on
 * each other (scripts/check-layers).
 */
#include <stdio.h>
#include <string.h>

#include "dlca_h5.h"
#include "h5util.h"
#include "pdla/dlca.h"

int dlca_write_parameters_h5(const h5u_writer *w, hid_t file, const dlca_params *p)
{
    hid_t g = h5u_group(w, file, "parameters");
    if (g < 0) return -1;
    size_t n;
    const dlca_param_desc *t = dlca_param_table(&n);
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        const char *f = (const char *)p + t[i].offset;
        char name[64];
        snprintf(name, sizeof name, "%s", t[i].name);
        for (char *c = name; *c; c++)
            if (*c == '-') *c = '_';
        switch (t[i].type) {
        case DLCA_T_INT: rc = h5u_attr_int(w, g, name, *(const int *)f); break;
        case DLCA_T_U64: rc = h5u_attr_u64(w, g, name, *(const uint64_t *)f); break;
        case DLCA_T_F64: rc = h5u_attr_f64(w, g, name, *(const double *)f); break;
        case DLCA_T_SEARCH: rc = h5u_attr_str(w, g, name, dlca_search_name(*(const int *)f)); break;
        case DLCA_T_BOX: {
            uint64_t L[DLCA_MAX_DIM];
            for (int a = 0; a < p->dim; a++) L[a] = ((const uint32_t *)f)[a];
            rc = h5u_attr_u64_array(w, g, name, L, (size_t)p->dim);
            break;
        }
        }
    }
    return h5u_close(w, rc < 0 ? -1 : 0, g, H5Gclose, "/parameters");
}

int dlca_read_parameters_h5(hid_t file, dlca_params *p)
{
    const hid_t g = H5Gopen2(file, "parameters", H5P_DEFAULT);
    if (g < 0) return -1;
    size_t n;
    const dlca_param_desc *t = dlca_param_table(&n);
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        char name[64], text[128];
        snprintf(name, sizeof name, "%s", t[i].name);
        for (char *c = name; *c; c++)
            if (*c == '-') *c = '_';
        const hid_t a = H5Aopen(g, name, H5P_DEFAULT);
        if (a < 0) {
            rc = -1;
            break;
        }
        char *f = (char *)p + t[i].offset;
        if (t[i].type == DLCA_T_INT) rc = H5Aread(a, H5T_NATIVE_INT, f) < 0 ? -1 : 0;
        else if (t[i].type == DLCA_T_U64) rc = H5Aread(a, H5T_NATIVE_UINT64, f) < 0 ? -1 : 0;
        else if (t[i].type == DLCA_T_F64) rc = H5Aread(a, H5T_NATIVE_DOUBLE, f) < 0 ? -1 : 0;
        else if (t[i].type == DLCA_T_SEARCH) {
            const hid_t ty = H5Aget_type(a);
            memset(text, 0, sizeof text);
            if (ty < 0 || H5Tis_variable_str(ty) || H5Tget_size(ty) >= sizeof text || H5Aread(a, ty, text) < 0 ||
                dlca_param_set(p, &t[i], text, NULL, 0))
                rc = -1;
            if (ty >= 0) H5Tclose(ty);
        } else {
            const hid_t sp = H5Aget_space(a);
            uint64_t L[DLCA_MAX_DIM] = {0};
            if (sp < 0 || H5Sget_simple_extent_npoints(sp) != p->dim || H5Aread(a, H5T_NATIVE_UINT64, L) < 0) rc = -1;
            for (int j = 0; j < DLCA_MAX_DIM; j++) ((uint32_t *)f)[j] = j < p->dim ? (uint32_t)L[j] : 0;
            if (sp >= 0) H5Sclose(sp);
        }
        H5Aclose(a);
    }
    H5Gclose(g);
    return rc == 0 && dlca_params_validate(p, NULL, 0) == 0 ? 0 : -1;
}
