/* granularctl's commands: the table, option parsing and the command implementations. */
#pragma once

/* Exit statuses of granularctl (documented in granularctl.1 and docs/client.md). */
enum {
	CTL_EXIT_OK = 0,        /* done; for submit --wait and watch: the job succeeded */
	CTL_EXIT_JOB = 1,       /* the job failed or was cancelled */
	CTL_EXIT_USAGE = 2,     /* bad command line or bad local input (scene file, --set) */
	CTL_EXIT_SERVER = 3,    /* server or network error (unreachable, 5xx, 429, bad answer) */
	CTL_EXIT_REFUSED = 4,   /* refused or not found: 401, 403, 404, 409 */
};

/* Run granularctl with main's arguments; returns the exit status. Writes to stdout/stderr only. */
int cmd_main(int argc, char **argv);
