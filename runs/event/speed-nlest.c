/* Quick estimate for a neighbour-list scheme: rebuilds per collision and list size for skins s. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include "pdla/event.h"
enum { NS = 5 };
static const double skins[NS] = {0.1, 0.2, 0.3, 0.5, 0.8};
static int D; static double L; static size_t N;
static double *X[NS], *P0; /* build centres, last positions */
static unsigned long long reb[NS], coll;
static void seg(size_t i, const double *p1) {
  double *p0 = P0 + i * 3, d[3];
  for (int k = 0; k < D; k++) { d[k] = p1[k] - p0[k]; if (d[k] > L/2) d[k] -= L; else if (d[k] < -L/2) d[k] += L; }
  for (int q = 0; q < NS; q++) {
    const double del = skins[q] / 2; double *x = X[q] + i * 3;
    double u0 = 0;
    for (;;) { /* from p0 + u0 d: exits the sphere around x before u = 1? */
      double a = 0, b = 0, c = 0;
      for (int k = 0; k < D; k++) { double r = p0[k] + d[k] * u0 - x[k]; a += d[k]*d[k]; b += r*d[k]; c += r*r; }
      c -= del * del; /* |r + u d|^2 = del^2 , u relative */
      double disc = b*b - a*c; if (a == 0) break;
      double u = (-b + sqrt(disc > 0 ? disc : 0)) / a;
      if (u0 + u >= 1) break;
      u0 += u; if (u <= 1e-12) u0 += 1e-12;
      for (int k = 0; k < D; k++) x[k] = p0[k] + d[k] * u0;
      reb[q]++;
    }
  }
  for (int k = 0; k < D; k++) p0[k] = p0[k] + d[k];
}
static ev_sim *S;
static void fn(const ev_trace_event *e, void *u) { (void)u; if (e->kind != EV_EV_PAIR) return; coll++;
  seg(e->i, ev_pos(S, e->i)); seg(e->j, ev_pos(S, e->j)); }
int main(int argc, char **argv) {
  ev_params p; ev_params_default(&p); char err[512];
  for (int k = 1; k + 1 < argc; k += 2) if (ev_param_set(&p, argv[k], argv[k+1], err, sizeof err)) { fprintf(stderr, "%s\n", err); return 2; }
  S = ev_create(&p, err, sizeof err); if (!S) { fprintf(stderr, "%s\n", err); return 2; }
  D = ev_dim(S); N = ev_count(S); ev_stats st; ev_get_stats(S, &st); L = st.box;
  P0 = malloc(N * 3 * sizeof *P0);
  for (size_t i = 0; i < N; i++) for (int k = 0; k < D; k++) P0[i*3+k] = ev_pos(S, i)[k];
  for (int q = 0; q < NS; q++) { X[q] = malloc(N * 3 * sizeof(double)); memcpy(X[q], P0, N * 3 * sizeof(double)); }
  ev_set_trace(S, fn, NULL); ev_run(S, NULL); ev_sync(S); ev_get_stats(S, &st);
  double sig = 2 * ev_radius(S, 0);
  /* neighbours within sigma(1+s) at the end, all pairs */
  double cnt[NS] = {0};
  for (size_t i = 0; i < N; i++) for (size_t j = i + 1; j < N; j++) {
    double rr = 0; for (int k = 0; k < D; k++) { double r = ev_pos(S,i)[k] - ev_pos(S,j)[k]; r -= L * round(r / L); rr += r*r; }
    for (int q = 0; q < NS; q++) if (rr < sig*sig*(1+skins[q])*(1+skins[q])) cnt[q] += 2;
  }
  printf("dim %d N %zu events %llu coll %llu cross %llu stale %llu\n", D, N, (unsigned long long)st.events, coll,
         (unsigned long long)st.cell_crossings, (unsigned long long)st.invalid);
  for (int q = 0; q < NS; q++) printf("skin %.2f sigma: rebuilds/collision %.3f  list size %.2f\n", skins[q], (double)reb[q] / coll, cnt[q] / N);
  return 0; }
