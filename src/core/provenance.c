/*
 * provenance.c - collects the provenance strings of pdla_provenance: build
 * facts from the generated headers, run-time versions of HDF5 and hwloc, a
 * one-line hwloc topology summary, the host name and the UTC time (or
 * SOURCE_DATE_EPOCH when set).
 *
 * Nothing here may make a write fail: a fact that cannot be found becomes
 * "unknown" and is counted, so the output still says that it was looked for.
 */
#include "provenance.h"

#include <errno.h>
#include <hdf5.h>
#include <hwloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "pdla_config.h"
#include "pdla/pdla.h"
#include "pdla_git_rev.h"

static const char unknown[] = "unknown";

/* snprintf into a field, reporting truncation as success: a cut string is
 * still better provenance than none. Returns 0, or 1 when nothing usable was
 * written (an encoding error) and the field was set to "unknown". */
static int set_str(char *dst, size_t cap, const char *src)
{
    if (src == NULL || src[0] == '\0') {
        snprintf(dst, cap, "%s", unknown);
        return 1;
    }
    if (snprintf(dst, cap, "%s", src) < 0) {
        snprintf(dst, cap, "%s", unknown);
        return 1;
    }
    return 0;
}

static int hdf5_version(char *dst, size_t cap)
{
    unsigned maj = 0, min = 0, rel = 0;
    /* The run-time library, not H5_VERS_*: a file is written by the library
     * actually loaded, which can differ from the headers after an upgrade. */
    if (H5get_libversion(&maj, &min, &rel) < 0) return set_str(dst, cap, NULL);
    snprintf(dst, cap, "%u.%u.%u", maj, min, rel);
    return 0;
}

static int hwloc_version(char *dst, size_t cap)
{
    /* hwloc only exposes its API version at run time (e.g. 2.8.0 for the
     * 2.9 releases), so the string says so rather than pose as the release. */
    const unsigned v = hwloc_get_api_version();
    snprintf(dst, cap, "API %u.%u.%u", (v >> 16) & 0xffu, (v >> 8) & 0xffu, v & 0xffu);
    return 0;
}

/* Writes a size in bytes as KiB/MiB/GiB, whichever reads as a whole number
 * or is the largest below the value. */
static void format_bytes(char *dst, size_t cap, unsigned long long b)
{
    static const char *const unit[] = {"B", "KiB", "MiB", "GiB"};
    int u = 0;
    while (u < 3 && b >= 1024 && b % 1024 == 0) {
        b /= 1024;
        u++;
    }
    snprintf(dst, cap, "%llu %s", b, unit[u]);
}

static int topology_summary(char *dst, size_t cap)
{
    hwloc_topology_t topo;
    if (hwloc_topology_init(&topo) != 0) return set_str(dst, cap, NULL);
    /* Keep the load cheap: no I/O devices (already the default) and, of the
     * caches, only L3, the one level reported. Packages, cores and PUs are
     * always kept. The x86 CPUID backend adds nothing the summary needs
     * (Linux sysfs has it all) and prints a warning under Valgrind. Leaving
     * it out is optional: if that fails, the load simply uses it too. */
    (void)hwloc_topology_set_components(topo, HWLOC_TOPOLOGY_COMPONENTS_FLAG_BLACKLIST, "x86");
    if (hwloc_topology_set_io_types_filter(topo, HWLOC_TYPE_FILTER_KEEP_NONE) != 0 ||
        hwloc_topology_set_cache_types_filter(topo, HWLOC_TYPE_FILTER_KEEP_NONE) != 0 ||
        hwloc_topology_set_icache_types_filter(topo, HWLOC_TYPE_FILTER_KEEP_NONE) != 0 ||
        hwloc_topology_set_type_filter(topo, HWLOC_OBJ_L3CACHE, HWLOC_TYPE_FILTER_KEEP_ALL) != 0 ||
        hwloc_topology_load(topo) != 0)
        goto fail;

    const int packages = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_PACKAGE);
    const int cores = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_CORE);
    const int pus = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_PU);
    const int l3 = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_L3CACHE);
    /* -1 means the type sits at several depths: no single count exists. */
    if (packages < 0 || cores < 0 || pus <= 0 || l3 < 0) goto fail;

    char l3s[48] = "none";
    if (l3 > 0) {
        const hwloc_obj_t c = hwloc_get_obj_by_type(topo, HWLOC_OBJ_L3CACHE, 0);
        if (c == NULL || c->attr == NULL) goto fail;
        char size[24];
        format_bytes(size, sizeof size, (unsigned long long)c->attr->cache.size);
        snprintf(l3s, sizeof l3s, "%d x %s", l3, size);
    }
    snprintf(dst, cap, "%d package%s, %d core%s, %d PU%s, L3 %s", packages,
             packages == 1 ? "" : "s", cores, cores == 1 ? "" : "s", pus, pus == 1 ? "" : "s",
             l3s);
    hwloc_topology_destroy(topo);
    return 0;

fail:
    hwloc_topology_destroy(topo);
    return set_str(dst, cap, NULL);
}

static int host_name(char *dst, size_t cap)
{
    char h[256];
    if (gethostname(h, sizeof h) != 0) return set_str(dst, cap, NULL);
    h[sizeof h - 1] = '\0'; /* POSIX leaves a cut name unterminated */
    return set_str(dst, cap, h);
}

/* The creation time, or SOURCE_DATE_EPOCH (seconds since 1970, the
 * reproducible-builds convention) when that is set to a valid number, so
 * the same run can be written twice into byte-identical files. */
static time_t creation_time(void)
{
    const char *const sde = getenv("SOURCE_DATE_EPOCH");
    if (sde && *sde) {
        char *end = NULL;
        errno = 0;
        const long long v = strtoll(sde, &end, 10);
        if (errno == 0 && *end == '\0' && v >= 0 && (long long)(time_t)v == v) return (time_t)v;
    }
    return time(NULL);
}

static int utc_now(char *dst, size_t cap)
{
    const time_t t = creation_time();
    struct tm tm;
    if (t == (time_t)-1 || gmtime_r(&t, &tm) == NULL ||
        strftime(dst, cap, "%Y-%m-%dT%H:%M:%SZ", &tm) == 0)
        return set_str(dst, cap, NULL);
    return 0;
}

int prov_collect(pdla_provenance *out)
{
    int missing = 0;
    memset(out, 0, sizeof *out);
    missing += set_str(out->version, sizeof out->version, PDLA_VERSION);
    missing += set_str(out->git_revision, sizeof out->git_revision, PDLA_GIT_REV);
    missing += set_str(out->compiler, sizeof out->compiler, PDLA_COMPILER);
    /* Empty c_args leave a leading blank in the generated string. */
    const char *flags = PDLA_BUILD_FLAGS;
    while (*flags == ' ') flags++;
    missing += set_str(out->build_flags, sizeof out->build_flags, flags);
    missing += hdf5_version(out->hdf5_version, sizeof out->hdf5_version);
    missing += hwloc_version(out->hwloc_version, sizeof out->hwloc_version);
    missing += topology_summary(out->topology, sizeof out->topology);
    missing += host_name(out->host, sizeof out->host);
    missing += utc_now(out->created_utc, sizeof out->created_utc);
    return missing;
}

const char *pdla_build_compiler(void) { return PDLA_COMPILER; }
const char *pdla_build_revision(void) { return PDLA_GIT_REV; }
const char *pdla_build_flags(void) { return PDLA_BUILD_FLAGS; }
