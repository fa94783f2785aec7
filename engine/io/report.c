/* JSON-lines serialisation of run records: fixed key order, exact doubles, no allocation. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "report.h"
#include "observe/tables.h"

typedef struct {
	char *buf;
	size_t len, pos;
	int overflow;
} out_t;

static void put(out_t *o, const char *fmt, ...)
{
	va_list ap;
	if (o->overflow)
		return;
	va_start(ap, fmt);
	int k = vsnprintf(o->buf + o->pos, o->len - o->pos, fmt, ap);
	va_end(ap);
	if (k < 0 || (size_t)k >= o->len - o->pos)
		o->overflow = 1;
	else
		o->pos += (size_t)k;
}

/* JSON has no NaN or infinity: those become null. */
static void num(out_t *o, const char *key, double v)
{
	if (isfinite(v))
		put(o, ",\"%s\":%.17g", key, v);
	else
		put(o, ",\"%s\":null", key);
}

/* A mean and, in ensemble records, its standard error as KEY_se. */
static void num_se(out_t *o, const run_record_t *r, const char *key, double v, double se)
{
	num(o, key, v);
	if (r->replicas > 1) {
		char k[64];
		snprintf(k, sizeof k, "%s_se", key);
		num(o, k, se);
	}
}

/* "key":[v0,...] with dim entries (null where not finite, or all null when !have) */
static void vec(out_t *o, const char *key, int dim, const double *v, int have)
{
	put(o, ",\"%s\":[", key);
	for (int a = 0; a < dim; a++) {
		double f = have ? v[a] : NAN;
		put(o, isfinite(f) ? "%s%.17g" : "%snull", a ? "," : "", f);
	}
	put(o, "]");
}

static void u64(out_t *o, const char *key, uint64_t v)
{
	put(o, ",\"%s\":%llu", key, (unsigned long long)v);
}

int report_format(const run_record_t *r, char *buf, size_t len)
{
	out_t o = {.buf = buf, .len = len};
	if (!buf || len == 0)
		return -1;
	put(&o, "{\"type\":\"%s\"", r->kind == RUN_SUMMARY ? "summary" : "progress");
	if (r->kind == RUN_SUMMARY)
		put(&o, ",\"status\":\"%s\"", run_status_name(r->status));
	if (r->replicas > 1)
		put(&o, ",\"replicas\":%u", r->replicas);
	num_se(&o, r, "time", r->time, r->se.time);
	u64(&o, "events", r->events);
	u64(&o, "collisions", r->collisions);
	num_se(&o, r, "collisions_per_particle", r->collisions_per_particle, r->se.collisions_per_particle);
	if (r->have & SCENE_OBS_ENERGY) {
		num_se(&o, r, "kinetic_energy", r->kinetic_energy, r->se.kinetic_energy);
		num_se(&o, r, "temperature", r->temperature, r->se.temperature);
		if (r->n_species > 1) {
			put(&o, ",\"temperature_species\":[");
			for (int k = 0; k < r->n_species; k++)
				put(&o, isfinite(r->temperature_species[k]) ? "%s%.17g" : "%snull", k ? "," : "",
				    r->temperature_species[k]);
			put(&o, "]");
			if (r->replicas > 1) {   /* ensembles: the standard error of each species' mean */
				put(&o, ",\"temperature_species_se\":[");
				for (int k = 0; k < r->n_species; k++)
					put(&o, isfinite(r->se.temperature_species[k]) ? "%s%.17g" : "%snull", k ? "," : "",
					    r->se.temperature_species[k]);
				put(&o, "]");
			}
		}
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_PRESSURE)) {
		num_se(&o, r, "pressure", r->have_interval ? r->pressure : NAN, r->have_interval ? r->se.pressure : NAN);
		num_se(&o, r, "compressibility", r->have_interval ? r->compressibility : NAN,
		       r->have_interval ? r->se.compressibility : NAN);
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_COLLISION_RATE))
		num_se(&o, r, "collision_rate", r->have_interval ? r->collision_rate : NAN,
		       r->have_interval ? r->se.collision_rate : NAN);
	if (r->have & SCENE_OBS_MOMENTUM) {
		put(&o, ",\"momentum\":[");
		for (int a = 0; a < r->dim; a++)
			put(&o, isfinite(r->momentum[a]) ? "%s%.17g" : "%snull", a ? "," : "", r->momentum[a]);
		put(&o, "]");
	}
	if (r->elastic_by_tc)
		u64(&o, "elastic_by_tc", r->elastic_by_tc);
	if (r->ranks > 0) {   /* a split ed run over several ranks */
		put(&o, ",\"ranks\":%d", r->ranks);
		if (r->rank_events && r->rank_particles) {
			for (int w = 0; w < 2; w++) {
				const uint64_t *x = w ? r->rank_particles : r->rank_events;
				put(&o, ",\"%s\":[", w ? "rank_particles" : "rank_events");
				for (int k = 0; k < r->ranks; k++)
					put(&o, "%s%llu", k ? "," : "", (unsigned long long)x[k]);
				put(&o, "]");
			}
		}
		u64(&o, "rollbacks", r->rollbacks);
		u64(&o, "syncs", r->syncs);
		num(&o, "sync_interval", r->sync_interval);
		u64(&o, "rebalances", r->rebalances);
	}
	if (r->have & SCENE_OBS_WALL_FORCE) {
		static const char *const axis[3] = { "x", "y", "z" };
		u64(&o, "wall_collisions", r->wall_collisions);
		if (r->kind == RUN_PROGRESS) {
			put(&o, ",\"wall_force\":[");
			int first = 1;
			for (int w = 0; w < 6; w++) {
				if (!(r->walls & (1u << w)))
					continue;
				put(&o, "%s{\"wall\":\"%s.%s\"", first ? "" : ",", axis[w >> 1], (w & 1) ? "upper" : "lower");
				num_se(&o, r, "pressure", r->have_interval ? r->wall_pressure[w] : NAN,
				       r->have_interval ? r->se.wall_pressure[w] : NAN);
				vec(&o, "force", r->dim, r->wall_force[w], r->have_interval);
				if (r->replicas > 1)
					vec(&o, "force_se", r->dim, r->se.wall_force[w], r->have_interval);
				put(&o, "}");
				first = 0;
			}
			put(&o, "]");
		}
	}
	if (r->have & SCENE_OBS_OBSTACLE_FORCE) {
		u64(&o, "obstacle_collisions", r->obstacle_collisions);
		if (r->kind == RUN_PROGRESS) {
			for (int e = 0; e < 1 + (r->replicas > 1); e++) {   /* ensembles: then obstacle_force_se */
				put(&o, ",\"%s\":[", e ? "obstacle_force_se" : "obstacle_force");
				for (int k = 0; k < r->n_obstacles; k++) {
					put(&o, "%s[", k ? "," : "");
					for (int a = 0; a < r->dim; a++) {
						double f = r->have_interval ? (e ? r->se.obstacle_force[k][a] : r->obstacle_force[k][a]) : NAN;
						put(&o, isfinite(f) ? "%s%.17g" : "%snull", a ? "," : "", f);
					}
					put(&o, "]");
				}
				put(&o, "]");
			}
		}
	}
	if (r->have & SCENE_OBS_OUTFLOW) {
		u64(&o, "particles_present", r->particles);
		put(&o, ",\"outflow\":{");
		static const char *const ax[3] = { "x", "y", "z" };
		int first = 1;
		for (int w = 0; w < 6; w++)
			if (r->walls & (1u << w) && r->wall_outflow[w]) {
				put(&o, "%s\"%s.%s\":%llu", first ? "" : ",", ax[w >> 1], (w & 1) ? "upper" : "lower",
				    (unsigned long long)r->wall_outflow[w]);
				first = 0;
			}
		put(&o, "}");
		if (r->source && r->replicas <= 1) {   /* particles.source: inserted and skipped (totals) */
			u64(&o, "inserted", r->source_inserted);
			u64(&o, "insert_skipped", r->source_skipped);
		}
		if (r->reservoirs) {   /* reservoir walls: entries made and rejected per wall (totals) */
			const uint64_t *cnt[2] = { r->wall_inflow, r->wall_rejected };
			static const char *const key[2] = { "inflow", "inflow_rejected" };
			for (int j = 0; j < 2; j++) {
				put(&o, ",\"%s\":{", key[j]);
				first = 1;
				for (int w = 0; w < 6; w++)
					if (r->reservoirs & (1u << w)) {
						put(&o, "%s\"%s.%s\":%llu", first ? "" : ",", ax[w >> 1], (w & 1) ? "upper" : "lower",
						    (unsigned long long)cnt[j][w]);
						first = 0;
					}
				put(&o, "}");
			}
		}
	}
	if (r->have & SCENE_OBS_COM_HEIGHT)
		num_se(&o, r, "center_of_mass_height", r->com_height, r->se.com_height);
	if (r->have & SCENE_OBS_POTENTIAL)
		num_se(&o, r, "potential_energy", r->potential_energy, r->se.potential_energy);
	if (r->have & SCENE_OBS_ROTATION) {
		num_se(&o, r, "rotational_energy", r->rotational_energy, r->se.rotational_energy);
		num_se(&o, r, "rotational_temperature", r->rotational_temperature, r->se.rotational_temperature);
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_CLUSTERS)) {
		const clusters_stats_t *c = &r->clusters;
		put(&o, ",\"clusters\":{\"count\":%llu,\"largest\":%llu", (unsigned long long)c->n_clusters,
		    (unsigned long long)c->largest);
		num_se(&o, r, "largest_fraction", c->largest_fraction, r->se.largest_fraction);
		num_se(&o, r, "mean_size", c->mean_size, r->se.mean_size);
		num(&o, "m2", c->m2);
		num(&o, "m2_reduced", c->m2_reduced);
		num_se(&o, r, "w", c->w, r->se.cluster_w);
		num_se(&o, r, "exponent", c->exponent, r->se.cluster_exponent);
		/* histogram: bin k counts clusters of size in [2^k, 2^(k+1)) */
		put(&o, ",\"histogram\":[");
		for (int k = 0; k < c->n_bins && k < CLUSTERS_MAX_BINS; k++)
			put(&o, "%s%llu", k ? "," : "", (unsigned long long)c->hist[k]);
		put(&o, "]}");
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_VDIST)) {
		num_se(&o, r, "a2", r->obs.a2, r->se.a2);
		num_se(&o, r, "a3", r->obs.a3, r->se.a3);
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_GOFR)) {
		num_se(&o, r, "g_contact_pairs", r->obs.g_pairs, r->se.g_pairs);
		num_se(&o, r, "g_contact_rate", r->have_interval ? r->obs.g_rate : NAN, r->have_interval ? r->se.g_rate : NAN);
		num_se(&o, r, "g_contact_pressure", r->have_interval ? r->obs.g_pressure : NAN,
		       r->have_interval ? r->se.g_pressure : NAN);
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_MSD)) {
		/* single runs: the standard error over particles; ensembles: over replicas */
		num(&o, "msd", r->obs.msd);
		num(&o, "msd_se", r->replicas > 1 ? r->se.msd : r->obs.msd_se);
		num_se(&o, r, "diffusion", r->obs.diffusion, r->se.diffusion);
		if (r->replicas <= 1 && !isnan(r->obs.msd_walled))   /* scenes with walls */
			num(&o, "msd_walled", r->obs.msd_walled);
		if (r->replicas <= 1 && !isnan(r->obs.msd_count))   /* varying particle sets */
			num(&o, "msd_count", r->obs.msd_count);
	}
	if (r->kind == RUN_PROGRESS && (r->have & SCENE_OBS_FLUX)) {
		/* single runs: the standard error over particles of the instantaneous sum; ensembles: over replicas */
		num(&o, "flux", r->obs.flux);
		num(&o, "flux_se", r->obs.flux_se);
	}
	if (r->warning) {
		/* Our own text: printable ASCII; quote the two JSON specials anyway. */
		put(&o, ",\"warning\":\"");
		for (const char *p = r->warning; *p; p++)
			put(&o, *p == '"' || *p == '\\' ? "\\%c" : "%c", (unsigned char)*p >= 0x20 ? *p : '?');
		put(&o, "\"");
	}
	num(&o, "wall_seconds", r->wall_seconds);
	if (r->kind == RUN_SUMMARY) {
		if (r->vmax_raised)
			u64(&o, "vmax_raised", r->vmax_raised);
		if (r->cell_collisions)
			u64(&o, "cell_collisions", r->cell_collisions);
		if (r->rejected_moves)
			u64(&o, "rejected_moves", r->rejected_moves);
		u64(&o, "particles", r->n);
		num(&o, "events_per_second", r->events_per_second);
		num(&o, "collisions_per_second", r->collisions_per_second);
		u64(&o, "memory_bytes", r->memory_bytes);
		put(&o, ",\"cells\":[%d,%d", r->cells[0], r->cells[1]);
		if (r->dim == 3)
			put(&o, ",%d", r->cells[2]);
		put(&o, "]");
	}
	put(&o, "}\n");
	return o.overflow ? -1 : (int)o.pos;
}

/* ---- curves (observables.jsonl) ------------------------------------------ */

static void num9(out_t *o, const char *sep, double v)
{
	if (isfinite(v))
		put(o, "%s%.9g", sep, v);
	else
		put(o, "%snull", sep);
}

static void array9(out_t *o, const char *key, const double *v, int n)
{
	put(o, "\"%s\":[", key);
	for (int k = 0; k < n; k++)
		num9(o, k ? "," : "", v[k]);
	put(o, "]");
}

/* A scalar of the sample with, in ensembles, its standard error. */
static void scalar9(out_t *o, int ens, const char *key, double v, double se)
{
	put(o, ",\"%s\":", key);
	num9(o, "", v);
	if (ens) {
		put(o, ",\"%s_se\":", key);
		num9(o, "", se);
	}
}

static int has_table(const obs_curves_t *c, const char *family, const char *table)
{
	for (int i = 0; i < c->ntables; i++)
		if (!strcmp(c->t[i].family, family) && !strcmp(c->t[i].table, table))
			return 1;
	return 0;
}

size_t report_curves_max(const obs_curves_t *c)
{
	return tables_json_max(c, 1);   /* either kind of run */
}

int report_curves(const run_record_t *r, uint64_t sample, char *buf, size_t len)
{
	out_t o = {.buf = buf, .len = len};
	const obs_curves_t *c = r->curves;
	const int ens = r->replicas > 1;
	if (!buf || len == 0 || !c)
		return -1;
	for (int i = 0; i < c->ntables; i++) {
		const obs_table_t *t = &c->t[i];
		if (i > 0 && !strcmp(t->family, c->t[i - 1].family))
			continue;   /* written with the family's first table */
		put(&o, "{\"name\":\"%s\",\"sample\":%llu", t->family, (unsigned long long)sample);
		if (ens)
			put(&o, ",\"replicas\":%u", r->replicas);
		put(&o, ",\"time\":%.17g,\"collisions_per_particle\":%.17g", r->time, r->collisions_per_particle);
		scalar9(&o, ens, "temperature", c->temperature, c->se_temperature);
		if (!strcmp(t->family, "velocity_distribution")) {
			scalar9(&o, ens, "a2", c->a2, c->se_a2);
			scalar9(&o, ens, "a3", c->a3, c->se_a3);
			if (has_table(c, "velocity_distribution", "spin")) {
				scalar9(&o, ens, "a2_spin", c->a2_spin, c->se_a2_spin);
				scalar9(&o, ens, "temperature_rot", c->temperature_rot, c->se_temperature_rot);
			}
		} else if (!strcmp(t->family, "pair_correlation")) {
			scalar9(&o, ens, "g_contact_pairs", c->g_pairs, c->se_g_pairs);
		} else if (!strcmp(t->family, "clusters")) {
			scalar9(&o, ens, "mean_size", c->mean_size, c->se_mean_size);
			scalar9(&o, ens, "m2_reduced", c->m2_reduced, c->se_m2_reduced);
			scalar9(&o, ens, "w", c->cluster_w, c->se_cluster_w);
			scalar9(&o, ens, "exponent", c->cluster_exponent, c->se_cluster_exponent);
		} else if (!strcmp(t->family, "impact_parameter")) {
			scalar9(&o, ens, "fit_a", c->impact_a, c->se_impact_a);
			scalar9(&o, ens, "fit_c", c->impact_c, c->se_impact_c);
		} else if (!strcmp(t->family, "density_spectrum")) {
			put(&o, ",\"samples\":%d", c->dspec_samples);
			scalar9(&o, 0, "alpha", c->dspec_alpha, NAN);
			scalar9(&o, 0, "alpha_se", c->dspec_alpha_se, NAN);
		} else if (!strcmp(t->family, "fields")) {
			put(&o, ",\"samples\":%d", c->fields_samples);
		}
		put(&o, ",\"tables\":[");
		for (int j = i; j < c->ntables && !strcmp(c->t[j].family, t->family); j++) {
			const obs_table_t *u = &c->t[j];
			put(&o, "%s{\"table\":\"%s\",\"x\":\"%s\",", j > i ? "," : "", u->table, u->x);
			if (u->shape[0] > 0)
				put(&o, "\"shape\":[%d,%d%s", u->shape[0], u->shape[1], u->shape[2] > 0 ? "," : "],");
			if (u->shape[0] > 0 && u->shape[2] > 0)
				put(&o, "%d],", u->shape[2]);
			array9(&o, "edges", u->edges, u->nb + 1);
			put(&o, ",");
			array9(&o, "centres", u->centres, u->nb);
			put(&o, ",\"columns\":{");
			for (int k = 0; k < u->ncols; k++) {
				put(&o, k ? "," : "");
				array9(&o, u->col[k], u->val[k], u->nb);
			}
			put(&o, "}");
			if (ens) {
				put(&o, ",\"se\":{");
				for (int k = 0; k < u->ncols; k++) {
					put(&o, k ? "," : "");
					array9(&o, u->col[k], u->se[k], u->nb);
				}
				put(&o, "}");
			}
			put(&o, "}");
		}
		put(&o, "]}\n");
	}
	return o.overflow ? -1 : (int)o.pos;
}
