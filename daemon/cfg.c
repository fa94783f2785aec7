/* Daemon configuration table and its readers (flags, `key = value` files). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cfg.h"
#include "scene.h"

#ifndef GRANULARD_MPIRUN
#define GRANULARD_MPIRUN "mpirun"
#endif

typedef enum { T_STR, T_INT, T_REAL } ktype_t;
/* How a number is shown in --help and the man page (the value itself is always plain). */
typedef enum { U_NONE = 0, U_BYTES, U_SECONDS } kunit_t;

typedef struct {
	const char *name;
	ktype_t type;
	size_t off;
	double min, max;
	const char *def;         /* NULL: computed in cfg_init */
	const char *help;        /* what the key does; no default, no range (printed from the fields) */
	const char *const *choices;  /* for T_STR enumerations */
	const char *arg;         /* the value's name in --help (default from type and unit) */
	const char *def_text;    /* the default in words, where the literal says too little ("" = search...) */
	kunit_t unit;
	int (*check)(const char *value, char *err, size_t errlen);   /* T_STR: further rules, err "reason" */
} key_t_;

static const char *const placeholders[] = {"{mpirun}", "{ranks}", "{engine}", "{scene}", "{dir}", NULL};

/* The scheduler substitutes whole words only (daemon/scheduler.c,
 * build_argv()): a placeholder inside a word, an unknown one or a stray
 * brace would reach the launcher as literal text and every job would fail
 * at launch; refuse the template instead. */
static int check_launch(const char *tpl, char *err, size_t errlen)
{
	char known[128] = "";
	for (int i = 0; placeholders[i]; i++)
		snprintf(known + strlen(known), sizeof(known) - strlen(known), "%s%s", i ? " " : "", placeholders[i]);
	if (!tpl[strspn(tpl, " ")]) {
		snprintf(err, errlen, "empty template (placeholders: %s)", known);
		return CFG_EINVAL;
	}
	for (const char *p = tpl; *p;) {
		p += strspn(p, " ");
		size_t len = strcspn(p, " ");
		if (!len)
			break;
		if (memchr(p, '{', len) || memchr(p, '}', len)) {
			int whole = 0;
			for (int i = 0; placeholders[i] && !whole; i++)
				whole = strlen(placeholders[i]) == len && !strncmp(p, placeholders[i], len);
			if (!whole) {
				const char *o = memchr(p, '{', len), *c = o ? memchr(o, '}', len - (size_t)(o - p)) : NULL;
				if (o && c && (c - o != (ptrdiff_t)len - 1 || o != p))
					snprintf(err, errlen, "'%.*s': a placeholder must be a word of its own (placeholders: %s)",
					         (int)len, p, known);
				else if (o && c)
					snprintf(err, errlen, "unknown placeholder %.*s (placeholders: %s)", (int)len, p, known);
				else
					snprintf(err, errlen, "'%.*s': unbalanced brace (placeholders: %s)", (int)len, p, known);
				return CFG_EINVAL;
			}
		}
		p += len;
	}
	return CFG_OK;
}

static const char *const read_auth_choices[] = {"auto", "open", "token", NULL};
static const char *const log_choices[] = {"error", "warning", "info", "debug", NULL};
static const char *const launcher_choices[] = {"mpirun", "slurm", NULL};
static const char *const slurm_mpi_choices[] = {"pmix", "pmi2", "none", NULL};

/* Slurm names (partition, account): written into a batch script, so no
 * characters a shell or sbatch would read otherwise. */
static int check_slurm_name(const char *v, char *err, size_t errlen)
{
	if (strlen(v) > 64 || strspn(v, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-") != strlen(v)) {
		snprintf(err, errlen, "'%s': at most 64 characters from A-Z a-z 0-9 _ . -", v);
		return CFG_EINVAL;
	}
	return CFG_OK;
}

#define K(n, t, mn, mx, d, h, ...) {.name = #n, .type = t, .off = offsetof(cfg_t, n), .min = mn, .max = mx, \
	.def = d, .help = h, __VA_ARGS__}
static const key_t_ keys[] = {
	K(listen, T_STR, 0, 0, "127.0.0.1:8080", "address to serve on (port 0: any free port)", .arg = "HOST:PORT"),
	K(state_dir, T_STR, 0, 0, NULL, "state directory: database, job directories, token, granulard.addr, granulard.lock",
	  .arg = "DIR", .def_text = "$STATE_DIRECTORY, else ./var"),
	K(config, T_STR, 0, 0, "", "config file of `key = value` lines (these keys)", .arg = "FILE",
	  .def_text = "none"),
	K(slots, T_INT, 1, 4096, NULL, "MPI ranks that may run at once", .def_text = "the number of online CPUs"),
	K(engine, T_STR, 0, 0, "", "granular-engine program", .arg = "PROGRAM",
	  .def_text = "next to granulard, else the install dir, else PATH"),
	K(mpirun, T_STR, 0, 0, GRANULARD_MPIRUN, "MPI launcher program", .arg = "PROGRAM"),
	K(launch, T_STR, 0, 0, "{mpirun} --stdin none -np {ranks} {engine} run {scene} --out {dir}",
	  "launch command template; placeholders {mpirun} {ranks} {engine} {scene} {dir}, each a word of its own",
	  .arg = "TEMPLATE", .check = check_launch),
	K(launcher, T_STR, 0, 0, "mpirun",
	  "how jobs run: mpirun on this host (the launch template), or slurm: each attempt submitted with sbatch "
	  "(docs/daemon.md, \"Running on a cluster\")", .choices = launcher_choices),
	K(slurm_partition, T_STR, 0, 0, "", "launcher = slurm: the partition jobs are submitted to", .arg = "NAME",
	  .def_text = "none (Slurm picks)", .check = check_slurm_name),
	K(slurm_account, T_STR, 0, 0, "", "launcher = slurm: the account jobs are charged to", .arg = "NAME",
	  .def_text = "none (Slurm picks)", .check = check_slurm_name),
	K(slurm_time_limit, T_INT, 0, 1e8, "0",
	  "launcher = slurm: time limit of one attempt (sbatch --time; 0: the partition's limit); a job killed at "
	  "its limit is retried from its checkpoint", .unit = U_SECONDS),
	K(slurm_mpi, T_STR, 0, 0, "pmix", "launcher = slurm: the MPI plugin the engine runs under (srun --mpi)",
	  .choices = slurm_mpi_choices),
	K(slurm_poll, T_REAL, 0.1, 3600, "1", "launcher = slurm: time between looks at a job's Slurm state",
	  .unit = U_SECONDS),
	K(sbatch, T_STR, 0, 0, "sbatch", "launcher = slurm: sbatch program", .arg = "PROGRAM"),
	K(srun, T_STR, 0, 0, "srun", "launcher = slurm: srun program (run by the batch script on the cluster)",
	  .arg = "PROGRAM"),
	K(squeue, T_STR, 0, 0, "squeue", "launcher = slurm: squeue program", .arg = "PROGRAM"),
	K(scontrol, T_STR, 0, 0, "scontrol", "launcher = slurm: scontrol program", .arg = "PROGRAM"),
	K(scancel, T_STR, 0, 0, "scancel", "launcher = slurm: scancel program", .arg = "PROGRAM"),
	K(sinfo, T_STR, 0, 0, "sinfo", "launcher = slurm: sinfo program", .arg = "PROGRAM"),
	K(token, T_STR, 0, 0, "", "bearer token for mutating requests (as a flag it shows in ps: prefer the file)",
	  .arg = "TOKEN", .def_text = "read from STATE_DIR/token, generated on first start"),
	K(read_auth, T_STR, 0, 0, "auto",
	  "read-only requests: open, token, or auto (open to local clients: loopback peer and Host, no proxy headers)",
	  .choices = read_auth_choices),
	K(allowed_hosts, T_STR, 0, 0, "", "extra Host names this server answers to (as clients send them), comma-separated",
	  .arg = "HOSTS", .def_text = "none"),
	K(max_body, T_INT, 1024, 1 << 30, "4194304", "largest request body", .unit = U_BYTES),
	K(max_json_depth, T_INT, 2, 1000, "32", "deepest JSON nesting accepted"),
	K(max_connections, T_INT, 16, 1000000, "4096",
	  "concurrent connections; when full, the one waiting longest for a request head is closed for a new one"),
	K(per_ip_connections, T_INT, 0, 100000, "64",
	  "concurrent connections per client address, IPv6 per /64 (0: no limit); beyond, as for max_connections"),
	K(header_timeout, T_INT, 1, 3600, "10",
	  "time a connection has to send a complete request head, after connecting and between requests", .unit = U_SECONDS),
	K(request_timeout, T_INT, 1, 3600, "30",
	  "time for a request body to arrive, and of silence before a connection is closed while answering", .unit = U_SECONDS),
	K(http_workers, T_INT, 1, 1024, "32", "threads that run request handlers (database, files)"),
	/* The scene parser's own limit is the most that can ever run: a larger value would promise more. */
	K(max_particles, T_INT, 2, SCENE_COUNT_MAX, "100000000", "largest particles.count of a job"),
	K(max_ranks, T_INT, 0, 4096, "0", "most ranks one job may ask for (0: slots)"),
	K(max_wall_seconds, T_INT, 0, 1e9, "0", "wall-clock limit of one attempt (0: none)", .unit = U_SECONDS),
	K(max_queued, T_INT, 1, 1e9, "100000", "most jobs waiting in the queue"),
	K(max_progress_records, T_INT, 16, 1e8, "10000", "stored progress records per job before downsampling"),
	K(progress_rate, T_REAL, 0.01, 1e6, "100",
	  "progress records per second stored per job; beyond, the newest waits for the next slot and older ones are thinned",
	  .arg = "RATE"),
	K(progress_burst, T_INT, 1, 1e8, "1000", "progress records a job may send at once before progress_rate applies"),
	K(progress_flush, T_REAL, 0.01, 60, "0.25", "time between progress commits of one job (one transaction each)",
	  .unit = U_SECONDS),
	K(max_attempts, T_INT, 1, 1000, "3", "launches per job, counting retries"),
	K(cancel_grace, T_REAL, 0, 3600, "10", "time from SIGTERM to SIGKILL when cancelling", .unit = U_SECONDS),
	K(shutdown_grace, T_REAL, 0, 3600, "30", "time running jobs get to checkpoint when the daemon stops",
	  .unit = U_SECONDS),
	K(disk_reserve, T_INT, 0, 1 << 30, "8388608",
	  "ballast in STATE_DIR/reserve, freed when the disk fills so jobs can still be ended (0: none)", .unit = U_BYTES),
	K(log_level, T_STR, 0, 0, "info", "the least severe messages logged", .choices = log_choices),
	K(memory_budget, T_INT, 0, 1e15, "0",
	  "memory running jobs may use together, by their estimates (docs/daemon.md, \"Admission\"; 0: 90% of the "
	  "physical memory or of the service's cgroup limit, whichever is smaller)", .unit = U_BYTES),
	K(max_replicas, T_INT, 1, 1000000, "1000", "largest run.replicas of a job"),
	K(max_job_output, T_INT, 1048576, 1e15, "17179869184",
	  "what a job's directory may hold; a job may ask for less (max_output_bytes)", .unit = U_BYTES),
};
#define NKEYS (sizeof(keys) / sizeof(keys[0]))

static void number_text(const key_t_ *k, double v, char *buf, size_t n);
static void flag_name(const key_t_ *k, char *buf, size_t n);

static const key_t_ *find(const char *name)
{
	for (size_t i = 0; i < NKEYS; i++) {
		const char *a = keys[i].name, *b = name;
		while (*a && (*a == *b || (*a == '_' && *b == '-'))) {
			a++;
			b++;
		}
		if (!*a && !*b)
			return &keys[i];
	}
	return NULL;
}

static int set(cfg_t *c, const key_t_ *k, const char *v, const char *where, char *err, size_t errlen)
{
	char *end, name[64];
	void *p = (char *)c + k->off;
	/* Errors name the key as it was given: --max-body as a flag, max_body in a file. */
	if (!strcmp(where, "--"))
		flag_name(k, name, sizeof(name));
	else
		snprintf(name, sizeof(name), "%s", k->name);
	if (k->type == T_STR) {
		if (k->choices) {
			int ok = 0;
			for (int i = 0; k->choices[i]; i++)
				ok |= !strcmp(v, k->choices[i]);
			if (!ok) {
				snprintf(err, errlen, "%s%s: '%s' is not one of the allowed values (see --help)", where, name, v);
				return CFG_EINVAL;
			}
		}
		char why[384];
		if (k->check && k->check(v, why, sizeof(why))) {
			snprintf(err, errlen, "%s%s: %s", where, k->name, why);
			return CFG_EINVAL;
		}
		char *s = strdup(v);
		if (!s) {
			snprintf(err, errlen, "out of memory");
			return CFG_EINVAL;
		}
		free(*(char **)p);
		*(char **)p = s;
		return CFG_OK;
	}
	errno = 0;
	double x = strtod(v, &end);
	if (!*v || *end || errno || !isfinite(x) || (k->type == T_INT && x != floor(x))) {
		snprintf(err, errlen, "%s%s: '%s' is not %s", where, name, v, k->type == T_INT ? "an integer" : "a number");
		return CFG_EINVAL;
	}
	if (x < k->min || x > k->max) {
		char lo[48], hi[48];
		number_text(k, k->min, lo, sizeof(lo));
		number_text(k, k->max, hi, sizeof(hi));
		snprintf(err, errlen, "%s%s: %s is out of range %s..%s", where, name, v, lo, hi);
		return CFG_EINVAL;
	}
	if (k->type == T_INT)
		*(long *)p = (long)x;
	else
		*(double *)p = x;
	return CFG_OK;
}

int cfg_init(cfg_t *c)
{
	char err[256], buf[32];
	memset(c, 0, sizeof(*c));
	for (size_t i = 0; i < NKEYS; i++)
		if (keys[i].def && set(c, &keys[i], keys[i].def, "", err, sizeof(err)))
			return CFG_EINVAL;
	const char *sd = getenv("STATE_DIRECTORY");  /* systemd StateDirectory= */
	c->state_dir = strdup(sd && *sd ? sd : "./var");
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	snprintf(buf, sizeof(buf), "%ld", n > 0 ? n : 1);
	set(c, find("slots"), buf, "", err, sizeof(err));
	return c->state_dir ? CFG_OK : CFG_EINVAL;
}

void cfg_deinit(cfg_t *c)
{
	for (size_t i = 0; i < NKEYS; i++)
		if (keys[i].type == T_STR) {
			free(*(char **)((char *)c + keys[i].off));
			*(char **)((char *)c + keys[i].off) = NULL;
		}
}

int cfg_set(cfg_t *c, const char *key, const char *value, char *err, size_t errlen)
{
	const key_t_ *k = find(key);
	if (!k) {
		snprintf(err, errlen, "%s: unknown configuration key", key);
		return CFG_EINVAL;
	}
	return set(c, k, value, "", err, errlen);
}

int cfg_load_file(cfg_t *c, const char *path, char *err, size_t errlen)
{
	FILE *f = fopen(path, "r");
	char line[4096], where[512];
	int ln = 0, ret = CFG_OK;
	if (!f) {
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		return CFG_EIO;
	}
	while (ret == CFG_OK && fgets(line, sizeof(line), f)) {
		char *s = line, *eq, *e;
		ln++;
		snprintf(where, sizeof(where), "%s:%d: ", path, ln);
		s[strcspn(s, "\r\n")] = '\0';
		while (*s == ' ' || *s == '\t')
			s++;
		if (!*s || *s == '#')
			continue;
		eq = strchr(s, '=');
		if (!eq) {
			snprintf(err, errlen, "%sexpected `key = value`", where);
			ret = CFG_EINVAL;
			break;
		}
		for (e = eq; e > s && (e[-1] == ' ' || e[-1] == '\t'); e--)
			;
		*e = '\0';
		char *v = eq + 1;
		while (*v == ' ' || *v == '\t')
			v++;
		for (e = v + strlen(v); e > v && (e[-1] == ' ' || e[-1] == '\t'); e--)
			;
		*e = '\0';
		const key_t_ *k = find(s);
		if (!k || !strcmp(k->name, "config")) {
			snprintf(err, errlen, "%s%s: unknown configuration key", where, s);
			ret = CFG_EINVAL;
		} else {
			ret = set(c, k, v, where, err, errlen);
		}
	}
	fclose(f);
	return ret;
}

int cfg_from_args(cfg_t *c, int argc, char **argv, char *err, size_t errlen)
{
	/* The file first, so flags override it wherever they appear. */
	for (int i = 1; i < argc; i++)
		if (!strcmp(argv[i], "--config") && i + 1 < argc) {
			int r = cfg_load_file(c, argv[i + 1], err, errlen);
			if (r)
				return r;
		}
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = NULL;
		char name[64];
		if (!strcmp(a, "--help") || !strcmp(a, "-h"))
			return CFG_EHELP;
		if (strncmp(a, "--", 2)) {
			snprintf(err, errlen, "%s: unexpected argument (flags are --key value)", a);
			return CFG_EINVAL;
		}
		a += 2;
		const char *eq = strchr(a, '=');
		size_t n = eq ? (size_t)(eq - a) : strlen(a);
		if (n >= sizeof(name))
			n = sizeof(name) - 1;
		memcpy(name, a, n);
		name[n] = '\0';
		const key_t_ *k = find(name);
		if (!k) {
			snprintf(err, errlen, "--%s: unknown option (see --help)", name);
			return CFG_EINVAL;
		}
		if (eq)
			v = eq + 1;
		else if (i + 1 < argc)
			v = argv[++i];
		else {
			snprintf(err, errlen, "--%s: needs a value", name);
			return CFG_EINVAL;
		}
		int r = set(c, k, v, "--", err, errlen);
		if (r)
			return r;
	}
	return CFG_OK;
}

/* ---- the table as text, roff and Markdown ----------------------------------- */

/* A number as digits (never 1e+09), with the binary multiple for byte counts: "4194304 (4 MiB)". */
static void number_text(const key_t_ *k, double v, char *buf, size_t n)
{
	static const char *const bin[] = {"KiB", "MiB", "GiB", "TiB"};
	int len = snprintf(buf, n, "%.15g", v);
	if (k->type == T_INT || v == floor(v))
		len = snprintf(buf, n, "%.0f", v);
	if (k->unit != U_BYTES || v < 1024 || len < 0 || (size_t)len >= n)
		return;
	int u = -1;
	double m = v;
	while (u < 3 && m >= 1024 && fmod(m, 1024) == 0) {
		m /= 1024;
		u++;
	}
	if (u >= 1)   /* MiB and up: "1024 (1 KiB)" tells nothing new */
		snprintf(buf + len, n - (size_t)len, " (%.0f %s)", m, bin[u]);
}

static const char *arg_name(const key_t_ *k, char *buf, size_t n)
{
	if (k->arg)
		return k->arg;
	if (k->choices) {
		size_t o = 0;
		buf[0] = '\0';
		for (int i = 0; k->choices[i] && o < n; i++)
			o += (size_t)snprintf(buf + o, n - o, "%s%s", i ? "|" : "", k->choices[i]);
		return buf;
	}
	return k->unit == U_BYTES ? "BYTES" : k->unit == U_SECONDS ? "SECONDS" : k->type == T_INT ? "N" : "VALUE";
}

/* The range ("1024..1073741824 (1 GiB)"; "" for strings) and the default, each once. */
static void range_text(const key_t_ *k, char *buf, size_t n)
{
	char lo[48], hi[48];
	buf[0] = '\0';
	if (k->type == T_STR)
		return;
	number_text(k, k->min, lo, sizeof(lo));
	number_text(k, k->max, hi, sizeof(hi));
	snprintf(buf, n, "%s..%s", lo, hi);
}

static void default_text(const key_t_ *k, char *buf, size_t n)
{
	if (k->def_text)
		snprintf(buf, n, "%s", k->def_text);
	else if (!k->def || !*k->def)
		snprintf(buf, n, "none");
	else if (k->type == T_STR)
		snprintf(buf, n, "%s", k->def);
	else
		number_text(k, strtod(k->def, NULL), buf, n);
}

/* The flag as typed: dashes for underscores. */
static void flag_name(const key_t_ *k, char *buf, size_t n)
{
	size_t i = 0;
	for (; k->name[i] && i + 1 < n; i++)
		buf[i] = k->name[i] == '_' ? '-' : k->name[i];
	buf[i] = '\0';
}

/* roff text: backslashes and dashes escaped, no line may start a request. */
static void roff_puts(FILE *f, const char *s)
{
	if (*s == '.' || *s == '\'')
		fputs("\\&", f);
	for (; *s; s++) {
		if (*s == '\\')
			fputs("\\e", f);
		else if (*s == '-')
			fputs("\\-", f);
		else
			fputc(*s, f);
	}
}

/* --help: the description column starts at HELP_COL and wraps at spaces before HELP_WIDTH. */
#define HELP_COL 28
#define HELP_WIDTH 100
static void wrap(FILE *f, const char *s)
{
	const size_t room = HELP_WIDTH - HELP_COL;
	while (strlen(s) > room) {
		size_t cut = room;
		while (cut > 0 && s[cut] != ' ')
			cut--;
		if (cut == 0)
			cut = strcspn(s, " ");   /* one long word: print it whole */
		fprintf(f, "%.*s\n%*s", (int)cut, s, HELP_COL, "");
		s += cut;
		while (*s == ' ')
			s++;
	}
	fprintf(f, "%s\n", s);
}

/* A Markdown table cell: '|' would end it. */
static void md_puts(FILE *f, const char *s)
{
	for (; *s; s++) {
		if (*s == '|')
			fputc('\\', f);
		fputc(*s, f);
	}
}

int cfg_print_keys(void *file, cfg_format_t fmt)
{
	FILE *f = file;
	char flag[64], argbuf[64], range[128], def[160], head[160], line[1024];
	if (fmt == CFG_FMT_MARKDOWN)
		fputs("| key | flag | meaning | range | default |\n|---|---|---|---|---|\n", f);
	for (size_t i = 0; i < NKEYS; i++) {
		const key_t_ *k = &keys[i];
		flag_name(k, flag, sizeof(flag));
		const char *arg = arg_name(k, argbuf, sizeof(argbuf));
		range_text(k, range, sizeof(range));
		default_text(k, def, sizeof(def));
		switch (fmt) {
		case CFG_FMT_TEXT:
			snprintf(head, sizeof(head), "--%s %s", flag, arg);
			snprintf(line, sizeof(line), "%s%s%s; default %s", k->help, *range ? "; " : "", range, def);
			fprintf(f, "  %-*s", HELP_COL - 2, head);
			if (strlen(head) > HELP_COL - 3)
				fprintf(f, "\n%*s", HELP_COL, "");
			wrap(f, line);
			break;
		case CFG_FMT_ROFF:
			fputs(".TP\n\\fB\\-\\-", f);
			roff_puts(f, flag);
			fputs("\\fR \\fI", f);
			roff_puts(f, arg);
			fprintf(f, "\\fR (\\fB%s\\fR)\n", k->name);
			roff_puts(f, k->help);
			fputs(".\n", f);
			if (*range) {
				fputs("Range ", f);
				roff_puts(f, range);
				fputs("; default ", f);
			} else {
				fputs("Default ", f);
			}
			roff_puts(f, def);
			fputs(".\n", f);
			break;
		case CFG_FMT_MARKDOWN:
			fprintf(f, "| `%s` | `--%s ", k->name, flag);
			md_puts(f, arg);
			fprintf(f, "` | %s | %s | %s |\n", k->help, range, def);
			break;
		default:
			return CFG_EINVAL;
		}
	}
	return CFG_OK;
}

int cfg_format_parse(const char *name)
{
	static const char *const names[] = {[CFG_FMT_TEXT] = "text", [CFG_FMT_ROFF] = "man",
	                                    [CFG_FMT_MARKDOWN] = "markdown"};
	for (int i = 0; i < (int)(sizeof(names) / sizeof(names[0])); i++)
		if (name && !strcmp(name, names[i]))
			return i;
	return CFG_EINVAL;
}
