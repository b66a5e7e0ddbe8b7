/*
 * params_h5.c - one parameter row back from its /parameters attribute (see
 * params_h5.h); the DLA checkpoint and the DLCA files read through it.
 */
#include "params_h5.h"

#include <string.h>

#include "pdla/h5check.h"

static int read_box(hid_t g, const pdla_param_desc *d, void *s)
{
    pdla_h5_value v;
    const int n = *(const int *)((const char *)s + d->count_offset);
    if (pdla_h5_attr_value(g, d->name, &v) < 0 || !v.read || v.kind != 'u' || v.n != n || n < 1 ||
        n > PDLA_PARAM_BOX_MAX)
        return -1;
    uint32_t *L = (uint32_t *)((char *)s + d->offset);
    for (int i = 0; i < PDLA_PARAM_BOX_MAX; i++) {
        if (i < n && v.u[i] > UINT32_MAX) return -1;
        L[i] = i < n ? (uint32_t)v.u[i] : 0;
    }
    return 0;
}

int pdla_param_read_h5(hid_t g, const pdla_param_desc *d, void *s)
{
    if (d->absent_default && H5Aexists(g, d->name) == 0) {
        if (d->type == PDLA_PT_REAL) pdla_param_set_real(d, s, d->def_r);
        else pdla_param_set_u(d, s, d->def_u);
        return 0;
    }
    switch (d->type) {
    case PDLA_PT_U64: {
        uint64_t v;
        if (pdla_h5_attr_exact(g, d->name, PDLA_H5_U64, &v) < 0) return -1;
        pdla_param_set_u(d, s, v);
        return 0;
    }
    case PDLA_PT_REAL: {
        double v;
        if (pdla_h5_attr_exact(g, d->name, PDLA_H5_F64, &v) < 0) return -1;
        pdla_param_set_real(d, s, v);
        return 0;
    }
    case PDLA_PT_CHOICE: {
        char word[32];
        const int v = pdla_h5_attr_str(g, d->name, word, sizeof word) != 0 ? -1 : pdla_param_choice(d, word);
        if (v < 0) return -1;
        pdla_param_set_u(d, s, (uint64_t)v);
        return 0;
    }
    case PDLA_PT_BOX: return read_box(g, d, s);
    default: {
        int32_t v;
        if (pdla_h5_attr_exact(g, d->name, PDLA_H5_I32, &v) < 0) return -1;
        pdla_param_set_u(d, s, (uint64_t)(int64_t)v);
        return 0;
    }
    }
}
