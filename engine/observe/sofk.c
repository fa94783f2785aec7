/* Structure factor: density deposited on the grid, transformed, |F|^2 / W^2 averaged per shell. */
#include "sofk.h"

#include <math.h>
#include <string.h>

void sofk_compute(fgrid_t *g, size_t n, const double *pos, double *s)
{
	const int J = fgrid_bins(g);
	memset(s, 0, (size_t)J * sizeof(double));
	fgrid_deposit(g, 0, n, pos, NULL, 0, 0.0);
	fgrid_forward(g, 0);
	fgrid_mode_t md;
	for (size_t i = 0, nm = fgrid_modes(g); i < nm; i++) {
		if (!fgrid_mode(g, i, &md))
			continue;
		const double *c = fgrid_coef(g, 0, i);
		s[md.bin] += md.weight * ((c[0] * c[0] + c[1] * c[1]) / (double)n - md.alias) / md.w2;
	}
	for (int b = 0; b < J; b++) {
		double w = fgrid_shell_modes(g, b);
		s[b] = w > 0 ? s[b] / w : NAN;
	}
}
