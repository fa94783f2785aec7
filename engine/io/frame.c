/* Reads one frame of an H5MD trajectory (positions, velocities) as a scene's initial state, with the checks that make it usable. */
#include <errno.h>
#include <hdf5.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "frame.h"
#include "h5util.h"
#include "place.h"

/* Read frame k (of frames) of dataset name in group g into buf (n x dim).
 * The dataset must be [frames, n, dim] doubles. Its chunk index is checked
 * for the frame's chunks first (h5u_chunks_sane(): HDF5 would allocate a
 * damaged chunk size before reading). 0, -2 (a damaged chunk index) or -1. */
static int read_frame(hid_t g, const char *name, hsize_t k, hsize_t n, hsize_t dim, double *buf)
{
	int ret = -1;
	hid_t d = H5Dopen2(g, name, H5P_DEFAULT), sp = d >= 0 ? H5Dget_space(d) : H5I_INVALID_HID;
	hid_t mem = H5I_INVALID_HID, file = d >= 0 ? H5Iget_file_id(d) : H5I_INVALID_HID;
	hsize_t start[3] = {k, 0, 0}, count[3] = {1, n, dim}, mdim[1] = {n * dim}, eof = 0;
	if (file < 0 || H5Fget_filesize(file, &eof) < 0)
		goto out;
	if (h5u_chunks_sane(d, eof, k, 1)) {
		ret = -2;
		goto out;
	}
	if (sp < 0 || H5Sselect_hyperslab(sp, H5S_SELECT_SET, start, NULL, count, NULL) < 0)
		goto out;
	mem = H5Screate_simple(1, mdim, NULL);
	if (mem >= 0 && H5Dread(d, H5T_NATIVE_DOUBLE, mem, sp, H5P_DEFAULT, buf) >= 0)
		ret = 0;
out:
	if (mem >= 0) H5Sclose(mem);
	if (sp >= 0) H5Sclose(sp);
	if (file >= 0) H5Fclose(file);
	if (d >= 0) H5Dclose(d);
	return ret;
}

/* Dimensions of dataset name in g: rank 3 doubles [frames, n, dim]. 0 or -1. */
static int extent(hid_t g, const char *name, hsize_t dims[3])
{
	int ret = -1;
	hid_t d = H5Dopen2(g, name, H5P_DEFAULT), sp = d >= 0 ? H5Dget_space(d) : H5I_INVALID_HID;
	hid_t t = d >= 0 ? H5Dget_type(d) : H5I_INVALID_HID;
	if (sp >= 0 && t >= 0 && H5Tget_class(t) == H5T_FLOAT && H5Sget_simple_extent_ndims(sp) == 3 &&
	    H5Sget_simple_extent_dims(sp, dims, NULL) == 3)
		ret = 0;
	if (t >= 0) H5Tclose(t);
	if (sp >= 0) H5Sclose(sp);
	if (d >= 0) H5Dclose(d);
	return ret;
}

/* Mixtures: the frame's per-particle diameters (/GROUP/diameter, [n]
 * doubles, as h5md.c writes them) equal the scene's 2 r_i
 * (scene_species_radii(): the species' radii, polydisperse ones drawn from
 * the seed and stream), bit for bit. FRAME_OK, or FRAME_EINVAL /
 * FRAME_ENOMEM with msg naming the key. */
static int check_diameters(hid_t g, const scene_t *s, const char *path, const char *group, char *msg, size_t msglen)
{
	int ret = FRAME_EINVAL;
	const hsize_t n = s->count;
	double *diam = malloc(n * sizeof(double)), *rad = malloc(n * sizeof(double));
	hid_t d = H5I_INVALID_HID, sp = H5I_INVALID_HID, t = H5I_INVALID_HID;
	hsize_t dims[1];
	if (!diam || !rad) {
		ret = FRAME_ENOMEM;
		h5u_fail(msg, msglen, 0, "out of memory reading %llu particles", (unsigned long long)n);
		goto out;
	}
	if (H5Lexists(g, "diameter", H5P_DEFAULT) <= 0 || (d = H5Dopen2(g, "diameter", H5P_DEFAULT)) < 0 ||
	    (sp = H5Dget_space(d)) < 0 || (t = H5Dget_type(d)) < 0 || H5Tget_class(t) != H5T_FLOAT ||
	    H5Sget_simple_extent_ndims(sp) != 1 || H5Sget_simple_extent_dims(sp, dims, NULL) != 1 || dims[0] != n ||
	    H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, diam) < 0) {
		h5u_fail(msg, msglen, 0, "particles.initial.from: %s has no per-particle diameters /%s/diameter (%llu "
		         "numbers), which a mixture (particles.species) starts from: its radii must match the scene's", path,
		         group, (unsigned long long)n);
		goto out;
	}
	scene_species_radii(s, rad);
	for (hsize_t i = 0; i < n; i++)
		if (diam[i] != 2.0 * rad[i]) {
			h5u_fail(msg, msglen, 0, "particles.initial.from: particle %llu has diameter %.17g in %s (/%s/diameter), "
			         "the scene's particles.species give it %.17g (the same species, counts and radii, and for "
			         "radius_range the same run.seed)", (unsigned long long)i, diam[i], path, group, 2.0 * rad[i]);
			goto out;
		}
	ret = FRAME_OK;
out:
	if (t >= 0) H5Tclose(t);
	if (sp >= 0) H5Sclose(sp);
	if (d >= 0) H5Dclose(d);
	free(diam);
	free(rad);
	return ret;
}

int frame_load(const scene_t *s, const char *path, double **pos, double **vel, double **spin, char *msg,
               size_t msglen)
{
	const char *key = s->from_job ? "particles.initial.from.job" : "particles.initial.from.file";
	int ret = FRAME_EINVAL;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID;
	double *p = NULL, *v = NULL, *w = NULL;
	char group[64];
	hsize_t dp[3], dv[3];

	*pos = *vel = *spin = NULL;
	h5u_quiet();
	if (access(path, R_OK) != 0) {
		h5u_fail(msg, msglen, 0, "%s: cannot read %s: %s", key, path, strerror(errno));
		goto out;
	}
	if (H5Fis_hdf5(path) <= 0 || (f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0) {
		h5u_fail(msg, msglen, 0, "%s: %s is not an HDF5 file that can be opened (another run still writing it?)",
		         key, path);
		goto out;
	}
	if (s->from_replica >= 0)
		snprintf(group, sizeof group, "particles/replica_%" PRId64, s->from_replica);
	else
		snprintf(group, sizeof group, "particles/all");
	if (H5Lexists(f, "particles", H5P_DEFAULT) <= 0 || H5Lexists(f, group, H5P_DEFAULT) <= 0 ||
	    (g = H5Gopen2(f, group, H5P_DEFAULT)) < 0) {
		h5u_fail(msg, msglen, 0, "%s: %s has no /%s%s", key, path, group,
		         s->from_replica >= 0 ? " (from.replica: not an ensemble's trajectory, or no such replica)"
		                              : " (not a trajectory; an ensemble's frames are in /particles/replica_K: "
		                                "set from.replica)");
		goto out;
	}
	if (H5Lexists(g, "position", H5P_DEFAULT) <= 0 || H5Lexists(g, "velocity", H5P_DEFAULT) <= 0 ||
	    extent(g, "position/value", dp) || extent(g, "velocity/value", dv) || memcmp(dp, dv, sizeof dp)) {
		h5u_fail(msg, msglen, 0, "%s: %s: /%s has no position and velocity frames of the same shape", key, path,
		         group);
		goto out;
	}
	const int64_t frames = (int64_t)dp[0], k_frame = s->from_frame < 0 ? frames + s->from_frame : s->from_frame;
	if (k_frame < 0 || k_frame >= frames) {
		h5u_fail(msg, msglen, 0, "particles.initial.from.frame: %" PRId64 " is out of range: %s has %" PRId64
		         " frame%s%s", s->from_frame, path, frames, frames == 1 ? "" : "s",
		         frames ? " (0 .. frames-1, or -frames .. -1 from the end)" : "");
		goto out;
	}
	if (dp[2] != (hsize_t)s->dim) {
		h5u_fail(msg, msglen, 0, "particles.initial.from: the frame in %s is %llu-dimensional, the scene's "
		         "dimensions is %d", path, (unsigned long long)dp[2], s->dim);
		goto out;
	}
	if (dp[1] != (hsize_t)s->count) {
		h5u_fail(msg, msglen, 0, "particles.initial.from: the frame in %s has %llu particles, the scene's "
		         "particles.count is %llu", path, (unsigned long long)dp[1], (unsigned long long)s->count);
		goto out;
	}
	p = malloc(s->count * s->dim * sizeof(double));
	v = malloc(s->count * s->dim * sizeof(double));
	if (!p || !v) {
		ret = FRAME_ENOMEM;
		h5u_fail(msg, msglen, 0, "out of memory reading %llu particles", (unsigned long long)s->count);
		goto out;
	}
	int rr = read_frame(g, "position/value", (hsize_t)k_frame, dp[1], dp[2], p);
	if (!rr)
		rr = read_frame(g, "velocity/value", (hsize_t)k_frame, dp[1], dp[2], v);
	if (rr) {
		h5u_fail(msg, msglen, 0, "%s: %s: cannot read frame %" PRId64 " (%s)", key, path, k_frame,
		         rr == -2 ? "damaged chunk index" : "damaged?");
		goto out;
	}
	if (s->rough) {
		/* rough particles: the frame's angular velocities, [frames, N, 1 (2D) or 3 (3D)] */
		hsize_t dw[3];
		const hsize_t k = s->dim == 2 ? 1 : 3;
		if (H5Lexists(g, "angular_velocity", H5P_DEFAULT) <= 0 || extent(g, "angular_velocity/value", dw) ||
		    dw[0] != dp[0] || dw[1] != dp[1] || dw[2] != k) {
			h5u_fail(msg, msglen, 0, "particles.initial.from: the frame in %s has no angular velocities (/%s/"
			         "angular_velocity: a smooth run's trajectory), which rough particles (collisions.rough) start "
			         "from", path, group);
			goto out;
		}
		if (!(w = malloc(s->count * k * sizeof(double)))) {
			ret = FRAME_ENOMEM;
			h5u_fail(msg, msglen, 0, "out of memory reading %llu particles", (unsigned long long)s->count);
			goto out;
		}
		if ((rr = read_frame(g, "angular_velocity/value", (hsize_t)k_frame, dp[1], k, w)) != 0) {
			h5u_fail(msg, msglen, 0, "%s: %s: cannot read frame %" PRId64 " (%s)", key, path, k_frame,
			         rr == -2 ? "damaged chunk index" : "damaged?");
			goto out;
		}
		for (size_t i = 0; i < s->count * k; i++)
			if (!isfinite(w[i])) {
				h5u_fail(msg, msglen, 0, "particles.initial.from: particle %zu has a non-finite angular velocity",
				         (size_t)(i / k));
				goto out;
			}
	}
	if (scene_has_species(s) && (ret = check_diameters(g, s, path, group, msg, msglen)) != FRAME_OK)
		goto out;
	ret = FRAME_EINVAL;
	int rc = place_check_state(s, p, v, "particles.initial.from", msg, msglen);
	if (rc != PLACE_OK) {
		ret = rc == PLACE_ENOMEM ? FRAME_ENOMEM : FRAME_EINVAL;
		goto out;
	}
	*pos = p;
	*vel = v;
	*spin = w;
	p = v = w = NULL;
	ret = FRAME_OK;
out:
	free(p);
	free(v);
	free(w);
	if (g >= 0) H5Gclose(g);
	if (f >= 0) H5Fclose(f);
	return ret;
}

const char *frame_strerror(int code)
{
	switch (code) {
	case FRAME_OK: return "success";
	case FRAME_EINVAL: return "initial frame not usable";
	case FRAME_ENOMEM: return "out of memory";
	default: return "unknown error";
	}
}
