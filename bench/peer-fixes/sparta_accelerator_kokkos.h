/* accelerator_kokkos.h for a SPARTA tree without its KOKKOS package (bench/peers.py adds it to its copy).
 * The peer's source ships without this header; sparta.cpp, input.cpp and error.cpp include it and expect
 * the stand-in classes below when KOKKOS is not built in: they are never instantiated with -kokkos off. */
#ifndef SPARTA_ACCELERATOR_KOKKOS_H
#define SPARTA_ACCELERATOR_KOKKOS_H

#include "update.h"
#include "particle.h"
#include "comm.h"
#include "domain.h"
#include "grid.h"
#include "surf.h"
#include "modify.h"

namespace SPARTA_NS {

class KokkosSPARTA {
 public:
  int kokkos_exists = 0;
  KokkosSPARTA(class SPARTA *, int, char **) {}
  void accelerator(int, char **) {}
};

class UpdateKokkos : public Update { public: UpdateKokkos(class SPARTA *s) : Update(s) {} };
class ParticleKokkos : public Particle { public: ParticleKokkos(class SPARTA *s) : Particle(s) {} };
class CommKokkos : public Comm { public: CommKokkos(class SPARTA *s) : Comm(s) {} };
class DomainKokkos : public Domain { public: DomainKokkos(class SPARTA *s) : Domain(s) {} };
class GridKokkos : public Grid { public: GridKokkos(class SPARTA *s) : Grid(s) {} };
class SurfKokkos : public Surf { public: SurfKokkos(class SPARTA *s) : Surf(s) {} };
class ModifyKokkos : public Modify { public: ModifyKokkos(class SPARTA *s) : Modify(s) {} };

}

namespace Kokkos { inline void finalize() {} }

#endif
