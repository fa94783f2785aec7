/* density_spectrum: slice counts along an axis in a ring of samples, their frequency power spectrum and its log-log slope. */
#include "observe/dspec.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct dspec {
	int dim, axis, S, m;
	double length, interval, f_lo, f_hi;
	double *ring;         /* m * S counts, sample-major */
	int head;             /* next slot to write */
	int filled;           /* samples in the ring (<= m) */
	double *cs, *sn;      /* m: cos and sin of 2 pi j / m */
};

int dspec_bins(int m) { return m / 2 - 1; }

dspec_t *dspec_create(int dim, int axis, int slices, double length, int m, double interval, double f_lo,
                      double f_hi)
{
	if (slices < 2 || m < 4 || axis < 0 || axis >= dim || !(length > 0) || !(interval > 0))
		return NULL;
	dspec_t *d = calloc(1, sizeof(*d));
	if (!d)
		return NULL;
	d->dim = dim, d->axis = axis, d->S = slices, d->m = m;
	d->length = length, d->interval = interval, d->f_lo = f_lo, d->f_hi = f_hi;
	d->ring = calloc((size_t)m * slices, sizeof(double));
	d->cs = malloc((size_t)m * sizeof(double));
	d->sn = malloc((size_t)m * sizeof(double));
	if (!d->ring || !d->cs || !d->sn) {
		dspec_destroy(d);
		return NULL;
	}
	for (int j = 0; j < m; j++) {
		d->cs[j] = cos(2 * 3.14159265358979323846 * j / m);
		d->sn[j] = sin(2 * 3.14159265358979323846 * j / m);
	}
	return d;
}

void dspec_destroy(dspec_t *d)
{
	if (!d)
		return;
	free(d->ring);
	free(d->cs);
	free(d->sn);
	free(d);
}

void dspec_axis(const dspec_t *d, double *edges, double *centres)
{
	int K = dspec_bins(d->m);
	double df = 1.0 / (d->m * d->interval);
	for (int k = 0; k <= K; k++)
		edges[k] = (k + 0.5) * df;
	for (int k = 0; k < K; k++)
		centres[k] = (k + 1) * df;
}

void dspec_add(dspec_t *d, uint64_t n, const double *pos)
{
	double *row = d->ring + (size_t)d->head * d->S;
	memset(row, 0, (size_t)d->S * sizeof(double));
	const double scale = d->S / d->length;
	for (uint64_t i = 0; i < n; i++) {
		double x = pos[i * d->dim + d->axis];
		int s = (int)floor(x * scale);
		s = s < 0 ? 0 : s >= d->S ? d->S - 1 : s;   /* a particle on the upper edge belongs to the last slice */
		row[s] += 1.0;
	}
	d->head = (d->head + 1) % d->m;
	if (d->filled < d->m)
		d->filled++;
}

int dspec_result(dspec_t *d, double *P, double *alpha, double *alpha_se)
{
	const int K = dspec_bins(d->m), m = d->m;
	*alpha = *alpha_se = NAN;
	if (d->filled < m) {
		for (int k = 0; k < K; k++)
			P[k] = NAN;
		return d->filled;
	}
	/* plain DFT: m is a few hundred to a few thousand samples per snapshot interval */
	for (int k = 1; k <= K; k++) {
		double sum = 0.0;
		for (int s = 0; s < d->S; s++) {
			double re = 0.0, im = 0.0, re2 = 0.0, im2 = 0.0;
			for (int j = 0; j < m; j++) {
				double c = d->ring[(size_t)((d->head + j) % m) * d->S + s];
				int p = (int)(((int64_t)j * k) % m), q = (int)(((int64_t)j * (m - k)) % m);
				re += c * d->cs[p], im += c * d->sn[p];
				re2 += c * d->cs[q], im2 += c * d->sn[q];
			}
			sum += (re * re + im * im + re2 * re2 + im2 * im2) / ((double)m * m);
		}
		P[k - 1] = sum / d->S;
	}
	/* least squares of y = log P on x = log f over the fit range */
	double sx = 0, sy = 0, sxx = 0, sxy = 0;
	int nf = 0;
	const double df = 1.0 / (m * d->interval);
	for (int k = 1; k <= K; k++) {
		double f = k * df;
		if (f < d->f_lo || f > d->f_hi || !(P[k - 1] > 0))
			continue;
		double x = log(f), y = log(P[k - 1]);
		sx += x, sy += y, sxx += x * x, sxy += x * y;
		nf++;
	}
	if (nf >= 3) {
		double den = nf * sxx - sx * sx;
		double b = (nf * sxy - sx * sy) / den, a = (sy - b * sx) / nf, r2 = 0.0;
		for (int k = 1; k <= K; k++) {
			double f = k * df;
			if (f < d->f_lo || f > d->f_hi || !(P[k - 1] > 0))
				continue;
			double e = log(P[k - 1]) - a - b * log(f);
			r2 += e * e;
		}
		*alpha = b;
		*alpha_se = sqrt(r2 / (nf - 2) * nf / den);
	}
	return d->filled;
}

size_t dspec_state_size(const dspec_t *d) { return (size_t)d->m * d->S + 2; }

void dspec_state_get(const dspec_t *d, double *v)
{
	memcpy(v, d->ring, (size_t)d->m * d->S * sizeof(double));
	v[(size_t)d->m * d->S] = d->head;
	v[(size_t)d->m * d->S + 1] = d->filled;
}

int dspec_state_set(dspec_t *d, const double *v)
{
	size_t n = (size_t)d->m * d->S;
	double h = v[n], f = v[n + 1];
	if (!(h >= 0 && h < d->m && h == floor(h) && f >= 0 && f <= d->m && f == floor(f)))
		return -1;
	for (size_t i = 0; i < n; i++)
		if (!(v[i] >= 0))
			return -1;
	memcpy(d->ring, v, n * sizeof(double));
	d->head = (int)h, d->filled = (int)f;
	return 0;
}

size_t dspec_memory(const dspec_t *d) { return sizeof(*d) + ((size_t)d->m * d->S + 2 * (size_t)d->m) * sizeof(double); }
