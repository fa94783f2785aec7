/* Instantiates ed_impl.h for 2D and 3D with the feature switches SPEC, ROUGH, WALLS, GRAV the includer has set. */
/*
 * Contract: the includer defines SPEC, ROUGH, WALLS, GRAV (0 or 1), FILTG (optional, 0 if not defined) and
 * VARIANT, the suffix letters of this variant's kernels (d, w, g, dr, ws,
 * ...): the kernels come out as name_2VARIANT and name_3VARIANT. Include it
 * once per variant; it undefines WALLS, GRAV, FILTG and VARIANT (set anew for the
 * next variant) and leaves SPEC and ROUGH (set per group of variants).
 */
#ifndef FILTG
#define FILTG 0   /* filters under gravity (frozen particles fly straight): only the variants that set it */
#endif
#define ED_CAT_(a, b) a##b
#define ED_CAT(a, b) ED_CAT_(a, b)

#define D 2
#define P_T p2_t
#define FN(x) ED_CAT(x, ED_CAT(_2, VARIANT))
#include "ed_impl.h"
#undef D
#undef P_T
#undef FN

#define D 3
#define P_T p3_t
#define FN(x) ED_CAT(x, ED_CAT(_3, VARIANT))
#include "ed_impl.h"
#undef D
#undef P_T
#undef FN

#undef ED_CAT
#undef ED_CAT_
#undef WALLS
#undef GRAV
#undef VARIANT
#undef FILTG
