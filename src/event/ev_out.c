/*
 * ev_out.c - cluster.h5 of the event model. Layout:
 *   /            attributes model = "event", dim, particles
 *   /parameters  one attribute per row of ev_param_table (typed; shared writer)
 *   /cluster     positions [k x dim], radii, arrival_time, parent (particle
 *                index; -1: the seed, -1-k: seed k of a --seeds file),
 *                species, index: the stuck particles in arrival order;
 *                attributes seed_x, seed_y[, seed_z], seed_radius (one
 *                seed); seed_positions, seed_radii (a --seeds file)
 *   /free        positions, velocities, radii, species of the free ones
 *   /series      time, stuck, kinetic_energy, collisions, pressure
 *   /species     count, radius, density, mass, stuck, sticky (per kind)
 *   /results     counters and energies (attributes)
 *   /Code        provenance
 * Written to PATH.tmp and renamed onto PATH when complete.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ev_internal.h"
#include "h5util.h"
#include "pdla/xdmf.h"
#include "provenance.h"

static int write_ds(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype,
                    int rank, size_t rows, size_t cols, const void *data)
{
    hid_t space = H5I_INVALID_HID;
    const hid_t d = h5u_dataset(w, g, name, ftype, rank, rows, cols, 4096, &space);
    if (d < 0) return -1;
    int rc = 0;
    if (rows > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
        rc = h5u_fail(w, "write dataset %s", name);
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

static int write_parameters(const h5u_writer *w, hid_t file, const ev_params *p)
{
    size_t n;
    const pdla_param_desc *t = ev_param_table(&n);
    return h5u_write_param_table(w, file, t, n, p);
}

/* The seeds of a --seeds file: /cluster/seed_positions [nseeds x dim] and
 * seed_radii, in the file's order (parent -1 - k is seed k). */
static int write_seeds(const h5u_writer *w, hid_t g, const ev_sim *s)
{
    const int D = s->dim;
    const size_t k = s->nseeds;
    double *pos = malloc((k ? k : 1) * (size_t)D * sizeof *pos), *rad = malloc((k ? k : 1) * sizeof *rad);
    int rc = pos && rad ? 0 : h5u_fail_msg(w, "out of memory writing the seeds");
    for (size_t a = 0; !rc && a < k; a++) {
        const double *p = EV_P(s, s->n + a);
        memcpy(pos + a * (size_t)D, p, (size_t)D * sizeof *pos);
        rad[a] = p[2 * D + 1];
    }
    if (!rc) rc = write_ds(w, g, "seed_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, k, (size_t)D, pos);
    if (!rc) rc = write_ds(w, g, "seed_radii", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, k, 1, rad);
    free(pos);
    free(rad);
    return rc;
}

static int write_cluster(const h5u_writer *w, hid_t file, const ev_sim *s)
{
    const int D = s->dim;
    const size_t k = s->nstuck;
    double *pos = malloc((k ? k : 1) * (size_t)D * sizeof *pos);
    double *rad = malloc((k ? k : 1) * sizeof *rad);
    int64_t *par = malloc((k ? k : 1) * sizeof *par);
    int32_t *spc = malloc((k ? k : 1) * sizeof *spc);
    uint32_t *idx = malloc((k ? k : 1) * sizeof *idx);
    int rc = -1;
    const hid_t g = h5u_group(w, file, "cluster");
    if (g < 0) goto out;
    if (!pos || !rad || !par || !spc || !idx) {
        rc = h5u_fail_msg(w, "out of memory writing /cluster");
        goto close;
    }
    for (size_t a = 0; a < k; a++) {
        const uint32_t i = s->stuck_idx[a];
        for (int q = 0; q < D; q++) pos[a * D + q] = EV_P(s, i)[q];
        rad[a] = EV_P(s, i)[2 * D + 1];
        /* a seed: -1 - its number (the central seed: -1) */
        par[a] = s->parent[i] >= s->n ? -1 - (int64_t)(s->parent[i] - s->n) : (int64_t)s->parent[i];
        spc[a] = s->species[i];
        idx[a] = i;
    }
    rc = write_ds(w, g, "positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, k, (size_t)D, pos);
    if (!rc) rc = write_ds(w, g, "radii", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, k, 1, rad);
    if (!rc)
        rc = write_ds(w, g, "arrival_time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, k, 1, s->stuck_t);
    if (!rc) rc = write_ds(w, g, "parent", H5T_STD_I64LE, H5T_NATIVE_INT64, 1, k, 1, par);
    if (!rc) rc = write_ds(w, g, "species", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, k, 1, spc);
    if (!rc) rc = write_ds(w, g, "index", H5T_STD_U32LE, H5T_NATIVE_UINT32, 1, k, 1, idx);
    if (!rc && s->par.seeds[0]) rc = write_seeds(w, g, s);
    if (!rc && s->nseeds == 1) {
        rc = h5u_attr_f64(w, g, "seed_radius", EV_P(s, s->n)[2 * D + 1]);
        for (int q = 0; q < D && !rc; q++) {
            static const char *nm[] = {"seed_x", "seed_y", "seed_z"};
            rc = h5u_attr_f64(w, g, nm[q], EV_P(s, s->n)[q]);
        }
    }
    if (!rc) rc = h5u_attr_str(w, g, "order", "arrival");
close:
    rc = h5u_close(w, rc, g, H5Gclose, "/cluster");
out:
    free(pos);
    free(rad);
    free(par);
    free(spc);
    free(idx);
    return rc;
}

/* Free particles at the current time (positions advanced, state kept). */
static int write_free(const h5u_writer *w, hid_t file, const ev_sim *s)
{
    const int D = s->dim;
    const size_t k = s->n - s->nstuck;
    double *pos = malloc((k ? k : 1) * (size_t)D * sizeof *pos);
    double *vel = malloc((k ? k : 1) * (size_t)D * sizeof *vel);
    double *rad = malloc((k ? k : 1) * sizeof *rad);
    int32_t *spc = malloc((k ? k : 1) * sizeof *spc);
    int rc = -1;
    const hid_t g = h5u_group(w, file, "free");
    if (g < 0) goto out;
    if (!pos || !vel || !rad || !spc) {
        rc = h5u_fail_msg(w, "out of memory writing /free");
        goto close;
    }
    size_t a = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        if (s->stuck[i]) continue;
        const double *p = EV_P(s, i);
        for (int q = 0; q < D; q++) {
            double x = p[q] + p[D + q] * (s->now - p[2 * D]);
            if (s->periodic) x -= s->L * floor(x / s->L);
            pos[a * D + q] = x;
            vel[a * D + q] = p[D + q];
        }
        rad[a] = p[2 * D + 1];
        spc[a] = s->species[i];
        a++;
    }
    rc = write_ds(w, g, "positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, k, (size_t)D, pos);
    if (!rc) rc = write_ds(w, g, "velocities", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, k, (size_t)D, vel);
    if (!rc) rc = write_ds(w, g, "radii", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, k, 1, rad);
    if (!rc) rc = write_ds(w, g, "species", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, k, 1, spc);
close:
    rc = h5u_close(w, rc, g, H5Gclose, "/free");
out:
    free(pos);
    free(vel);
    free(rad);
    free(spc);
    return rc;
}

static int write_series(const h5u_writer *w, hid_t file, const ev_series *ser)
{
    const hid_t g = h5u_group(w, file, "series");
    if (g < 0) return -1;
    const size_t n = ser ? ser->n : 0;
    int rc = write_ds(w, g, "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, n, 1, n ? ser->t : NULL);
    if (!rc) rc = write_ds(w, g, "stuck", H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, n, 1, n ? ser->stuck : NULL);
    if (!rc)
        rc = write_ds(w, g, "kinetic_energy", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, n, 1,
                      n ? ser->ke : NULL);
    if (!rc)
        rc = write_ds(w, g, "collisions", H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, n, 1,
                      n ? ser->collisions : NULL);
    if (!rc)
        rc = write_ds(w, g, "pressure", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, n, 1,
                      n ? ser->pressure : NULL);
    if (!rc)
        rc = h5u_attr_str(w, g, "pressure_note",
                          "collision virial over the interval ending at this row: "
                          "(2 KE/d + sum r_ij.dp_i/(d dt))/V; NaN on the first row");
    return h5u_close(w, rc, g, H5Gclose, "/series");
}

static int write_species(const h5u_writer *w, hid_t file, const ev_sim *s)
{
    const hid_t g = h5u_group(w, file, "species");
    if (g < 0) return -1;
    const int n = s->nspecies;
    uint64_t cnt[EV_MAX_SPECIES], stk[EV_MAX_SPECIES] = {0};
    uint8_t sticky[EV_MAX_SPECIES];
    double r[EV_MAX_SPECIES], rho[EV_MAX_SPECIES], m[EV_MAX_SPECIES];
    for (int k = 0; k < n; k++) {
        cnt[k] = s->sp[k].count;
        r[k] = s->sp[k].radius;
        rho[k] = s->sp[k].density;
        m[k] = rho[k] * ev_particle_volume(s->dim, r[k]);
        sticky[k] = (uint8_t)s->sp[k].sticky;
    }
    for (uint32_t a = 0; a < s->nstuck; a++) stk[s->species[s->stuck_idx[a]]]++;
    int rc = write_ds(w, g, "count", H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, (size_t)n, 1, cnt);
    if (!rc) rc = write_ds(w, g, "radius", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, (size_t)n, 1, r);
    if (!rc) rc = write_ds(w, g, "density", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, (size_t)n, 1, rho);
    if (!rc) rc = write_ds(w, g, "mass", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, (size_t)n, 1, m);
    if (!rc) rc = write_ds(w, g, "stuck", H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, (size_t)n, 1, stk);
    /* 1: the kind sticks; 0: a bath kind (STICKY 0 in --species) */
    if (!rc) rc = write_ds(w, g, "sticky", H5T_STD_U8LE, H5T_NATIVE_UINT8, 1, (size_t)n, 1, sticky);
    return h5u_close(w, rc, g, H5Gclose, "/species");
}

/* Fractal dimension of the stuck cluster from R_g(k) over arrival order:
 * least squares of log R_g against log k on 40 log-spaced k in
 * [max(20, k1/30), k1], k1 the last k with R_g < L/8 (before the walls are
 * felt). NaN when the range is shorter than a factor 5. */
double ev_df_fit(const double *pos, size_t n, int D, double rg_max, double *rg_out,
                 uint64_t *k_lo, uint64_t *k_hi)
{
    double sx[3] = {0, 0, 0}, sxx = 0;
    double *rg = rg_out ? rg_out : malloc((n ? n : 1) * sizeof *rg);
    *k_lo = *k_hi = 0;
    if (!rg) return NAN;
    size_t k1 = 0;
    for (size_t a = 0; a < n; a++) {
        const double *p = pos + a * (size_t)D;
        for (int q = 0; q < D; q++) {
            sx[q] += p[q];
            sxx += p[q] * p[q];
        }
        double c2 = 0;
        for (int q = 0; q < D; q++) c2 += (sx[q] / (a + 1)) * (sx[q] / (a + 1));
        rg[a] = sqrt(fmax(0, sxx / (a + 1) - c2));
        if (rg[a] < rg_max) k1 = a + 1;
    }
    const double k0 = fmax(20, k1 / 30.0);
    double res = NAN;
    if (k1 >= 5 * k0) {
        double sl = 0, sll = 0, sy = 0, sly = 0;
        const int m = 40;
        for (int j = 0; j < m; j++) {
            const uint32_t k = (uint32_t)llround(exp(log(k0) + (log((double)k1) - log(k0)) * j / (m - 1)));
            const double l = log((double)k), y = log(rg[k - 1]);
            sl += l, sll += l * l, sy += y, sly += l * y;
        }
        const double slope = (m * sly - sl * sy) / (m * sll - sl * sl);
        res = 1 / slope;
        *k_lo = (uint64_t)k0;
        *k_hi = k1;
    }
    if (!rg_out) free(rg);
    return res;
}

double ev_fractal_dimension(const ev_sim *s, uint64_t *k_lo, uint64_t *k_hi)
{
    const int D = s->dim;
    const uint32_t n = s->nstuck;
    double *pos = malloc((n ? n : 1) * (size_t)D * sizeof *pos);
    *k_lo = *k_hi = 0;
    if (!pos) return NAN;
    for (uint32_t a = 0; a < n; a++) memcpy(pos + (size_t)a * D, EV_P(s, s->stuck_idx[a]), D * sizeof *pos);
    const double df = ev_df_fit(pos, n, D, s->L / 8, NULL, k_lo, k_hi);
    free(pos);
    return df;
}

/* Dilute-gas mean free path / diameter at the start density (one species:
 * its diameter; several: the mean). */
static double mean_free_path(const ev_sim *s)
{
    double sig = 0;
    for (uint32_t i = 0; i < s->n; i++) sig += 2 * EV_P_ANY(s, i)[2 * s->dim + 1];
    sig /= s->n;
    const double rho = s->n / s->V;
    return s->dim == 2 ? 1 / (2 * sqrt(2.0) * rho * sig) / sig : 1 / (sqrt(2.0) * M_PI * rho * sig * sig) / sig;
}

static int write_results(const h5u_writer *w, hid_t file, const ev_sim *s, int why)
{
    const hid_t g = h5u_group(w, file, "results");
    if (g < 0) return -1;
    ev_stats st;
    ev_get_stats(s, &st);
    int rc = h5u_attr_f64(w, g, "time", st.t);
    if (!rc) rc = h5u_attr_u64(w, g, "events", st.events);
    if (!rc) rc = h5u_attr_u64(w, g, "collisions", st.collisions);
    if (!rc) rc = h5u_attr_u64(w, g, "wall_hits", st.wall_hits);
    if (!rc) rc = h5u_attr_u64(w, g, "cell_crossings", st.cell_crossings);
    if (!rc) rc = h5u_attr_u64(w, g, "stale_events", st.invalid);
    if (!rc) rc = h5u_attr_u64(w, g, "stuck", st.stuck);
    if (!rc) rc = h5u_attr_f64(w, g, "kinetic_energy_free", st.ke_free);
    if (!rc) rc = h5u_attr_f64(w, g, "kinetic_energy_stuck", st.ke_stuck);
    if (!rc) rc = h5u_attr_f64(w, g, "box_side", st.box);
    if (!rc) rc = h5u_attr_f64(w, g, "max_overlap_seen", st.max_overlap);
    if (!rc) rc = h5u_attr_str(w, g, "stop_reason", ev_stop_name(why));
    uint64_t klo, khi;
    const double df = ev_fractal_dimension(s, &klo, &khi);
    if (!rc) rc = h5u_attr_f64(w, g, "D_f_rg", df);
    if (!rc) rc = h5u_attr_u64(w, g, "D_f_k_lo", klo);
    if (!rc) rc = h5u_attr_u64(w, g, "D_f_k_hi", khi);
    if (!rc) rc = h5u_attr_f64(w, g, "mean_free_path_over_diameter", mean_free_path(s));
    return h5u_close(w, rc, g, H5Gclose, "/results");
}

static int write_file(const h5u_writer *w, const char *tmp, const ev_sim *s, const ev_series *ser,
                      const char *cmdline, int why)
{
    const hid_t file = h5u_create_file(w, tmp);
    if (file < 0) return -1;
    pdla_provenance pv;
    (void)prov_collect(&pv);
    int rc = h5u_attr_str(w, file, "model", "event");
    if (!rc) rc = h5u_attr_int(w, file, "dim", s->dim);
    if (!rc) rc = h5u_attr_u64(w, file, "particles", s->n);
    if (!rc) rc = h5u_attr_str(w, file, "box_walls", s->periodic ? "periodic" : "elastic");
    if (!rc) rc = write_parameters(w, file, &s->par);
    if (!rc) rc = write_cluster(w, file, s);
    if (!rc) rc = write_free(w, file, s);
    if (!rc) rc = write_series(w, file, ser);
    if (!rc) rc = write_species(w, file, s);
    if (!rc) rc = write_results(w, file, s, why);
    if (!rc) rc = h5u_write_code(w, file, &pv, cmdline);
    return h5u_close(w, rc, file, H5Fclose, tmp);
}

/* fsync of the directory holding path. */
static int sync_parent(const char *path)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash) return h5u_fsync_dir(".");
    if (slash == dir) slash[1] = '\0';
    else *slash = '\0';
    return h5u_fsync_dir(dir);
}

int ev_write_h5(const ev_sim *s, const ev_series *ser, const char *path, const char *cmdline,
                int why, char *err, size_t errlen)
{
    const size_t n = strlen(path) + 5;
    char *tmp = malloc(n);
    if (!tmp) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    snprintf(tmp, n, "%s.tmp", path);
    h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    int rc = h5u_silence(&q);
    if (rc) snprintf(err, errlen, "cannot silence HDF5");
    if (!rc) rc = write_file(&w, tmp, s, ser, cmdline, why);
    if (!rc && h5u_trim_and_sync(tmp) != 0) rc = h5u_fail_msg(&w, "cannot sync %s: %s", tmp, strerror(errno));
    if (!rc && rename(tmp, path) != 0)
        rc = h5u_fail_msg(&w, "cannot rename %s to %s: %s", tmp, path, strerror(errno));
    if (rc) unlink(tmp);
    /* The rename is durable only once the directory is synced (as the DLA
     * and DLCA writers do): before, a crash just after a run that said
     * "wrote" could leave the older cluster.h5 or none. Failing, the new
     * file is in place: 1, so that its sidecars are still written. */
    if (!rc && sync_parent(path) != 0) {
        rc = h5u_fail_msg(&w, "%s is in place, but its directory could not be synced: %s", path, strerror(errno));
        if (err && errlen) h5u_one_line(err);
        free(tmp);
        (void)h5u_restore(&q); /* the line already names the first failure */
        return 1;
    }
    if (h5u_restore(&q) < 0 && !rc) rc = h5u_fail_msg(&w, "written, but %s", "cannot restore the HDF5 error handler");
    if (rc && err && errlen) h5u_one_line(err);
    free(tmp);
    return rc ? -1 : 0;
}

/* ParaView sidecars (pdla/xdmf.h) of cluster.h5 at h5_path: NAME.xdmf2 for
 * the stuck particles (rows in arrival order: "arrival", with radius,
 * arrival_time, species, parent) and NAME-free.xdmf2 for the free ones.
 * Positions in the model's length units (units_per_diameter 1). A sidecar
 * with no rows is not written and an older one removed (it would describe
 * another file), as is the free one when the first cannot be written. */
int ev_write_xdmf(const ev_sim *s, const char *h5_path, char *err, size_t errlen)
{
    const size_t len = strlen(h5_path) + 32;
    char *side = malloc(len), *free_side = malloc(len);
    int rc = 0;
    if (!side || !free_side) {
        snprintf(err, errlen, "out of memory for the sidecars' names");
        rc = -1;
    }
    if (!rc) {
        /* the names of xdmf.h's one list; len always fits */
        (void)xdmf_sidecar_name(h5_path, XDMF_SIDECAR_MAIN, side, len);
        (void)xdmf_sidecar_name(h5_path, XDMF_SIDECAR_FREE, free_side, len);
        static const xdmf_array stuck_arrays[] = {
            {"radius", "/cluster/radii", "Float", 8},
            {"arrival_time", "/cluster/arrival_time", "Float", 8},
            {"species", "/cluster/species", "Int", 4},
            {"parent", "/cluster/parent", "Int", 8},
        };
        static const xdmf_array free_arrays[] = {
            {"radius", "/free/radii", "Float", 8},
            {"species", "/free/species", "Int", 4},
        };
        const xdmf_points ps = {h5_path, "/cluster/positions", s->nstuck, s->dim, 1, 0, "arrival",
                                stuck_arrays, 4};
        const xdmf_points pf = {h5_path, "/free/positions", s->n - s->nstuck, s->dim, 1, 0, NULL,
                                free_arrays, 2};
        /* n == 0: none written, an older one removed (xdmf_write_points) */
        rc = xdmf_write_points(side, &ps, err, errlen);
        if (rc) unlink(free_side); /* not written: an older one describes the older cluster.h5 */
        else rc = xdmf_write_points(free_side, &pf, err, errlen);
        /* any kind of the list this model does not write (none today) */
        char rerr[512];
        const unsigned both = XDMF_SIDECAR_BIT(XDMF_SIDECAR_MAIN) | XDMF_SIDECAR_BIT(XDMF_SIDECAR_FREE);
        if (xdmf_remove_sidecars(h5_path, both, rerr, sizeof rerr) && !rc) rc = pdla_errorf(-1, err, errlen, "%s", rerr);
    }
    free(side);
    free(free_side);
    return rc;
}
