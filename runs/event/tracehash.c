#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include "pdla/event.h"
static uint64_t h = 1469598103934665603ull, hs = 1469598103934665603ull; static uint64_t cnt;
static void mixh(uint64_t *x, const void *p, size_t n){const unsigned char*c=p;for(size_t k=0;k<n;k++){*x^=c[k];*x*=1099511628211ull;}}
static void mix(const void *p, size_t n){mixh(&h,p,n);}
/* hs: the same with a pair written as (min, max), so it does not depend on which of the two found the event */
static void fn(const ev_trace_event *e, void *u){(void)u;mix(&e->t,8);mix(&e->i,4);mix(&e->j,4);mix(&e->kind,4);
  uint32_t a=e->i,b=e->j; if(e->kind==EV_EV_PAIR&&b<a){uint32_t t=a;a=b;b=t;}
  mixh(&hs,&e->t,8);mixh(&hs,&a,4);mixh(&hs,&b,4);mixh(&hs,&e->kind,4);cnt++;}
int main(int argc,char**argv){
  ev_params p; ev_params_default(&p); char err[512];
  for(int k=1;k+1<argc;k+=2) if(ev_param_set(&p,argv[k],argv[k+1],err,sizeof err)){fprintf(stderr,"%s\n",err);return 2;}
  ev_sim*s=ev_create(&p,err,sizeof err); if(!s){fprintf(stderr,"%s\n",err);return 2;}
  ev_set_trace(s,fn,NULL); int why=ev_run(s,NULL); ev_stats st; ev_get_stats(s,&st);
  printf("why=%d events=%llu coll=%llu stuck=%llu trace=%llu hash=%016llx shash=%016llx t=%.17g\n",why,(unsigned long long)st.events,(unsigned long long)st.collisions,(unsigned long long)st.stuck,(unsigned long long)cnt,(unsigned long long)h,(unsigned long long)hs,st.t);
  ev_free(s); return 0;}
