/* libFuzzer harness: restoring a run from a checkpoint (ckpt_read, ckpt_read_ensemble, ckpt_read_split) and reopening a trajectory (h5md_open_append) on fuzzed HDF5 files. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <hdf5.h>

#include "checkpoint.h"
#include "h5md.h"
#include "scene.h"

/*
 * Input: one selector byte, then the bytes of an HDF5 file (a checkpoint or
 * a trajectory written by granular-engine: tests/fuzz/corpus/ckpt/ holds
 * real ones, made by the scenes below). The file is written to a directory
 * on tmpfs, as the engine finds it on --resume, and given to the code that
 * restores a run:
 * - selector bit 7 clear: the checkpoint reader for scene (selector & 0x7f)
 *   % NSCENES (ckpt_read(), ckpt_read_ensemble() for the ensemble scene,
 *   ckpt_read_split() for the split scene);
 *   a file written for another of the scenes takes the "different scene"
 *   path (its stored scene parsed, its state checked, CKPT_ESCENE);
 * - bit 7 set: h5md_open_append() (the resume path of trajectory.h5) for
 *   that scene, at 1 observable row and 1 frame per particles group.
 * Checked beyond the sanitizers: the answer is one of the documented codes
 * (never CKPT_EMISSING or CKPT_EIO: the file is there and readable) with a
 * one-line message; a restored run or ensemble comes back whole; and no
 * HDF5 object (file, group, dataset, type, space, attribute) is left open,
 * which LeakSanitizer cannot see (HDF5 keeps them until exit).
 */

static const char *const scenes[] = {
	"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":16,\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9,\"tc\":0.001},\"run\":{\"seed\":1,\"until\":{\"time\":3}},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\",\"pressure\",\"clusters\",\"momentum\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":1.1}}}}",
	"{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":12,\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9,\"tc\":0.0001},\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.3,\"frequency\":0.7,\"restitution\":0.9},\"upper\":{\"type\":\"thermal\",\"temperature\":1,\"accommodation\":0.5}}},\"gravity\":[0,0,-0.5],\"run\":{\"seed\":2,\"until\":{\"time\":3}},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\",\"wall_force\",\"center_of_mass_height\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":1.1}}}}",
	"{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":32,\"volume_fraction\":0.05,\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9},\"run\":{\"seed\":3,\"until\":{\"time\":3}},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\",\"temperature\",\"collision_rate\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":1.1}}},\"dsmc\":{\"correction\":\"cba\"}}",
	"{\"method\":\"hsmc\",\"dimensions\":3,\"particles\":{\"count\":32,\"volume_fraction\":0.2},\"collisions\":{\"restitution\":0.9},\"run\":{\"seed\":4,\"until\":{\"time\":2}},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\",\"pressure\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":0.7}}},\"hsmc\":{\"cell_size\":2}}",
	"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":9,\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\"}},\"run\":{\"seed\":5,\"until\":{\"time\":3},\"replicas\":2},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":1.1}}}}",
	"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":4,\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\"}},\"run\":{\"seed\":6,\"until\":{\"time\":2}},\"output\":{\"every\":{\"time\":1},\"observables\":[\"kinetic_energy\"],\"checkpoint\":{\"every\":{\"time\":1.1}}}}",
	/* split over ranks (ckpt_read_split(): written by mpirun -np 2, read whatever the rank count) */
	"{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"count\":40,\"volume_fraction\":0.05,\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9},\"run\":{\"seed\":7,\"until\":{\"time\":3}},\"output\":{\"every\":{\"time\":0.5},\"observables\":[\"kinetic_energy\",\"pressure\"],\"snapshots\":{\"every\":{\"time\":1}},\"checkpoint\":{\"every\":{\"time\":1.1}}}}",
};
#define NSCENES (sizeof scenes / sizeof scenes[0])
#define SPLIT_SCENE 6   /* its checkpoints are a split run's */

static scene_t parsed[NSCENES];
static char dir[128], file[160];
static int verbose;   /* CKPT_FUZZ_VERBOSE=1: one line per input (reader, scene, answer) */

/* HDF5 1.10.8 itself loses blocks of its allocators on some damaged object
 * headers (found here: a changed byte in an attribute's header, through
 * H5Aopen -> H5O_protect -> H5FL_blk_malloc). Not ours to fix, and the
 * library has no frame pointers, so the fast unwinder sees only "malloc <-
 * libhdf5": the suppression names the library (as tests/lsan.supp does).
 * Our allocations stay checked unless made inside an HDF5 callback
 * (gather_one() under H5Literate), and HDF5 objects we leave open are
 * checked by H5Fget_obj_count() below. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
	return "leak:libhdf5\n";
}

const char *__lsan_default_options(void);
const char *__lsan_default_options(void)
{
	return "print_suppressions=0";
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	char err[256];
	(void)argc;
	(void)argv;
	snprintf(dir, sizeof dir, "%s/ckpt_fuzz.%ld", access("/dev/shm", W_OK) ? "/tmp" : "/dev/shm", (long)getpid());
	snprintf(file, sizeof file, "%s/file.h5", dir);
	verbose = getenv("CKPT_FUZZ_VERBOSE") != NULL;
	if (mkdir(dir, 0755) && access(dir, W_OK))
		abort();
	for (size_t i = 0; i < NSCENES; i++)
		if (scene_parse(scenes[i], strlen(scenes[i]), &parsed[i], err, sizeof err) != SCENE_OK) {
			fprintf(stderr, "ckpt_fuzz: scene %zu: %s\n", i, err);
			abort();
		}
	return 0;
}

static void check_msg(const char *msg, size_t n)
{
	const char *nul = memchr(msg, '\0', n);
	if (!nul || nul == msg || memchr(msg, '\n', (size_t)(nul - msg)))
		__builtin_trap();
}

static void restore(size_t k)
{
	const scene_t *s = &parsed[k];
	const char *text = scenes[k];
	char msg[512];
	ckpt_output_t out = {0};
	int rc;
	memset(msg, 0x55, sizeof msg);
	if (s->replicas > 1) {
		unsigned char *blobs[8] = {0};
		size_t lens[8] = {0};
		ckpt_ensemble_t es;
		if (s->replicas > 8)
			abort();
		rc = ckpt_read_ensemble(file, s, text, strlen(text), blobs, lens, &es, &out, msg, sizeof msg);
		for (uint64_t r = 0; r < s->replicas; r++) {
			if ((rc == CKPT_OK) != (blobs[r] != NULL))
				__builtin_trap();   /* states on success, none on failure */
			free(blobs[r]);
		}
	} else if (k == SPLIT_SCENE) {
		ckpt_split_t ck;
		rc = ckpt_read_split(file, s, text, strlen(text), &ck, &out, msg, sizeof msg);
		if ((rc == CKPT_OK) != (ck.state.pos != NULL))
			__builtin_trap();   /* a state on success, none on failure */
		dsmcp_saved_free(&ck.state);
	} else {
		run_opts_t opts = {.snapshots = 1, .checkpoints = 1};
		run_t *run = NULL;
		rc = ckpt_read(file, s, text, strlen(text), &opts, &run, &out, msg, sizeof msg);
		if ((rc == CKPT_OK) != (run != NULL))
			__builtin_trap();
		run_destroy(run);
	}
	if (rc != CKPT_OK && rc != CKPT_ECORRUPT && rc != CKPT_ESCENE && rc != CKPT_ENOMEM)
		__builtin_trap();
	if (rc != CKPT_OK)
		check_msg(msg, sizeof msg);
	if (verbose)
		fprintf(stderr, "ckpt_fuzz: scene %zu: %s%s%s\n", k, ckpt_strerror(rc), rc ? ": " : "", rc ? msg : "");
}

static void reopen(size_t k)
{
	uint64_t frames[8] = {1, 1, 1, 1, 1, 1, 1, 1};
	char msg[512];
	int err = 0;
	memset(msg, 0x55, sizeof msg);
	if (h5md_groups(&parsed[k]) > 8)
		abort();
	h5md_t *h = h5md_open_append(file, &parsed[k], 1, frames, &err, msg, sizeof msg);
	if (!h) {
		if (err != H5MD_EIO && err != H5MD_EFORMAT && err != H5MD_ENOMEM)
			__builtin_trap();
		check_msg(msg, sizeof msg);
	}
	if (verbose)
		fprintf(stderr, "ckpt_fuzz: trajectory of scene %zu: %s\n", k, h ? "reopened" : msg);
	h5md_destroy(h);   /* may fail (the file was damaged): only what stays open counts */
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 1)
		return 0;
	FILE *f = fopen(file, "wb");
	if (!f)
		abort();
	if (fwrite(data + 1, 1, size - 1, f) != size - 1)
		abort();
	fclose(f);
	size_t k = (data[0] & 0x7f) % NSCENES;
	if (data[0] & 0x80)
		reopen(k);
	else
		restore(k);
	if (H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) != 0)
		__builtin_trap();   /* an HDF5 object left open */
	return 0;
}
