/* Small HDF5 and file-system helpers shared by the H5MD writer and the checkpoint files. */
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "h5util.h"

void h5u_quiet(void)
{
	H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}

static int attr_write(hid_t obj, const char *name, hid_t ftype, hid_t mtype, hid_t space, const void *buf)
{
	int ret = -1;
	hid_t a = H5Acreate2(obj, name, ftype, space, H5P_DEFAULT, H5P_DEFAULT);
	if (a >= 0 && H5Awrite(a, mtype, buf) >= 0)
		ret = 0;
	if (a >= 0)
		H5Aclose(a);
	return ret;
}

int h5u_attr_str(hid_t obj, const char *name, const char *value)
{
	int ret = -1;
	hid_t t = H5Tcopy(H5T_C_S1), s = H5Screate(H5S_SCALAR);
	if (t >= 0 && s >= 0 && H5Tset_size(t, strlen(value) + 1) >= 0 && H5Tset_strpad(t, H5T_STR_NULLTERM) >= 0)
		ret = attr_write(obj, name, t, t, s, value);
	if (t >= 0) H5Tclose(t);
	if (s >= 0) H5Sclose(s);
	return ret;
}

int h5u_attr_strs(hid_t obj, const char *name, const char *const *values, size_t n)
{
	size_t w = 1;
	char buf[16 * 64];
	for (size_t i = 0; i < n; i++)
		if (strlen(values[i]) + 1 > w)
			w = strlen(values[i]) + 1;
	if (n * w > sizeof buf || n == 0)
		return -1;
	memset(buf, 0, sizeof buf);
	for (size_t i = 0; i < n; i++)
		memcpy(buf + i * w, values[i], strlen(values[i]));
	int ret = -1;
	hsize_t dims[1] = {n};
	hid_t t = H5Tcopy(H5T_C_S1), s = H5Screate_simple(1, dims, NULL);
	if (t >= 0 && s >= 0 && H5Tset_size(t, w) >= 0 && H5Tset_strpad(t, H5T_STR_NULLTERM) >= 0)
		ret = attr_write(obj, name, t, t, s, buf);
	if (t >= 0) H5Tclose(t);
	if (s >= 0) H5Sclose(s);
	return ret;
}

static int attr_array(hid_t obj, const char *name, hid_t ftype, hid_t mtype, const void *v, size_t n)
{
	hsize_t dims[1] = {n};
	hid_t s = n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, dims, NULL);
	int ret = s >= 0 ? attr_write(obj, name, ftype, mtype, s, v) : -1;
	if (s >= 0) H5Sclose(s);
	return ret;
}

int h5u_attr_i64(hid_t obj, const char *name, const int64_t *values, size_t n)
{
	/* small integers as 32-bit: what H5MD readers expect for version/dimension */
	int32_t v[16];
	if (n > 16)
		return -1;
	for (size_t i = 0; i < n; i++)
		v[i] = (int32_t)values[i];
	return attr_array(obj, name, H5T_STD_I32LE, H5T_NATIVE_INT32, v, n);
}

int h5u_attr_u64(hid_t obj, const char *name, uint64_t value)
{
	return attr_array(obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &value, 1);
}

int h5u_attr_f64(hid_t obj, const char *name, const double *values, size_t n)
{
	return attr_array(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, values, n);
}

static int read_attr(hid_t obj, const char *name, hid_t mtype, void *v)
{
	int ret = -1;
	hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
	if (a < 0)
		return -1;
	hid_t s = H5Aget_space(a);
	if (s >= 0 && H5Sget_simple_extent_npoints(s) == 1 && H5Aread(a, mtype, v) >= 0)
		ret = 0;
	if (s >= 0) H5Sclose(s);
	H5Aclose(a);
	return ret;
}

int h5u_read_attr_u64(hid_t obj, const char *name, uint64_t *value)
{
	return read_attr(obj, name, H5T_NATIVE_UINT64, value);
}

int h5u_read_attr_f64(hid_t obj, const char *name, double *value)
{
	return read_attr(obj, name, H5T_NATIVE_DOUBLE, value);
}

hid_t h5u_group(hid_t loc, const char *path)
{
	hid_t lcpl = H5Pcreate(H5P_LINK_CREATE), g = H5I_INVALID_HID;
	if (lcpl >= 0 && H5Pset_create_intermediate_group(lcpl, 1) >= 0)
		g = H5Gcreate2(loc, path, lcpl, H5P_DEFAULT, H5P_DEFAULT);
	if (lcpl >= 0)
		H5Pclose(lcpl);
	return g;
}

int h5u_fsync_path(const char *path)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return -1;
	int ret = fsync(fd);
	close(fd);
	return ret == 0 ? 0 : -1;
}

int h5u_fsync_dir_of(const char *path)
{
	char dir[PATH_MAX];
	const char *slash = strrchr(path, '/');
	if (!slash)
		snprintf(dir, sizeof dir, ".");
	else if (slash == path)
		snprintf(dir, sizeof dir, "/");
	else
		snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
	int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (fd < 0)
		return -1;
	int ret = fsync(fd);
	close(fd);
	return ret == 0 ? 0 : -1;
}

int h5u_fail(char *msg, size_t msglen, int code, const char *fmt, ...)
{
	if (msg && msglen) {
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(msg, msglen, fmt, ap);
		va_end(ap);
	}
	return code;
}

int h5u_write_string(hid_t loc, const char *name, const char *text, size_t len)
{
	int ret = -1;
	char *buf = malloc(len + 1);
	hid_t t = H5Tcopy(H5T_C_S1), sp = H5Screate(H5S_SCALAR), d = H5I_INVALID_HID;
	if (!buf || t < 0 || sp < 0 || H5Tset_size(t, len + 1) < 0)
		goto out;
	memcpy(buf, text, len);
	buf[len] = '\0';
	d = H5Dcreate2(loc, name, t, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
	if (d >= 0 && H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) >= 0)
		ret = 0;
out:
	free(buf);
	if (d >= 0) H5Dclose(d);
	if (sp >= 0) H5Sclose(sp);
	if (t >= 0) H5Tclose(t);
	return ret;
}

/* Lookups by coordinate (H5Dget_chunk_info_by_coord: one B-tree descent
 * each) over the chunk grid of the rows asked for. */
int h5u_chunks_sane(hid_t d, hsize_t eof, hsize_t row0, hsize_t rows)
{
	hid_t dcpl = H5Dget_create_plist(d), fs = H5Dget_space(d), ft = H5Dget_type(d);
	hsize_t dims[3] = {0, 0, 0}, chunk[3] = {1, 1, 1}, off[3] = {0, 0, 0};
	int ret = -1, rank = fs >= 0 ? H5Sget_simple_extent_ndims(fs) : -1;
	size_t esize = ft >= 0 ? H5Tget_size(ft) : 0;
	if (dcpl < 0 || rank < 1 || rank > 3 || esize == 0 || H5Sget_simple_extent_dims(fs, dims, NULL) < 0)
		goto done;
	if (H5Pget_layout(dcpl) != H5D_CHUNKED) {
		ret = 0;   /* contiguous or compact: no chunk index */
		goto done;
	}
	if (H5Pget_chunk(dcpl, rank, chunk) != rank)
		goto done;
	hsize_t raw = esize;
	for (int a = 0; a < rank; a++) {
		if (chunk[a] == 0 || raw > ((hsize_t)1 << 40) / chunk[a])
			goto done;   /* no chunk of ours is near 1 TiB: a damaged layout */
		raw *= chunk[a];
	}
	/* Without a compressing filter the stored chunk has exactly its raw size, plus Fletcher-32's 4 bytes
	 * (every chunk is stored whole, edge chunks too). A shorter record (ckpt_fuzz: an all-zero region
	 * passes Fletcher-32 at any length) makes HDF5 unfilter into a buffer of that size and then write the
	 * whole chunk into it when it prunes the chunk on a shrink (H5Dset_extent): a heap overflow. With
	 * deflate only the bound below holds (a short stream fails to inflate or its checksum). */
	int compress = 0, fletcher = 0, nf = H5Pget_nfilters(dcpl);
	if (nf < 0)
		goto done;
	for (int k = 0; k < nf; k++) {
		unsigned flags = 0, cd[8];
		size_t ncd = sizeof cd / sizeof cd[0];
		H5Z_filter_t id = H5Pget_filter2(dcpl, (unsigned)k, &flags, &ncd, cd, 0, NULL, NULL);
		if (id == H5Z_FILTER_FLETCHER32)
			fletcher = 1;
		else if (id != H5Z_FILTER_SHUFFLE)
			compress = 1;   /* deflate, or anything we do not write: the bound only */
	}
	const hsize_t exact = raw + (fletcher ? 4 : 0);
	const hsize_t bound = raw + raw / 1000 + 64;
	/* rows [row0, end) of axis 0, from the chunk that holds row0 */
	const hsize_t end = rows == H5U_ALL_ROWS || rows > dims[0] || row0 > dims[0] - rows ? dims[0] : row0 + rows;
	off[0] = row0 - row0 % chunk[0];
	for (;;) {
		unsigned mask = 0;
		haddr_t addr = HADDR_UNDEF;
		hsize_t size = 0;
		int empty = 0;
		for (int a = 0; a < rank; a++)
			empty |= off[a] >= (a ? dims[a] : end);
		if (empty)
			break;   /* no rows asked for, or an extent of 0: nothing stored */
		if (H5Dget_chunk_info_by_coord(d, off, &mask, &addr, &size) < 0)
			goto done;
		if (addr != HADDR_UNDEF && (size > bound || addr > eof || size > eof - addr || (!compress && size != exact) ||
		                            mask != 0))
			goto done;   /* (we never skip a filter: a set mask bit is damage) */
		int a = rank - 1;
		for (; a >= 0; a--) {
			off[a] += chunk[a];
			if (off[a] < (a ? dims[a] : end))
				break;
			off[a] = 0;
		}
		if (a < 0)
			break;
	}
	ret = 0;
done:
	if (dcpl >= 0)
		H5Pclose(dcpl);
	if (fs >= 0)
		H5Sclose(fs);
	if (ft >= 0)
		H5Tclose(ft);
	return ret;
}

int h5u_superblock_version(const char *path)
{
	static const unsigned char sig[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
	unsigned char buf[9];
	int ret = -1;
	FILE *f = fopen(path, "rb");
	if (!f)
		return -1;
	/* HDF5 looks for its signature at 0, 512, 1024, 2048, ... (a user block before it) */
	for (long off = 0; off >= 0 && off < (1L << 30); off = off ? 2 * off : 512) {
		if (fseek(f, off, SEEK_SET) != 0 || fread(buf, 1, sizeof buf, f) != sizeof buf)
			break;
		if (!memcmp(buf, sig, sizeof sig)) {
			ret = buf[8];
			break;
		}
	}
	fclose(f);
	return ret;
}
