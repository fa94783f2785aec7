/* Velocity correlations: pair sums normalised per bin; momentum-density transforms split into the components along and across k. */
#include "vcorr.h"

#include <math.h>
#include <string.h>

void vcorr_pairs(int dim, int nb, const double *count, const double *par, const double *perp, double t_over_m,
                 double *g_par, double *g_perp)
{
	for (int k = 0; k < nb; k++) {
		if (!(count[k] > 0) || !(t_over_m > 0)) {
			g_par[k] = g_perp[k] = NAN;
			continue;
		}
		g_par[k] = par[k] / (count[k] * t_over_m);
		g_perp[k] = perp[k] / (count[k] * (dim - 1) * t_over_m);
	}
}

void vcorr_kspace(fgrid_t *g, int dim, size_t n, const double *pos, const double *vel, const double *mean,
                  double t_over_m, double *s_par, double *s_perp)
{
	const int J = fgrid_bins(g);
	memset(s_par, 0, (size_t)J * sizeof(double));
	memset(s_perp, 0, (size_t)J * sizeof(double));
	for (int a = 0; a < dim; a++) {
		fgrid_deposit(g, a, n, pos, vel + a, dim, mean[a]);
		fgrid_forward(g, a);
	}
	fgrid_mode_t md;
	for (size_t i = 0, nm = fgrid_modes(g); i < nm; i++) {
		if (!fgrid_mode(g, i, &md))
			continue;
		/* khat . j (complex) and |j|^2 */
		double lr = 0, li = 0, tot = 0;
		for (int a = 0; a < dim; a++) {
			const double *c = fgrid_coef(g, a, i);
			double e = md.k[a] / md.kmag;
			lr += e * c[0];
			li += e * c[1];
			tot += c[0] * c[0] + c[1] * c[1];
		}
		/* Aliases carry uncorrelated velocity noise: T/m per component of
		 * the alias power, isotropic (1 along k, D-1 across). */
		double lon = lr * lr + li * li, nt = (double)n * t_over_m;
		s_par[md.bin] += md.weight * (lon / nt - md.alias) / md.w2;
		s_perp[md.bin] += md.weight * ((tot - lon) / (nt * (dim - 1)) - md.alias) / md.w2;
	}
	for (int b = 0; b < J; b++) {
		double w = fgrid_shell_modes(g, b);
		s_par[b] = w > 0 && t_over_m > 0 ? s_par[b] / w : NAN;
		s_perp[b] = w > 0 && t_over_m > 0 ? s_perp[b] / w : NAN;
	}
}
