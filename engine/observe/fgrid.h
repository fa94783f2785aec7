/* Fourier grids for structure factors: cloud-in-cell deposit of particle quantities on a periodic grid, FFTW real-to-complex transform, radial shells in k. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - A grid of m[0] x m[1] (x m[2]) points over the periodic box (point g at
 *   g h, h = L/m per axis) holding `fields` real fields; all memory and the
 *   FFTW plans (FFTW_ESTIMATE: deterministic, no timing) are made in
 *   fgrid_create(). No I/O. Not thread-safe (FFTW planning is not).
 * - Deposit: cloud in cell (linear weights to the 2^D nearest points). The
 *   transform of a field is F(k) = sum_g rho_g exp(-i k.x_g), which for
 *   small k equals sum_j w_j exp(-i k.r_j) times the assignment window
 *   W(k) = prod_a sinc^2(k_a h_a / 2). Averaged over configurations,
 *   <|F(k)|^2> = sum_n W^2(k_n) P(k_n) over the aliases k_n = k + 2 pi n/h
 *   of the true power P; the callers take P(k) = (|F|^2 - alias)/W^2 with
 *   alias = sum_{n != 0} W^2(k_n) = prod_a (1 - 2/3 sin^2(k_a h_a/2)) - W^2,
 *   which assumes P = N (no correlation) at the aliases (Jing, ApJ 620,
 *   559 (2005)). Exact for uncorrelated particles; for a fluid the aliases
 *   lie beyond 2 pi/h, near the first peak of S(k) when h is about one
 *   diameter, so S(k) is good to a few per cent up to about half the
 *   Nyquist wavenumber and exact in the limit k -> 0.
 * - Shells: bin b = 1..J holds the modes with |k| in [(b - 1/2) dk, (b + 1/2) dk),
 *   dk = 2 pi / (the largest box edge), up to the smallest Nyquist
 *   wavenumber pi m_a / L_a. k = 0 is in no bin. Each mode of the half
 *   spectrum counts with its mirror image (weight 2) where it has one.
 */

typedef struct fgrid fgrid_t;

/* NULL on bad arguments (dim 2 or 3, every m >= 4) or no memory. */
fgrid_t *fgrid_create(int dim, const double *box, const int m[3], int fields);
/* The same with walls: walled[dim] (may be NULL: none) names the axes with walls, which have no periodic
 * images. The transform then runs over the periodic axes only: a walled axis gets one grid point (m there
 * is ignored), which sums the deposit along it, so every mode has k = 0 along the walled axes and the
 * shells (dk = 2 pi / the largest periodic edge, up to the smallest periodic Nyquist wavenumber) hold
 * wave vectors along the periodic axes: the structure of the density projected on them, exact (no
 * window, no padding: the sum along a walled axis does not depend on where in the box a particle is).
 * NULL also when every axis is walled. */
fgrid_t *fgrid_create_walled(int dim, const double *box, const int m[3], int fields, const int *walled);
void fgrid_destroy(fgrid_t *g);

/* J, the number of shells (>= 1 for m >= 4). */
int fgrid_bins(const fgrid_t *g);
/* The shells: edges[J + 1] (|k|, 1/length), centres[J] (mean |k| of the modes in the shell, weights
 * counted), modes[J] (number of wave vectors k in the shell, mirror images counted). Any may be NULL. */
void fgrid_axis(const fgrid_t *g, double *edges, double *centres, double *modes);
/* Number of wave vectors in shell index b (0 .. J-1). */
double fgrid_shell_modes(const fgrid_t *g, int b);

/* Deposit n particles (pos: n*dim) into field f, replacing its content; weight of particle i:
 * w ? w[i * wstride] - shift : 1. */
void fgrid_deposit(fgrid_t *g, int f, size_t n, const double *pos, const double *w, int wstride, double shift);
/* Forward transform of field f in place. */
void fgrid_forward(fgrid_t *g, int f);

/* Modes of the half spectrum, i = 0 .. fgrid_modes() - 1. fgrid_mode() returns 0 for a mode in no
 * shell; otherwise 1 and *md. fgrid_coef() is the transform of field f at mode i (after
 * fgrid_forward()), as {re, im}. */
typedef struct {
	int bin;        /* 0 .. J-1 (shell b = bin + 1) */
	double weight;  /* 1 or 2 (the mode and its mirror image) */
	double w2;      /* W(k)^2 of the cloud-in-cell assignment */
	double alias;   /* sum over the aliases k_n != k of W^2(k_n) */
	double k[3];    /* wave vector (1/length) */
	double kmag;
} fgrid_mode_t;
size_t fgrid_modes(const fgrid_t *g);
int fgrid_mode(const fgrid_t *g, size_t i, fgrid_mode_t *md);
const double *fgrid_coef(const fgrid_t *g, int f, size_t i);

/* Bytes held (grids, tables). */
size_t fgrid_memory(const fgrid_t *g);
