/* Surface profile h(x): the highest particle centre per bin across gravity (seed 000 sec. 3.5). */
#include "observe/surface.h"

#include <math.h>

void surface_profile(int dim, size_t n, const double *pos, int axis, double len, int bins, int gaxis, int up,
                     double glen, double *h, double *count)
{
	for (int b = 0; b < bins; b++) {
		h[b] = -INFINITY;
		count[b] = 0;
	}
	const double inv = bins / len;
	for (size_t i = 0; i < n; i++) {
		const double *x = &pos[i * (size_t)dim];
		double f = floor(x[axis] * inv);
		int b = f < 0 ? 0 : f >= bins ? bins - 1 : (int)f;
		double z = up > 0 ? x[gaxis] : glen - x[gaxis];
		if (z > h[b])
			h[b] = z;
		count[b] += 1;
	}
	for (int b = 0; b < bins; b++)
		if (count[b] == 0)
			h[b] = NAN;
}
