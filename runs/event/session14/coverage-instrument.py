p='src/event/ev_core.c'
src=open(p).read()
src=src.replace('''static inline __attribute__((always_inline)) void la_particle(const ev_sim *s, const int D,
                                                              uint32_t id)
{''','''static uint32_t la_p[4][16], la_c[4][16]; static int la_np[4], la_nc[4]; static unsigned la_ev;
static unsigned long long st_ev, st_c1, st_c2, st_p1, st_p2, st_part, st_hn[8], st_l1[8], st_l2[8];
static inline __attribute__((always_inline)) void la_particle(const ev_sim *s, const int D,
                                                              uint32_t id)
{
    if (la_np[la_ev & 3] < 16) la_p[la_ev & 3][la_np[la_ev & 3]++] = id;''')
src=src.replace('''static inline __attribute__((always_inline)) void la_cells(const ev_sim *s, const int D,
                                                           uint32_t id)
{''','''static inline __attribute__((always_inline)) void la_cells(const ev_sim *s, const int D,
                                                           uint32_t id)
{
    if (la_nc[la_ev & 3] < 16) la_c[la_ev & 3][la_nc[la_ev & 3]++] = id;''')
src=src.replace('''    if (s->lookahead) lookahead(s, D);''','''    if (s->lookahead) {
        int c1 = 0, c2 = 0, p1 = 0, p2 = 0;
        for (int b = 1; b <= 2; b++) {
            const unsigned sl = (la_ev - b) & 3;
            for (int q = 0; q < la_nc[sl]; q++) if (la_c[sl][q] == i) { if (b == 1) c1 = 1; else c2 = 1; }
            for (int q = 0; q < la_np[sl]; q++) if (la_p[sl][q] == i) { if (b == 1) p1 = 1; else p2 = 1; }
        }
        st_ev++; st_c1 += c1; st_c2 += c2 && !c1; st_p1 += p1; st_p2 += p2;
        st_part += (c1 || c2 || p1 || p2);
        st_hn[s->hn < 7 ? s->hn : 7]++;
        { int m = 0; if (s->cq + 1 < s->qnb) for (uint32_t h = s->qhead[s->cq + 1]; h != QNONE && m < 7; h = s->qnext[h]) m++; st_l1[m]++; }
        { int m = 0; if (s->cq + 2 < s->qnb) for (uint32_t h = s->qhead[s->cq + 2]; h != QNONE && m < 7; h = s->qnext[h]) m++; st_l2[m]++; }
        if ((st_ev & 0xfffff) == 0) { fprintf(stderr, "la: ev %llu cells@1 %.3f cells@2only %.3f part@1 %.3f part@2 %.3f any %.3f\\n", st_ev, (double)st_c1/st_ev, (double)st_c2/st_ev, (double)st_p1/st_ev, (double)st_p2/st_ev, (double)st_part/st_ev);
          fprintf(stderr, "hn/l1/l2:"); for (int q = 0; q < 8; q++) fprintf(stderr, " %d:%.3f/%.3f/%.3f", q, (double)st_hn[q]/st_ev, (double)st_l1[q]/st_ev, (double)st_l2[q]/st_ev); fprintf(stderr, "\\n"); }
        la_ev++; la_np[la_ev & 3] = 0; la_nc[la_ev & 3] = 0;
        lookahead(s, D);
    }''')
src=src.replace('#include <string.h>\n','#include <string.h>\n#include <stdio.h>\n',1)
open(p,'w').write(src)
