/*
 * dlca_internal.h - hooks of the DLCA model for its tests: a chosen move of
 * a chosen cluster (to test wrapping at the box edges and corners) and
 * lookups by site. Internal to libpdla.
 */
#ifndef PDLA_DLCA_INTERNAL_H
#define PDLA_DLCA_INTERNAL_H

#include <stdint.h>

#include "pdla/dlca.h"

enum { DLCA_MOVED = 0, DLCA_REFUSED = 1, DLCA_NOT_PICKED = 2 };

/* Move the cluster that holds site k one step along axis (sign +1 or -1),
 * with joins as in a run. Returns DLCA_MOVED or DLCA_REFUSED (overlap), or
 * PDLA_EINVAL if no cluster holds k. */
int dlca_move_site(dlca_sim *s, uint32_t k, int axis, int sign);
/* Number of monomers of the cluster holding site k (0: empty). */
uint64_t dlca_size_at(const dlca_sim *s, uint32_t k);
/* Extent (bounding-box width in sites) along axis of the cluster holding k. */
int64_t dlca_extent_at(const dlca_sim *s, uint32_t k, int axis);
/* Site index of coordinates x[0..d). */
uint32_t dlca_site(const dlca_sim *s, const int64_t *x);
/* Would a run of V sites and N monomers fit in half of this machine's
 * memory (the bit lattice and about 32 bytes a monomer)? Its need in GiB
 * into *gib. dlca_params_validate and a --start file's declared N. */
int dlca_memory_fits(double V, uint64_t N, double *gib);
#endif
