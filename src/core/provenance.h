/*
 * provenance.h - gathers the facts that say how and where a result was made
 * (code version, git revision, compiler and flags, library versions, machine
 * topology, host, time), as fixed-size strings for the output file's /Code
 * group. Internal to libpdla.
 */
#ifndef PDLA_PROVENANCE_H
#define PDLA_PROVENANCE_H

#include <stddef.h>

/* Every field is a NUL-terminated string; a fact that could not be found
 * reads "unknown" (never empty), so a reader can tell it was looked for.
 * Long values (build flags, topology) are cut to fit. */
typedef struct pdla_provenance {
    char version[32];        /* pdla version, e.g. "0.1.0" */
    char git_revision[64];   /* `git describe --always --dirty` at build time */
    char compiler[128];      /* e.g. "gcc 12.2.0" */
    char build_flags[1024];  /* c_args, buildtype, optimization, sanitizers */
    char hdf5_version[32];   /* of the library linked at run time, "1.10.8" */
    char hwloc_version[32];  /* run-time hwloc API version, "2.9.0" */
    char topology[256];      /* "1 package, 8 cores, 16 PUs, L3 1 x 32 MiB" */
    char host[256];          /* gethostname() */
    char created_utc[32];    /* "YYYY-MM-DDTHH:MM:SSZ", always 20 characters;
                                SOURCE_DATE_EPOCH (seconds) overrides the clock */
} pdla_provenance;

/* Fills *out. Never fails as a whole: returns the number of facts that fell
 * back to "unknown" (0 when everything was found). */
int prov_collect(pdla_provenance *out);

#endif /* PDLA_PROVENANCE_H */
