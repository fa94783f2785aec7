/* Job budget: memory and output volume of a scene's run from the engines' plans, the run's buffers and the output schedules. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "advice.h"
#include "budget.h"
#include "ed/ed.h"
#include "mc/dsmc.h"
#include "md/md.h"
#include "observe/clusters.h"
#include "observe/tables.h"
#include "par/ensemble.h"
#include "par/ped.h"
#include "run.h"

/*
 * Output figures measured on the files granular-engine writes (Debian 12,
 * HDF5 1.10.8; docs/daemon.md, "Admission"): bytes of an H5MD file besides
 * its frames and observable rows (header, parameters, the scene, constant
 * diameters and masses, chunk allocation of the time series), per particle
 * group; of the XDMF description per frame; of a checkpoint file besides its
 * state fields; of a progress line (default observables; clusters add the
 * histogram; ensembles a standard error per mean) and of the summary line.
 */
#define FRAME_CHUNK 65536.0   /* particles per chunk of a frame: FRAME_CHUNK in io/h5md.c */
#define TRAJ_FIXED (80u << 10)
#define TRAJ_GROUP (48u << 10)
#define XDMF_FRAME 640u
#define CKPT_FIXED (32u << 10)
#define CKPT_REPLICA (12u << 10)   /* per replica of an ensemble checkpoint: its ~25 datasets' headers */
#define OBS_CHUNK 256.0       /* rows per chunk of an observable series: OBS_CHUNK in io/h5md.c */
#define LINE_BASE 360u
#define LINE_MOMENTUM 80u
#define LINE_CLUSTERS 400u
#define LINE_SE 320u
#define LINE_SUMMARY 640u
#define H5_CACHE (1u << 20)          /* HDF5's default chunk cache per open dataset (frames are cached when a chunk fits) */
#define H5_META_GROUP (96u << 10)    /* HDF5 metadata held per particles group, and per replica while an
                                        ensemble checkpoint is written (measured) */
#define RECORD_STRUCT 1024u    /* per replica on its rank: last record, flags (ensemble_run()) */

/* Records of a schedule over [0, span] (same clock): the first, one per
 * schedule time before the end, and the last at the end. */
static double schedule(double span, double every)
{
	if (!(every > 0) || !(span > 0))
		return 2;
	double k = span / every;
	return isfinite(k) ? 1 + fmax(1, ceil(k * (1 - 1e-12))) : INFINITY;
}

typedef struct {
	double f0;       /* initial collision frequency per particle */
	double lambda;   /* 1 - e^2 */
	int dim;
	int approx;      /* set when a conversion was made */
} clock_t_;

/* The span of the run (until) in the clock of w. */
static double span_in(clock_t_ *ck, const scene_t *s, const scene_when_t *w)
{
	if (w->kind == s->until.kind)
		return s->until.value;
	ck->approx = 1;
	if (!(ck->f0 > 0))
		return 0;   /* no collisions: a quiescent run emits its first and last records */
	if (w->kind == SCENE_CLOCK_CPP)   /* until a time: collisions reached then */
		return advice_haff_cpp(ck->dim, ck->f0, ck->lambda, s->until.value);
	/* until a collision count: the time it takes (Haff's law inverted) */
	double c = s->until.value, D2 = 2.0 * ck->dim;
	if (ck->lambda <= 0)
		return c / ck->f0;
	double x = ck->lambda * c / D2;
	return x > 700 ? INFINITY : D2 / (ck->lambda * ck->f0) * expm1(x);
}

/* Doubles per observables row: step, time and each series asked for. */
static double row_doubles(const scene_t *s, int ensemble)
{
	unsigned o = s->observables;
	double n = 3;   /* step, time, collision_count */
	if (o & SCENE_OBS_ENERGY) n += 2 + (ensemble ? 2 : 0);
	if (o & SCENE_OBS_PRESSURE) n += 2 + (ensemble ? 2 : 0);
	if (o & SCENE_OBS_COLLISION_RATE) n += 1 + ensemble;
	if (o & SCENE_OBS_MOMENTUM) n += s->dim;
	if (o & SCENE_OBS_CLUSTERS) n += 6 + CLUSTERS_MAX_BINS + (ensemble ? 2 : 0);
	if (s->tc > 0) n += 1;
	if (ensemble) n += 1;
	return n;
}

/* A count or size in bytes; an unbounded estimate (INFINITY) saturates. */
static uint64_t sat(double x) { return x >= 1.8e19 ? UINT64_MAX : x > 0 ? (uint64_t)x : 0; }

int budget_estimate(const scene_t *s, int ranks, budget_t *out, char *err, size_t errlen)
{
	char msg[512] = "";
	uint64_t engine, state, largest, cells;
	double chi;

	if (err && errlen)
		err[0] = '\0';
	memset(out, 0, sizeof(*out));
	if (ranks < 1 || s->method == SCENE_METHOD_AUTO) {
		if (err && errlen)
			snprintf(err, errlen, "%s", ranks < 1 ? "ranks: must be >= 1" : "method: \"auto\" must be resolved first");
		return BUDGET_EINVAL;
	}
	if (s->method == SCENE_METHOD_ED) {
		ed_plan_t p;
		if (ed_plan(s, &p, msg, sizeof msg) != ED_OK)
			goto refused;
		engine = p.memory, state = p.state, largest = p.largest, cells = p.cells;
		chi = dsmc_contact_value(s->dim, s->volume_fraction);
	} else if (s->method == SCENE_METHOD_MD) {
		/* the core's arrays (md_plan(): every contact slot held in the state), and run.c's set-up copies of
		 * positions and velocities (3 n doubles each, freed after md_create) */
		static const double unequal = 0.5;   /* any value: md_plan() asks only whether pairs differ */
		md_params_t mp = {.dim = s->dim, .n = s->count > INT32_MAX ? 0 : (int)s->count, .radius = s->radius,
		                  .mass = s->mass, .mu_r = s->md_rolling, .restitution_pair = scene_has_species(s) ? &unequal : NULL};
		for (int a = 0; a < s->dim; a++)
			mp.box[a] = s->box[a], mp.periodic[a] = !s->boundary[a].walled;
		md_plan_t p;
		if (md_plan(&mp, s->volume_fraction, &p) != MD_OK) {
			snprintf(msg, sizeof msg, "particles.count: %llu particles: more than md holds (2^31 - 1)",
			         (unsigned long long)s->count);
			goto refused;
		}
		engine = p.memory + 6 * (uint64_t)s->count * (uint64_t)s->dim * sizeof(double);
		state = p.state, largest = p.largest, cells = p.cells;
		chi = dsmc_contact_value(s->dim, s->volume_fraction);
	} else {
		dsmc_plan_t p;
		dsmc_params_t pr;
		if (dsmc_plan(s, &p, msg, sizeof msg) != DSMC_OK || dsmc_params(s, &pr, NULL, 0) != DSMC_OK)
			goto refused;
		engine = p.memory, state = p.state, largest = p.largest, cells = p.cells;
		chi = pr.chi;
	}

	/* rows of the frames and sampling buffers: the particle slots (reservoir walls: particles.capacity) */
	const double N = (double)scene_slots(s), D = s->dim, R = (double)s->replicas;
	const int ensemble = s->replicas > 1;
	const int clusters = (s->observables & SCENE_OBS_CLUSTERS) != 0;
	/* run.c: the sampling copy of positions (clusters, snapshots) and of
	 * velocities (snapshots); clusters.c: its arrays and up to 3 cells per
	 * particle. Single runs under the daemon write snapshots (--out). */
	double run_bufs = (ensemble ? (clusters ? N * D * 8 : 0) : 2 * N * D * 8) +
	                  (clusters ? N * (8 * D + 20) + (3 * N + 28) * 4 : 0);
	double replica = (double)engine + run_bufs;
	const int frames_on = ensemble && s->snapshots.kind != SCENE_CLOCK_NONE;

	/* Output. */
	clock_t_ ck = {
		.f0 = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, s->temperature, chi),
		.lambda = 1 - s->restitution * s->restitution,
		.dim = s->dim,
	};
	double records = schedule(span_in(&ck, s, &s->every), s->every.value);
	double groups = ensemble ? (frames_on ? R : 0) : 1;
	double per_group = 2;   /* first and last */
	if (s->snapshots.kind != SCENE_CLOCK_NONE)
		per_group = schedule(span_in(&ck, s, &s->snapshots), s->snapshots.value);
	if (ensemble && per_group > records)
		per_group = records;   /* ensemble frames are taken at output records */
	double frames = groups > 0 ? groups * per_group : 0;

	/* Replicas r run on rank r mod P: rank k holds R / P of them, one more
	 * when k < R mod P. A single run sits on rank 0; other ranks wait. */
	const uint64_t P = (uint64_t)ranks, Rn = s->replicas, extra = Rn % P;
	const double nl0 = ensemble ? (double)(Rn / P + (extra > 0)) : 1;
	const double n_more = ensemble && extra > 1 ? (double)(extra - 1) : 0;   /* ranks 1.. with R / P + 1 */
	const double n_less = (double)(P - 1) - n_more;
	const double nl_more = ensemble ? (double)(Rn / P + 1) : 0, nl_less = ensemble ? (double)(Rn / P) : 0;
	/* per rank: libraries and MPI; for ensembles the reduction vector
	 * (R records + flags + frame requests) and the frame buffers */
	double rank_fixed = BUDGET_RANK_BYTES;
	if (ensemble)
		rank_fixed += (R * ENSEMBLE_NV + 3 + (frames_on ? R : 0)) * 8 + (frames_on ? 2 * N * D * 8 : 0);
	const double per_replica = replica + (ensemble ? RECORD_STRUCT : 0);
	/* checkpoints on rank 0: a single run copies one field at a time; an
	 * ensemble gathers every replica's state (and holds them all when it
	 * resumes) */
	double rank0 = rank_fixed + nl0 * per_replica + (ensemble ? R * ((double)state + CKPT_REPLICA) : (double)largest);
	/* HDF5 on rank 0: per particles group its metadata and the chunk cache
	 * of the position and velocity series (a frame's chunk stays cached
	 * when it fits the cache: small N); per replica of an ensemble the
	 * metadata of its checkpoint group while the checkpoint is written */
	double chunk = fmin(N, FRAME_CHUNK) * D * 8;
	double cached = chunk <= H5_CACHE ? fmin(H5_CACHE, per_group * chunk) : 0;
	rank0 += (groups > 0 ? groups * (2 * cached + H5_META_GROUP) : 0) + (ensemble ? R * H5_META_GROUP : 0);
	double total = BUDGET_LAUNCHER_BYTES + rank0 + n_more * (rank_fixed + nl_more * per_replica) +
	               n_less * (rank_fixed + nl_less * per_replica);
	/* An ed single run on several ranks runs split (engine/par/edrun.h) when the parallel core supports the
	 * scene: every rank holds the core with room for all particles (ped_scene_bytes(), exact) and, while it
	 * loads, the broadcast state (positions and velocities); rank 0 also builds the serial run (the replica
	 * above, at the start and at each checkpoint) and gathers each frame and checkpoint (a record of 2 D + 2
	 * doubles per particle, then positions, velocities and TC times). */
	if (!ensemble && s->method == SCENE_METHOD_ED && ranks > 1 && ped_scene_check(s, 1, NULL, 0) == 0) {
		double core = (double)ped_scene_bytes(s, ranks) + 2 * N * D * 8;
		double gather = N * (2 * D + 2) * 8 + N * (2 * D + 1) * 8;
		rank0 += core + gather;
		total += (double)P * core + gather;
	}

	/* a frame's positions and velocities fill whole chunks of FRAME_CHUNK
	 * particles (io/h5md.c) once N exceeds one chunk */
	double nc = N <= FRAME_CHUNK ? N : ceil(N / FRAME_CHUNK) * FRAME_CHUNK;
	double frame_bytes = (2 * nc * D + D * D + 2 + (scene_has_reservoir(s) ? nc : 0)) * 8;   /* + id per slot */
	double trajectory = TRAJ_FIXED + groups * TRAJ_GROUP + frames * (frame_bytes + XDMF_FRAME) +
	                    ceil(records / OBS_CHUNK) * OBS_CHUNK * row_doubles(s, ensemble) * 8;
	double line = LINE_BASE + (s->observables & SCENE_OBS_MOMENTUM ? LINE_MOMENTUM : 0) + (clusters ? LINE_CLUSTERS : 0) + (ensemble ? LINE_SE : 0);
	double progress = records * line + LINE_SUMMARY;
	/* Curves: one sample per snapshot time (ensembles: at the output times a
	 * snapshot asks for; first and last without snapshots). Each writes at
	 * most tables_json_max() bytes to observables.jsonl; fields and
	 * density_spectrum also write a row of their values (doubles) and its
	 * step, time and sample count to trajectory.h5 (io/h5md.c). */
	obs_curves_t lay;
	tables_of(s, &lay);
	double curve_samples = lay.ntables ? per_group : 0, curve_json = 0, curve_h5 = 0;
	if (lay.ntables) {
		curve_json = (double)tables_json_max(&lay, ensemble);
		for (int i = 0; i < lay.ntables; i++)
			if (!strcmp(lay.t[i].family, "fields") || !strcmp(lay.t[i].family, "density_spectrum"))
				curve_h5 += 8.0 * lay.t[i].nb * lay.t[i].ncols + 24;
	}
	double curves = curve_samples * (curve_json + curve_h5);
	double checkpoint = CKPT_FIXED + (ensemble ? R * ((double)state + CKPT_REPLICA) : (double)state);

	out->memory = sat(total);
	out->memory_rank0 = sat(rank0);
	out->replica = sat(replica);
	out->engine = engine;
	out->state = state;
	out->cells = cells;
	out->records = sat(records + 1);
	out->frames = sat(frames);
	out->trajectory = sat(trajectory);
	out->checkpoint = sat(checkpoint);
	out->progress = sat(progress);
	out->curve_samples = sat(curve_samples);
	out->curves = sat(curves);
	out->output = sat(trajectory + progress + curves + 3 * checkpoint);
	out->bound = ck.approx ? BUDGET_ESTIMATE : BUDGET_EXACT;
	return BUDGET_OK;
refused:
	if (err && errlen)
		snprintf(err, errlen, "%s", msg);
	return BUDGET_EINVAL;
}

const char *budget_strerror(int code)
{
	switch (code) {
	case BUDGET_OK: return "ok";
	case BUDGET_EINVAL: return "scene cannot be estimated";
	default: return "unknown error";
	}
}
