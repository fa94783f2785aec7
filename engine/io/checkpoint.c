/* Crash-safe checkpoint files: the complete state of a run in HDF5, verified by a digest on load. */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <jansson.h>

#include "checkpoint.h"
#include "config.h"
#include "mc/dsmc.h"
#include "ed/ed.h"
#include "par/ensemble.h"
#include "h5util.h"

#define FORMAT_NAME "granulard-checkpoint"
#define FORMAT_VERSION 2    /* 2: the file digest in the user block (below) */
/* The first FILE_HEAD bytes of the file are an HDF5 user block (HDF5 skips
 * it) holding FILE_MAGIC, the file's length and a digest of every byte after
 * the block, little-endian. ckpt_read() checks them before HDF5 parses a
 * byte: HDF5 1.10 checksums most metadata but not all of it (the link
 * messages of a group with many members lie in an unchecksummed heap block),
 * and it crashes on some damaged files (found by tests/fuzz/ckpt_fuzz). */
#define FILE_HEAD 512
#define FILE_MAGIC "granulard-ckpt\n"   /* 16 bytes with its NUL */
/* Enough for either engine's state fields (ed.h, dsmc.h). */
#define CKPT_MAX_FIELDS (ED_MAX_FIELDS > DSMC_MAX_FIELDS ? ED_MAX_FIELDS : DSMC_MAX_FIELDS)

/* ---- digest: 64-bit, 8 bytes a step (xxhash-style rounds) ---------------
 * Detects torn and altered files; not a cryptographic hash. */
static const uint64_t K1 = 0x9E3779B185EBCA87ull, K2 = 0xC2B2AE3D27D4EB4Full;

static inline uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

static void dig(uint64_t *h, const void *p, size_t n)
{
	const unsigned char *b = p;
	uint64_t x = *h;
	while (n >= 8) {
		uint64_t w;
		memcpy(&w, b, 8);
		x = rotl(x ^ (w * K2), 31) * K1;
		b += 8;
		n -= 8;
	}
	if (n) {
		uint64_t w = 0;
		memcpy(&w, b, n);
		x = rotl(x ^ (w * K2) ^ n, 31) * K1;
	}
	*h = x;
}

static void dig_u64(uint64_t *h, uint64_t v) { dig(h, &v, 8); }

static uint64_t dig_final(uint64_t x)
{
	x ^= x >> 33;
	x *= K2;
	x ^= x >> 29;
	return x;
}

static void put_le64(unsigned char *b, uint64_t v)
{
	for (int i = 0; i < 8; i++)
		b[i] = (unsigned char)(v >> (8 * i));
}

static uint64_t get_le64(const unsigned char *b)
{
	uint64_t v = 0;
	for (int i = 0; i < 8; i++)
		v |= (uint64_t)b[i] << (8 * i);
	return v;
}

/* Digest of fd's bytes from FILE_HEAD to the end; *size gets the file's length. 0 or -1 (errno). */
static int file_digest(int fd, uint64_t *size, uint64_t *out)
{
	static const size_t CHUNK = 1 << 16;   /* a multiple of 8: chunks digest like one stream */
	unsigned char *b = malloc(CHUNK);
	uint64_t h = 0, n = 0;
	off_t off = FILE_HEAD;
	ssize_t r = 0;
	if (!b)
		return -1;
	while ((r = pread(fd, b, CHUNK, off)) > 0) {
		dig(&h, b, (size_t)r);
		off += r;
		n += (uint64_t)r;
		if ((size_t)r < CHUNK)
			break;
	}
	free(b);
	if (r < 0)
		return -1;
	*size = FILE_HEAD + n;
	*out = dig_final(h ^ n);
	return 0;
}

/* Seal a closed checkpoint file: its length and digest into the user block. 0 or -1 (errno). */
static int seal_file(const char *path)
{
	unsigned char head[FILE_HEAD] = {0};
	uint64_t size, d;
	int fd = open(path, O_RDWR | O_CLOEXEC), ret = -1;
	if (fd < 0)
		return -1;
	if (file_digest(fd, &size, &d) == 0) {
		memcpy(head, FILE_MAGIC, sizeof FILE_MAGIC);
		put_le64(head + 16, size);
		put_le64(head + 24, d);
		ret = pwrite(fd, head, FILE_HEAD, 0) == FILE_HEAD ? 0 : -1;
	}
	if (close(fd) != 0)
		ret = -1;
	return ret;
}

/* Before HDF5 sees the file: its user block names it a sealed checkpoint of
 * this length and the digest matches. 0, or -1 with the reason in why. A
 * checkpoint of format 1 (no user block) cannot be checked and is refused:
 * reading it unchecked would let a damaged one crash HDF5. */
static int verify_file(const char *path, char *why, size_t whylen)
{
	unsigned char head[FILE_HEAD];
	uint64_t size, d;
	int fd = open(path, O_RDONLY | O_CLOEXEC), ret = -1;
	if (fd < 0) {
		snprintf(why, whylen, "cannot open: %s", strerror(errno));
		return -1;
	}
	if (pread(fd, head, FILE_HEAD, 0) != FILE_HEAD)
		snprintf(why, whylen, "shorter than its header (truncated)");
	else if (!memcmp(head, "\211HDF\r\n\032\n", 8))
		snprintf(why, whylen, "format 1 (an engine before format %d), which cannot be verified; submit the job again",
		         FORMAT_VERSION);
	else if (memcmp(head, FILE_MAGIC, sizeof FILE_MAGIC))
		snprintf(why, whylen, "no checkpoint header (damaged)");
	else if (file_digest(fd, &size, &d))
		snprintf(why, whylen, "unreadable: %s", strerror(errno));
	else if (size != get_le64(head + 16))
		snprintf(why, whylen, "%llu bytes, its header says %llu (truncated or extended)", (unsigned long long)size,
		         (unsigned long long)get_le64(head + 16));
	else if (d != get_le64(head + 24))
		snprintf(why, whylen, "file digest mismatch (altered or torn)");
	else
		ret = 0;
	close(fd);
	return ret;
}

/* A field's name, type and length go into the digest with its data. */
static void dig_field(uint64_t *h, const char *name, ed_type_t t, size_t count, const void *data)
{
	dig(h, name, strlen(name) + 1);
	dig_u64(h, (uint64_t)t);
	dig_u64(h, (uint64_t)count);
	dig(h, data, count * ed_type_size(t));
}

static hid_t mem_type(ed_type_t t)
{
	switch (t) {
	case ED_T_F64: return H5T_NATIVE_DOUBLE;
	case ED_T_U64: return H5T_NATIVE_UINT64;
	case ED_T_I64: return H5T_NATIVE_INT64;
	case ED_T_I32: return H5T_NATIVE_INT32;
	case ED_T_U32: return H5T_NATIVE_UINT32;
	case ED_T_U8: return H5T_NATIVE_UINT8;
	}
	return H5I_INVALID_HID;
}

static hid_t file_type(ed_type_t t)
{
	switch (t) {
	case ED_T_F64: return H5T_IEEE_F64LE;
	case ED_T_U64: return H5T_STD_U64LE;
	case ED_T_I64: return H5T_STD_I64LE;
	case ED_T_I32: return H5T_STD_I32LE;
	case ED_T_U32: return H5T_STD_U32LE;
	case ED_T_U8: return H5T_STD_U8LE;
	}
	return H5I_INVALID_HID;
}


/* The run's schedule and the output positions, in digest order. */
typedef struct {
	const char *name;
	size_t off;
	int is_double;
} rfield_t;

static const rfield_t sched_fields[] = {
	{ "started", offsetof(run_state_t, started), 0 },
	{ "k_out", offsetof(run_state_t, k_out), 0 },
	{ "k_snap", offsetof(run_state_t, k_snap), 0 },
	{ "k_ckpt", offsetof(run_state_t, k_ckpt), 0 },
	{ "snap_events", offsetof(run_state_t, snap_events), 0 },
	{ "wall_before", offsetof(run_state_t, wall_before), 1 },
};
static const rfield_t out_fields[] = {
	{ "obs_rows", offsetof(ckpt_output_t, obs_rows), 0 },
	{ "snap_rows", offsetof(ckpt_output_t, snap_rows), 0 },
	{ "progress_bytes", offsetof(ckpt_output_t, progress_bytes), 0 },
};
#define N_RUN_FIELDS (sizeof sched_fields / sizeof sched_fields[0])
#define N_OUT_FIELDS (sizeof out_fields / sizeof out_fields[0])

static int write_rfields(hid_t g, const rfield_t *f, size_t n, const void *base, uint64_t *h)
{
	for (size_t k = 0; k < n; k++) {
		const char *p = (const char *)base + f[k].off;
		dig(h, p, 8);
		if (f[k].is_double ? h5u_attr_f64(g, f[k].name, (const double *)p, 1)
		                   : h5u_attr_u64(g, f[k].name, *(const uint64_t *)p))
			return -1;
	}
	return 0;
}

static int read_rfields(hid_t g, const rfield_t *f, size_t n, void *base, uint64_t *h)
{
	for (size_t k = 0; k < n; k++) {
		char *p = (char *)base + f[k].off;
		if (f[k].is_double ? h5u_read_attr_f64(g, f[k].name, (double *)p)
		                   : h5u_read_attr_u64(g, f[k].name, (uint64_t *)p))
			return -1;
		dig(h, p, 8);
	}
	return 0;
}


/* Read a fixed-length string dataset; caller frees. */
static char *read_string(hid_t loc, const char *name, size_t *len)
{
	char *buf = NULL;
	hid_t d = H5Dopen2(loc, name, H5P_DEFAULT), t = H5I_INVALID_HID;
	if (d < 0)
		return NULL;
	t = H5Dget_type(d);
	size_t n = t >= 0 && H5Tget_class(t) == H5T_STRING && !H5Tis_variable_str(t) ? H5Tget_size(t) : 0;
	if (n > 0 && n < (64u << 20) && (buf = malloc(n + 1)) != NULL) {
		if (H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
			free(buf);
			buf = NULL;
		} else {
			buf[n] = '\0';
			*len = strlen(buf);
		}
	}
	if (t >= 0) H5Tclose(t);
	H5Dclose(d);
	return buf;
}

static void path_in(char *dst, size_t len, const char *dir, const char *name)
{
	snprintf(dst, len, "%s/%s", dir, name);
}

static int write_field(hid_t g, const char *name, ed_type_t type, size_t count, const void *data, uint64_t *h)
{
	hsize_t dims[1] = {count};
	dig_field(h, name, type, count, data);
	hid_t sp = H5Screate_simple(1, dims, NULL);
	hid_t d = sp >= 0 ? H5Dcreate2(g, name, file_type(type), sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT)
	                  : H5I_INVALID_HID;
	int bad = d < 0 || (count && H5Dwrite(d, mem_type(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0);
	if (d >= 0) H5Dclose(d);
	if (sp >= 0) H5Sclose(sp);
	return bad ? -1 : 0;
}

/* The three files of a checkpoint directory. */
typedef struct {
	char tmp[PATH_MAX], cur[PATH_MAX], prev[PATH_MAX];
} ckpt_paths_t;

/* Start a checkpoint: fill *p for dir and create p->tmp (format 1.10, whose
 * metadata is checksummed too) with the format attributes. Returns the file
 * or a negative id (errno may say why). */
static hid_t begin_file(const char *dir, ckpt_paths_t *p)
{
	path_in(p->tmp, sizeof p->tmp, dir, CKPT_TMP);
	path_in(p->cur, sizeof p->cur, dir, CKPT_FILE);
	path_in(p->prev, sizeof p->prev, dir, CKPT_PREV);
	hid_t fapl = H5Pcreate(H5P_FILE_ACCESS), fcpl = H5Pcreate(H5P_FILE_CREATE), f = H5I_INVALID_HID;
	if (fapl >= 0 && fcpl >= 0 && H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_LATEST) >= 0 &&
	    H5Pset_userblock(fcpl, FILE_HEAD) >= 0)
		f = H5Fcreate(p->tmp, H5F_ACC_TRUNC, fcpl, fapl);
	if (fapl >= 0)
		H5Pclose(fapl);
	if (fcpl >= 0)
		H5Pclose(fcpl);
	if (f >= 0 && (h5u_attr_str(f, "format", FORMAT_NAME) || h5u_attr_u64(f, "format_version", FORMAT_VERSION) ||
	               h5u_attr_str(f, "creator", "granular-engine " PACKAGE_VERSION))) {
		H5Fclose(f);
		f = H5I_INVALID_HID;
	}
	return f;
}

/* Finish a checkpoint: the output group and the digest, then close *f
 * (set invalid either way), fsync, keep the previous checkpoint and replace
 * checkpoint.h5 atomically. 0, or -1 with the temporary file left to the
 * caller. */
static int publish(hid_t *f, const ckpt_paths_t *p, const ckpt_output_t *out, uint64_t h)
{
	hid_t g = h5u_group(*f, "output");
	int bad = g < 0 || write_rfields(g, out_fields, N_OUT_FIELDS, out, &h);
	if (g >= 0)
		H5Gclose(g);
	if (bad || h5u_attr_u64(*f, "digest", dig_final(h)))
		return -1;
	herr_t cl = H5Fclose(*f);
	*f = H5I_INVALID_HID;
	if (cl < 0 || seal_file(p->tmp) || h5u_fsync_path(p->tmp))
		return -1;
	/* Keep the previous one; checkpoint.h5 itself is replaced atomically. */
	if (unlink(p->prev) != 0 && errno != ENOENT)
		return -1;
	if (link(p->cur, p->prev) != 0 && errno != ENOENT && rename(p->cur, p->prev) != 0)
		return -1;
	if (rename(p->tmp, p->cur) != 0 || h5u_fsync_dir_of(p->cur))
		return -1;
	return 0;
}

int ckpt_write(const char *dir, run_t *run, const char *scene_text, size_t len,
               const ckpt_output_t *out, char *msg, size_t msglen)
{
	ckpt_paths_t p;
	ed_field_t fields[CKPT_MAX_FIELDS];
	int ret = CKPT_EIO, nf = run_fields(run, fields, CKPT_MAX_FIELDS);
	uint64_t h = 0;
	void *buf = NULL;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID;
	run_state_t st;

	h5u_quiet();
	errno = 0;
	if (nf > CKPT_MAX_FIELDS) {
		path_in(p.tmp, sizeof p.tmp, dir, CKPT_TMP);
		return h5u_fail(msg, msglen, CKPT_EIO, "%s: too many state fields", p.tmp);
	}
	if ((f = begin_file(dir, &p)) < 0)
		goto io;
	double tot_time;
	uint64_t tot_events, tot_coll;
	run_totals(run, &tot_time, &tot_events, &tot_coll);
	if (h5u_attr_f64(f, "time", &tot_time, 1) || h5u_attr_u64(f, "events", tot_events) ||
	    h5u_attr_u64(f, "collisions", tot_coll) || h5u_write_string(f, "scene", scene_text, len))
		goto io;
	dig(&h, scene_text, len);
	if ((g = h5u_group(f, run_engine_name(run))) < 0)
		goto io;
	for (int k = 0; k < nf; k++) {
		size_t bytes = fields[k].count * ed_type_size(fields[k].type);
		buf = malloc(bytes ? bytes : 1);
		if (!buf) {
			ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", p.tmp);
			goto cleanup;
		}
		run_field_get(run, fields[k].name, buf);
		int bad = write_field(g, fields[k].name, fields[k].type, fields[k].count, buf, &h);
		free(buf);
		buf = NULL;
		if (bad)
			goto io;
	}
	H5Gclose(g);
	g = H5I_INVALID_HID;
	size_t xlen = 0;
	const void *x = run_extra(run, &xlen);
	if (x) {   /* a split ed run's core state (edrun.c), after the fields in the digest */
		if ((g = h5u_group(f, "ped")) < 0 || write_field(g, "image", ED_T_U8, xlen, x, &h))
			goto io;
		H5Gclose(g);
		g = H5I_INVALID_HID;
	}
	run_get_state(run, &st);
	if ((g = h5u_group(f, "run")) < 0 || write_rfields(g, sched_fields, N_RUN_FIELDS, &st, &h))
		goto io;
	H5Gclose(g);
	g = H5I_INVALID_HID;
	if (publish(&f, &p, out, h))
		goto io;
	ret = CKPT_OK;
	goto cleanup;
io:
	ret = h5u_fail(msg, msglen, CKPT_EIO, "%s: cannot write the checkpoint%s%s", p.tmp, errno ? ": " : "",
	            errno ? strerror(errno) : "");
	if (f < 0)
		unlink(p.tmp);   /* a half-written file must not linger (f open: removed below) */
cleanup:
	free(buf);
	if (g >= 0) H5Gclose(g);
	if (f >= 0) {
		H5Fclose(f);
		unlink(p.tmp);
	}
	return ret;
}

static int same_scene(const char *a, size_t alen, const char *b, size_t blen)
{
	json_error_t e;
	json_t *x = json_loadb(a, alen, 0, &e), *y = json_loadb(b, blen, 0, &e);
	int same = x && y && json_equal(x, y);
	json_decref(x);
	json_decref(y);
	return same;
}

/* The opening every checkpoint read shares: the file is there (else
 * CKPT_EMISSING or CKPT_EIO, msg set, nothing open), its whole-file digest
 * holds (verify_file()), it is HDF5 of this format with a stored digest
 * (*want) and scene (*text, *tlen; the caller frees). CKPT_ECORRUPT with
 * why set for a damaged file; *f is then open or invalid as far as it got
 * (the caller closes it). */
static int open_header(const char *path, hid_t *f, uint64_t *want, char **text, size_t *tlen, char *why,
                       size_t whylen, char *msg, size_t msglen)
{
	uint64_t fmt = 0;
	if (access(path, R_OK) != 0)
		return h5u_fail(msg, msglen, errno == ENOENT ? CKPT_EMISSING : CKPT_EIO, "%s: %s", path, strerror(errno));
	if (verify_file(path, why, whylen))
		return CKPT_ECORRUPT;
	*f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
	if (*f < 0) {
		snprintf(why, whylen, "not a readable HDF5 file (truncated or damaged)");
		return CKPT_ECORRUPT;
	}
	if (h5u_read_attr_u64(*f, "format_version", &fmt) || fmt != FORMAT_VERSION ||
	    h5u_read_attr_u64(*f, "digest", want) || !(*text = read_string(*f, "scene", tlen))) {
		snprintf(why, whylen, "not a granular-engine checkpoint of format %d", FORMAT_VERSION);
		return CKPT_ECORRUPT;
	}
	return CKPT_OK;
}

/* A stored scene (text, tlen) against the caller's: 0 the same; 1 another
 * one, parsed into *stored (another scene's checkpoint, CKPT_ESCENE, or a
 * damaged one, CKPT_ECORRUPT: the file is read against its own scene and
 * the digest decides); -1 not a valid scene (damaged, why set). */
static int stored_scene(const char *text, size_t tlen, const char *scene_text, size_t len, scene_t *stored,
                        char *why, size_t whylen)
{
	if (same_scene(text, tlen, scene_text, len))
		return 0;
	if (scene_parse(text, tlen, stored, NULL, 0) != SCENE_OK) {
		snprintf(why, whylen, "its stored scene is not a valid scene (damaged)");
		return -1;
	}
	return 1;
}

int ckpt_read(const char *path, const scene_t *s, const char *scene_text, size_t len,
              const run_opts_t *opts, run_t **run_out, ckpt_output_t *out, char *msg, size_t msglen)
{
	ed_field_t fields[CKPT_MAX_FIELDS];
	int ret = CKPT_ECORRUPT, err = 0;
	uint64_t h = 0, want = 0;
	char *text = NULL, why[256] = "";
	size_t tlen = 0;
	void *buf = NULL;
	run_t *run = NULL;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID, d = H5I_INVALID_HID, sp = H5I_INVALID_HID;
	run_state_t st = {0};   /* fields not stored (frames) start at 0 */
	scene_t stored;         /* the file's own scene, when it differs from s */
	int differs = 0;

	*run_out = NULL;
	h5u_quiet();
	int oc = open_header(path, &f, &want, &text, &tlen, why, sizeof why, msg, msglen);
	if (oc == CKPT_ECORRUPT)
		goto corrupt;
	if (oc != CKPT_OK)
		return oc;
	/* another scene's checkpoint (CKPT_ESCENE: the caller must not fall
	 * back) or a damaged one (CKPT_ECORRUPT: the caller falls back to the
	 * previous checkpoint): stored_scene() */
	if ((differs = stored_scene(text, tlen, scene_text, len, &stored, why, sizeof why)) < 0)
		goto corrupt;
	if (differs)
		s = &stored;
	dig(&h, text, tlen);
	run = run_create_blank(s, opts, &err, why, sizeof why);
	if (!run && err != RUN_ENOMEM && differs) {
		snprintf(why, sizeof why, "its stored scene cannot be verified (damaged or for another method)");
		goto corrupt;
	}
	if (!run) {
		ret = h5u_fail(msg, msglen, err == RUN_ENOMEM ? CKPT_ENOMEM : CKPT_ECORRUPT, "%s: %s", path, why);
		goto cleanup;
	}
	int nf = run_fields(run, fields, CKPT_MAX_FIELDS);
	if (nf > CKPT_MAX_FIELDS || (g = H5Gopen2(f, run_engine_name(run), H5P_DEFAULT)) < 0) {
		snprintf(why, sizeof why, "no engine state");
		goto corrupt;
	}
	for (int k = 0; k < nf; k++) {
		hssize_t count;
		d = H5Dopen2(g, fields[k].name, H5P_DEFAULT);
		if (d < 0 || (sp = H5Dget_space(d)) < 0 || (count = H5Sget_simple_extent_npoints(sp)) < 0) {
			snprintf(why, sizeof why, "state field %s missing", fields[k].name);
			goto corrupt;
		}
		size_t bytes = (size_t)count * ed_type_size(fields[k].type);
		buf = malloc(bytes ? bytes : 1);
		if (!buf) {
			ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
			goto cleanup;
		}
		if (bytes && H5Dread(d, mem_type(fields[k].type), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
			snprintf(why, sizeof why, "state field %s unreadable", fields[k].name);
			goto corrupt;
		}
		dig_field(&h, fields[k].name, fields[k].type, (size_t)count, buf);
		if (run_field_set(run, fields[k].name, fields[k].type, (size_t)count, buf) != RUN_OK) {
			snprintf(why, sizeof why, "state field %s does not fit the scene", fields[k].name);
			goto corrupt;
		}
		free(buf);
		buf = NULL;
		H5Sclose(sp);
		H5Dclose(d);
		sp = d = H5I_INVALID_HID;
	}
	H5Gclose(g);
	g = H5I_INVALID_HID;
	if (H5Lexists(f, "ped", H5P_DEFAULT) > 0) {
		/* optional: a split ed run's core state (written by split runs only;
		 * a run at another rank count, or serial, ignores it) */
		hssize_t count;
		if ((g = H5Gopen2(f, "ped", H5P_DEFAULT)) < 0 || (d = H5Dopen2(g, "image", H5P_DEFAULT)) < 0 ||
		    (sp = H5Dget_space(d)) < 0 || (count = H5Sget_simple_extent_npoints(sp)) < 0) {
			snprintf(why, sizeof why, "ped image unreadable");
			goto corrupt;
		}
		buf = malloc(count ? (size_t)count : 1);
		if (!buf) {
			ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
			goto cleanup;
		}
		if (count && H5Dread(d, mem_type(ED_T_U8), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
			snprintf(why, sizeof why, "ped image unreadable");
			goto corrupt;
		}
		dig_field(&h, "image", ED_T_U8, (size_t)count, buf);
		if (run_extra_set(run, buf, (size_t)count) != RUN_OK) {
			ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
			goto cleanup;
		}
		free(buf);
		buf = NULL;
		H5Sclose(sp);
		H5Dclose(d);
		H5Gclose(g);
		sp = d = g = H5I_INVALID_HID;
	}
	memset(&st, 0, sizeof st);
	if ((g = H5Gopen2(f, "run", H5P_DEFAULT)) < 0 || read_rfields(g, sched_fields, N_RUN_FIELDS, &st, &h)) {
		snprintf(why, sizeof why, "run state missing");
		goto corrupt;
	}
	H5Gclose(g);
	if ((g = H5Gopen2(f, "output", H5P_DEFAULT)) < 0 || read_rfields(g, out_fields, N_OUT_FIELDS, out, &h)) {
		snprintf(why, sizeof why, "output state missing");
		goto corrupt;
	}
	if (dig_final(h) != want) {
		snprintf(why, sizeof why, "digest mismatch (altered or torn)");
		goto corrupt;
	}
	if (differs) {
		ret = h5u_fail(msg, msglen, CKPT_ESCENE, "%s: written for a different scene than the one given", path);
		goto cleanup;
	}
	run_set_state(run, &st);
	if (run_restore_finish(run, why, sizeof why) != RUN_OK)
		goto corrupt;
	*run_out = run;
	run = NULL;
	ret = CKPT_OK;
	goto cleanup;
corrupt:
	ret = h5u_fail(msg, msglen, CKPT_ECORRUPT, "%s: corrupt checkpoint: %s", path, why);
cleanup:
	free(buf);
	free(text);
	run_destroy(run);
	if (sp >= 0) H5Sclose(sp);
	if (d >= 0) H5Dclose(d);
	if (g >= 0) H5Gclose(g);
	if (f >= 0) H5Fclose(f);
	return ret;
}

const char *ckpt_strerror(int code)
{
	switch (code) {
	case CKPT_OK: return "ok";
	case CKPT_EIO: return "cannot write the checkpoint";
	case CKPT_ENOMEM: return "out of memory";
	case CKPT_ECORRUPT: return "corrupt checkpoint";
	case CKPT_ESCENE: return "checkpoint of another scene";
	case CKPT_EMISSING: return "no checkpoint";
	default: return "unknown error";
	}
}

/* ---- ensembles ---------------------------------------------------------------
 * One file for all replicas, written by rank 0 from the replicas' state
 * strings (ensemble_save()): group /replica_K per replica, one dataset per
 * field in the string's order (creation order is tracked, so reading
 * rebuilds the same string), digest over the strings. */

static const rfield_t ens_fields[] = {
	{ "k_ckpt", offsetof(ckpt_ensemble_t, k_ckpt), 0 },
	{ "wall_before", offsetof(ckpt_ensemble_t, wall_before), 1 },
};
#define N_ENS_FIELDS (sizeof ens_fields / sizeof ens_fields[0])

int ckpt_write_ensemble(const char *dir, int R, unsigned char *const *blobs, const size_t *lens,
                        const ckpt_ensemble_t *es, const char *scene_text, size_t len, const ckpt_output_t *out,
                        char *msg, size_t msglen)
{
	ckpt_paths_t p;
	char gname[64];
	uint64_t h = 0;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID, gcpl = H5I_INVALID_HID;
	int ret = CKPT_EIO;

	h5u_quiet();
	errno = 0;
	f = begin_file(dir, &p);
	gcpl = H5Pcreate(H5P_GROUP_CREATE);
	if (f < 0 || gcpl < 0 || H5Pset_link_creation_order(gcpl, H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED) < 0 ||
	    h5u_attr_u64(f, "replicas", (uint64_t)R) || h5u_write_string(f, "scene", scene_text, len))
		goto io;
	dig(&h, scene_text, len);
	dig_u64(&h, (uint64_t)R);
	for (int r = 0; r < R; r++) {
		size_t pos = 0;
		ed_field_t fl;
		const void *data;
		int rc;
		snprintf(gname, sizeof gname, "replica_%d", r);
		if ((g = H5Gcreate2(f, gname, H5P_DEFAULT, gcpl, H5P_DEFAULT)) < 0)
			goto io;
		while ((rc = ensemble_next_field(blobs[r], lens[r], &pos, &fl, &data)) == 1)
			if (write_field(g, fl.name, fl.type, fl.count, data, &h))
				goto io;
		if (rc < 0)
			goto io;
		H5Gclose(g);
		g = H5I_INVALID_HID;
	}
	if ((g = h5u_group(f, "ensemble")) < 0 || write_rfields(g, ens_fields, N_ENS_FIELDS, es, &h))
		goto io;
	H5Gclose(g);
	g = H5I_INVALID_HID;
	if (publish(&f, &p, out, h))
		goto io;
	ret = CKPT_OK;
	goto cleanup;
io:
	ret = h5u_fail(msg, msglen, CKPT_EIO, "%s: cannot write the checkpoint%s%s", p.tmp, errno ? ": " : "",
	               errno ? strerror(errno) : "");
	if (f < 0)
		unlink(p.tmp);
cleanup:
	if (g >= 0) H5Gclose(g);
	if (f >= 0) {
		H5Fclose(f);
		unlink(p.tmp);
	}
	if (gcpl >= 0) H5Pclose(gcpl);
	return ret;
}

static int type_of(hid_t ft, ed_type_t *t)
{
	static const ed_type_t all[] = {ED_T_F64, ED_T_U64, ED_T_I64, ED_T_I32, ED_T_U32, ED_T_U8};
	for (size_t k = 0; k < sizeof all / sizeof all[0]; k++)
		if (H5Tequal(ft, file_type(all[k])) > 0) {
			*t = all[k];
			return 0;
		}
	return -1;
}

/* Rebuild one replica's state string from its group, in creation order. */
typedef struct {
	unsigned char *buf;
	size_t len, cap;
	uint64_t *h;
	int bad;
} gather_t;

static herr_t gather_one(hid_t g, const char *name, const H5L_info_t *info, void *ctx)
{
	gather_t *ga = ctx;
	(void)info;
	hid_t d = H5Dopen2(g, name, H5P_DEFAULT), sp = H5I_INVALID_HID, ft = H5I_INVALID_HID;
	hssize_t count = -1;
	ed_type_t t;
	void *data = NULL;
	if (d < 0 || (sp = H5Dget_space(d)) < 0 || (count = H5Sget_simple_extent_npoints(sp)) < 0 ||
	    (ft = H5Dget_type(d)) < 0 || type_of(ft, &t) || strlen(name) >= 64 ||
	    !(data = malloc((size_t)count * ed_type_size(t) + 1)) ||
	    (count && H5Dread(d, mem_type(t), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) ||
	    ensemble_put_field(&ga->buf, &ga->len, &ga->cap, name, t, (size_t)count, data))
		ga->bad = 1;
	else
		dig_field(ga->h, name, t, (size_t)count, data);
	free(data);
	if (ft >= 0) H5Tclose(ft);
	if (sp >= 0) H5Sclose(sp);
	if (d >= 0) H5Dclose(d);
	return ga->bad ? -1 : 0;
}

int ckpt_read_ensemble(const char *path, const scene_t *s, const char *scene_text, size_t len,
                       unsigned char **blobs, size_t *lens, ckpt_ensemble_t *es, ckpt_output_t *out,
                       char *msg, size_t msglen)
{
	int ret = CKPT_ECORRUPT, R = (int)s->replicas;
	uint64_t h = 0, want = 0, reps = 0;
	char *text = NULL, why[256] = "", gname[64];
	size_t tlen = 0;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID;

	for (int r = 0; r < R; r++)
		blobs[r] = NULL, lens[r] = 0;
	h5u_quiet();
	int oc = open_header(path, &f, &want, &text, &tlen, why, sizeof why, msg, msglen);
	if (oc == CKPT_ECORRUPT)
		goto corrupt;
	if (oc != CKPT_OK)
		return oc;
	/* A stored scene that differs: another scene's checkpoint (CKPT_ESCENE)
	 * or a damaged one (CKPT_ECORRUPT, the caller falls back): the digest,
	 * over the file's own replicas, decides. */
	int differs = !same_scene(text, tlen, scene_text, len);
	if (h5u_read_attr_u64(f, "replicas", &reps) || (!differs && reps != (uint64_t)R) || reps < 1 ||
	    reps > (uint64_t)1 << 24) {
		snprintf(why, sizeof why, "not an ensemble checkpoint of %d replicas", R);
		goto corrupt;
	}
	dig(&h, text, tlen);
	dig_u64(&h, reps);
	for (int r = 0; r < (int)reps; r++) {
		gather_t ga = {NULL, 0, 0, &h, 0};
		hsize_t idx = 0;
		snprintf(gname, sizeof gname, "replica_%d", r);
		if ((g = H5Gopen2(f, gname, H5P_DEFAULT)) < 0 ||
		    H5Literate(g, H5_INDEX_CRT_ORDER, H5_ITER_INC, &idx, gather_one, &ga) < 0 || ga.bad) {
			free(ga.buf);
			snprintf(why, sizeof why, "replica %d state missing or unreadable", r);
			goto corrupt;
		}
		H5Gclose(g);
		g = H5I_INVALID_HID;
		if (differs) {
			free(ga.buf);   /* only the digest counts */
			continue;
		}
		blobs[r] = ga.buf;
		lens[r] = ga.len;
	}
	if ((g = H5Gopen2(f, "ensemble", H5P_DEFAULT)) < 0 || read_rfields(g, ens_fields, N_ENS_FIELDS, es, &h)) {
		snprintf(why, sizeof why, "ensemble state missing");
		goto corrupt;
	}
	H5Gclose(g);
	if ((g = H5Gopen2(f, "output", H5P_DEFAULT)) < 0 || read_rfields(g, out_fields, N_OUT_FIELDS, out, &h)) {
		snprintf(why, sizeof why, "output state missing");
		goto corrupt;
	}
	if (dig_final(h) != want) {
		snprintf(why, sizeof why, "digest mismatch (altered or torn)");
		goto corrupt;
	}
	if (differs) {
		ret = h5u_fail(msg, msglen, CKPT_ESCENE, "%s: written for a different scene than the one given", path);
		goto cleanup;
	}
	/* Each replica must load (consistency checks of the engines). */
	for (int r = 0; r < R; r++) {
		run_t *run = NULL;
		int rc = ensemble_load(s, (uint64_t)r, blobs[r], lens[r], &run, why, sizeof why);
		run_destroy(run);
		if (rc == RUN_ENOMEM) {
			ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
			goto cleanup;
		}
		if (rc != RUN_OK) {
			ret = h5u_fail(msg, msglen, CKPT_ECORRUPT, "%s: corrupt checkpoint: replica %d: %s", path, r, why);
			goto cleanup;
		}
	}
	ret = CKPT_OK;
	goto cleanup;
corrupt:
	ret = h5u_fail(msg, msglen, CKPT_ECORRUPT, "%s: corrupt checkpoint: %s", path, why);
cleanup:
	if (ret != CKPT_OK)
		for (int r = 0; r < R; r++) {
			free(blobs[r]);
			blobs[r] = NULL;
		}
	free(text);
	if (g >= 0) H5Gclose(g);
	if (f >= 0) H5Fclose(f);
	return ret;
}

/* ---- split runs ----------------------------------------------------------------
 * Group /dsmcp: the state of dsmcp.h in the 1-rank order, written by rank 0
 * of the run (engine/par/dsmcrun.c gathers it), read by rank 0 of any rank
 * count. */
#define SPLIT_GROUP "dsmcp"
enum { SC_TIME, SC_EKIN, SC_ESCALE, SC_TSAMPLE, SC_EKIN_INT, SC_VIRIAL, SC_N };
enum { SN_STEPS, SN_COLL, SN_CAND, SN_VMAX, SN_MIGR, SN_MOVES, SN_CELLC, SN_REJ, SN_SAMPLE, SN_N };

/* The fields of a split state in file order: name, type, count, data. */
typedef struct {
	const char *name;
	ed_type_t type;
	size_t count;
	void *data;
} sfield_t;

static int split_fields(ckpt_split_t *ck, double *clock, uint64_t *counters, sfield_t *f)
{
	dsmcp_saved_t *sv = &ck->state;
	const size_t nd = (size_t)sv->n * (size_t)sv->dim;
	f[0] = (sfield_t){"position", ED_T_F64, nd, sv->pos};
	f[1] = (sfield_t){"velocity", ED_T_F64, nd, sv->vel};
	f[2] = (sfield_t){"id", ED_T_U32, (size_t)sv->n, sv->id};
	f[3] = (sfield_t){"cell_count", ED_T_U32, (size_t)sv->ncells, sv->count};
	f[4] = (sfield_t){"remainder", ED_T_F64, (size_t)sv->ncells, sv->rem};
	f[5] = (sfield_t){"clock", ED_T_F64, SC_N, clock};
	f[6] = (sfield_t){"counters", ED_T_U64, SN_N, counters};
	return 7;
}

static void pack_clock(const ckpt_split_t *ck, double *c, uint64_t *n)
{
	const dsmcp_clock_t *k = &ck->state.clock;
	c[SC_TIME] = k->time, c[SC_EKIN] = k->kinetic_energy, c[SC_ESCALE] = k->energy_scale;
	c[SC_TSAMPLE] = k->t_sample, c[SC_EKIN_INT] = k->ekin_int, c[SC_VIRIAL] = ck->state.virial;
	n[SN_STEPS] = k->steps, n[SN_COLL] = k->collisions, n[SN_CAND] = k->candidates, n[SN_VMAX] = k->vmax_raised;
	n[SN_MIGR] = k->migrated, n[SN_MOVES] = k->moves, n[SN_CELLC] = k->cell_collisions, n[SN_REJ] = k->rejected;
	n[SN_SAMPLE] = ck->coll_sample;
}

static void unpack_clock(ckpt_split_t *ck, const double *c, const uint64_t *n)
{
	dsmcp_clock_t *k = &ck->state.clock;
	k->time = c[SC_TIME], k->kinetic_energy = c[SC_EKIN], k->energy_scale = c[SC_ESCALE];
	k->t_sample = c[SC_TSAMPLE], k->ekin_int = c[SC_EKIN_INT], ck->state.virial = c[SC_VIRIAL];
	k->steps = n[SN_STEPS], k->collisions = n[SN_COLL], k->candidates = n[SN_CAND], k->vmax_raised = n[SN_VMAX];
	k->migrated = n[SN_MIGR], k->moves = n[SN_MOVES], k->cell_collisions = n[SN_CELLC], k->rejected = n[SN_REJ];
	ck->coll_sample = n[SN_SAMPLE];
}

int ckpt_write_split(const char *dir, const ckpt_split_t *ck, const char *scene_text, size_t len,
                     const ckpt_output_t *out, char *msg, size_t msglen)
{
	ckpt_paths_t p;
	uint64_t h = 0, counters[SN_N];
	double clock[SC_N];
	sfield_t fl[8];
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID;
	int ret = CKPT_EIO;
	ckpt_split_t c = *ck;   /* the fields point at ck's arrays; nothing is written through them */

	h5u_quiet();
	errno = 0;
	pack_clock(ck, clock, counters);
	int nf = split_fields(&c, clock, counters, fl);
	if ((f = begin_file(dir, &p)) < 0)
		goto io;
	if (h5u_attr_f64(f, "time", &clock[SC_TIME], 1) || h5u_attr_u64(f, "events", counters[SN_MOVES]) ||
	    h5u_attr_u64(f, "collisions", counters[SN_COLL]) || h5u_write_string(f, "scene", scene_text, len))
		goto io;
	dig(&h, scene_text, len);
	if ((g = h5u_group(f, SPLIT_GROUP)) < 0)
		goto io;
	for (int k = 0; k < nf; k++)
		if (write_field(g, fl[k].name, fl[k].type, fl[k].count, fl[k].data, &h))
			goto io;
	H5Gclose(g);
	if ((g = h5u_group(f, "run")) < 0 || write_rfields(g, sched_fields, N_RUN_FIELDS, &ck->sched, &h))
		goto io;
	H5Gclose(g);
	g = H5I_INVALID_HID;
	if (publish(&f, &p, out, h))
		goto io;
	ret = CKPT_OK;
	goto cleanup;
io:
	ret = h5u_fail(msg, msglen, CKPT_EIO, "%s: cannot write the checkpoint%s%s", p.tmp, errno ? ": " : "",
	               errno ? strerror(errno) : "");
	if (f < 0)
		unlink(p.tmp);
cleanup:
	if (g >= 0) H5Gclose(g);
	if (f >= 0) {
		H5Fclose(f);
		unlink(p.tmp);
	}
	return ret;
}

int ckpt_read_split(const char *path, const scene_t *s, const char *scene_text, size_t len, ckpt_split_t *ck,
                    ckpt_output_t *out, char *msg, size_t msglen)
{
	int ret = CKPT_ECORRUPT, differs = 0;
	uint64_t h = 0, want = 0, counters[SN_N], c0, c1, ncells;
	double clock[SC_N];
	char *text = NULL, why[256] = "";
	size_t tlen = 0;
	sfield_t fl[8];
	scene_t stored;
	hid_t f = H5I_INVALID_HID, g = H5I_INVALID_HID, d = H5I_INVALID_HID, sp = H5I_INVALID_HID;

	memset(ck, 0, sizeof *ck);
	h5u_quiet();
	int oc = open_header(path, &f, &want, &text, &tlen, why, sizeof why, msg, msglen);
	if (oc == CKPT_ECORRUPT)
		goto corrupt;
	if (oc != CKPT_OK)
		return oc;
	/* another scene's file (CKPT_ESCENE) or a damaged one (CKPT_ECORRUPT): the digest decides (ckpt_read()) */
	if ((differs = stored_scene(text, tlen, scene_text, len, &stored, why, sizeof why)) < 0)
		goto corrupt;
	if (differs)
		s = &stored;
	dig(&h, text, tlen);
	if (dsmcp_cells_of(s, 0, 1, &c0, &c1, &ncells, NULL, 0) != DSMCP_OK) {
		snprintf(why, sizeof why, "its scene cannot run split over ranks (damaged or for another method)");
		goto corrupt;
	}
	if (H5Lexists(f, SPLIT_GROUP, H5P_DEFAULT) <= 0 || (g = H5Gopen2(f, SPLIT_GROUP, H5P_DEFAULT)) < 0) {
		snprintf(why, sizeof why, "no state of a split run (/%s): it was written by a run on one rank, not split",
		         SPLIT_GROUP);
		goto corrupt;
	}
	if (dsmcp_saved_alloc(&ck->state, (int)s->dim, s->count, ncells) != DSMCP_OK) {
		ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
		goto cleanup;
	}
	int nf = split_fields(ck, clock, counters, fl);
	for (int k = 0; k < nf; k++) {
		hssize_t count;
		d = H5Dopen2(g, fl[k].name, H5P_DEFAULT);
		if (d < 0 || (sp = H5Dget_space(d)) < 0 || (count = H5Sget_simple_extent_npoints(sp)) < 0) {
			snprintf(why, sizeof why, "state field %s missing", fl[k].name);
			goto corrupt;
		}
		if ((size_t)count != fl[k].count) {
			snprintf(why, sizeof why, "state field %s has %lld elements, not %zu", fl[k].name, (long long)count,
			         fl[k].count);
			goto corrupt;
		}
		if (count && H5Dread(d, mem_type(fl[k].type), H5S_ALL, H5S_ALL, H5P_DEFAULT, fl[k].data) < 0) {
			snprintf(why, sizeof why, "state field %s unreadable", fl[k].name);
			goto corrupt;
		}
		dig_field(&h, fl[k].name, fl[k].type, fl[k].count, fl[k].data);
		H5Sclose(sp);
		H5Dclose(d);
		sp = d = H5I_INVALID_HID;
	}
	H5Gclose(g);
	if ((g = H5Gopen2(f, "run", H5P_DEFAULT)) < 0 || read_rfields(g, sched_fields, N_RUN_FIELDS, &ck->sched, &h)) {
		snprintf(why, sizeof why, "run state missing");
		goto corrupt;
	}
	H5Gclose(g);
	if ((g = H5Gopen2(f, "output", H5P_DEFAULT)) < 0 || read_rfields(g, out_fields, N_OUT_FIELDS, out, &h)) {
		snprintf(why, sizeof why, "output state missing");
		goto corrupt;
	}
	if (dig_final(h) != want) {
		snprintf(why, sizeof why, "digest mismatch (altered or torn)");
		goto corrupt;
	}
	if (differs) {
		ret = h5u_fail(msg, msglen, CKPT_ESCENE, "%s: written for a different scene than the one given", path);
		goto cleanup;
	}
	unpack_clock(ck, clock, counters);
	int rc = dsmcp_saved_check(&ck->state, s, why, sizeof why);
	if (rc == DSMCP_ENOMEM) {
		ret = h5u_fail(msg, msglen, CKPT_ENOMEM, "%s: out of memory", path);
		goto cleanup;
	}
	if (rc != DSMCP_OK || !ck->sched.started)
		goto corrupt;
	ret = CKPT_OK;
	goto cleanup;
corrupt:
	ret = h5u_fail(msg, msglen, CKPT_ECORRUPT, "%s: corrupt checkpoint: %s", path, why[0] ? why : "inconsistent");
cleanup:
	if (ret != CKPT_OK)
		dsmcp_saved_free(&ck->state);
	free(text);
	if (sp >= 0) H5Sclose(sp);
	if (d >= 0) H5Dclose(d);
	if (g >= 0) H5Gclose(g);
	if (f >= 0) H5Fclose(f);
	return ret;
}

/* Whether the verified file at path has the split group. -1: does not verify. */
static int split_file(const char *path)
{
	char why[256];
	if (access(path, R_OK) != 0 || verify_file(path, why, sizeof why))
		return -1;
	hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
	if (f < 0)
		return -1;
	int yes = H5Lexists(f, SPLIT_GROUP, H5P_DEFAULT) > 0;
	H5Fclose(f);
	return yes;
}

int ckpt_is_split(const char *path)
{
	char prev[PATH_MAX];
	h5u_quiet();
	int k = split_file(path);
	if (k >= 0)
		return k;
	const char *slash = strrchr(path, '/');
	snprintf(prev, sizeof prev, "%.*s%s", slash ? (int)(slash - path + 1) : 0, path, CKPT_PREV);
	return split_file(prev);
}
