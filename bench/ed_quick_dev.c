#define M_PI 3.14159265358979323846
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "ed.h"
static double now(void){struct timespec ts;clock_gettime(CLOCK_MONOTONIC,&ts);return ts.tv_sec+1e-9*ts.tv_nsec;}
int main(int argc,char**argv){
  scene_t s; memset(&s,0,sizeof s);
  s.dim=atoi(argv[1]); s.count=atol(argv[2]); double phi=atof(argv[3]); s.restitution=atof(argv[4]);
  double cpp=atof(argv[5]);
  s.radius=0.5; s.mass=1; s.temperature=1; s.seed=1; s.volume_fraction=phi;
  double vp = s.dim==2? M_PI*0.25 : M_PI/6; double V=s.count*vp/phi; double L=pow(V,1.0/s.dim);
  for(int a=0;a<s.dim;a++) s.box[a]=L;
  if(argc>6) s.ed_cell_size=atof(argv[6]);
  int err; char msg[256];
  ed_t *ed=ed_create(&s,&err,msg,sizeof msg); if(!ed){fprintf(stderr,"%s\n",msg);return 1;}
  ed_sample_t a,b; ed_sample(ed,&a);
  int c[3]; ed_cells(ed,c);
  double t0=now();
  ed_advance(ed, INFINITY, (uint64_t)(cpp*s.count/2), UINT64_MAX);
  double w=now()-t0;
  ed_sample(ed,&b);
  double T=2*b.kinetic_energy/(s.dim*s.count);
  double Z=1+b.virial/(s.dim*b.ekin_time_integral*2/(s.dim*s.count)*s.count);
  printf("cells %d %d %d  coll %lu events %lu  %.3g coll/s  %.3g ev/s time %.4g  dE/E %.3e  mom %.2e  Z %.5f rate %.5f mingap %.3e mem/p %.1f\n",
   c[0],c[1],c[2],b.collisions,b.events,b.collisions/w,b.events/w,b.time,(b.kinetic_energy-a.kinetic_energy)/a.kinetic_energy,
   sqrt(b.momentum[0]*b.momentum[0]+b.momentum[1]*b.momentum[1]+b.momentum[2]*b.momentum[2]),Z,2.0*b.interval_collisions/(s.count*b.interval),ed_min_gap(ed),(double)ed_memory(ed)/s.count);
  (void)T; ed_destroy(ed); return 0;}
