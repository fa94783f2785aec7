/* SQLite connection set-up: pragmas and schema migrations (SQL lives in schema/NNN_name.sql). */
#include <stdio.h>
#include "db.h"
#include "daemon/schema_sql.h"   /* generated from schema/NNN_*.sql: db_migrations[] */

static int exec(sqlite3 *db, const char *sql, char *err, size_t errlen)
{
	char *msg = NULL;
	int rc = sqlite3_exec(db, sql, NULL, NULL, &msg);
	if (rc != SQLITE_OK)
		snprintf(err, errlen, "%s", msg ? msg : sqlite3_errstr(rc));
	sqlite3_free(msg);
	return rc;
}

static int user_version(sqlite3 *db, int *v)
{
	sqlite3_stmt *st = NULL;
	int rc = sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &st, NULL);
	if (rc == SQLITE_OK && (rc = sqlite3_step(st)) == SQLITE_ROW) {
		*v = sqlite3_column_int(st, 0);
		rc = SQLITE_OK;
	}
	sqlite3_finalize(st);
	return rc;
}

sqlite3 *db_open(const char *path, char *err, size_t errlen)
{
	sqlite3 *db = NULL;
	int v = 0;
	char sql[128];
	int rc = sqlite3_open_v2(path, &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, NULL);
	if (rc != SQLITE_OK) {
		snprintf(err, errlen, "%s: %s", path, db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
		goto fail;
	}
	sqlite3_busy_timeout(db, 5000);
	/* Debian builds WAL with synchronous FULL already; say it anyway: an
	 * acknowledged submission must survive a power cut. */
	if (exec(db, "PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL; PRAGMA foreign_keys=ON; "
	                 /* after each checkpoint, give the journal's space back beyond 4 MiB */
	                 "PRAGMA journal_size_limit=4194304;", err, errlen))
		goto fail;
	if (user_version(db, &v) != SQLITE_OK) {
		snprintf(err, errlen, "%s: %s", path, sqlite3_errmsg(db));
		goto fail;
	}
	if (v > DB_SCHEMA_VERSION) {
		snprintf(err, errlen, "%s: database schema version %d is newer than this granulard (%d)", path, v,
		         DB_SCHEMA_VERSION);
		goto fail;
	}
	for (; v < DB_SCHEMA_VERSION; v++) {
		char e2[256];
		if (exec(db, "BEGIN IMMEDIATE", err, errlen))
			goto fail;
		snprintf(sql, sizeof(sql), "PRAGMA user_version=%d; PRAGMA application_id=%d;", v + 1, DB_APPLICATION_ID);
		if (exec(db, db_migrations[v], e2, sizeof(e2)) || exec(db, sql, e2, sizeof(e2))) {
			snprintf(err, errlen, "%s: migration to schema %d failed: %s", path, v + 1, e2);
			exec(db, "ROLLBACK", e2, sizeof(e2));
			goto fail;
		}
		if (exec(db, "COMMIT", err, errlen))
			goto fail;
	}
	return db;
fail:
	sqlite3_close_v2(db);
	return NULL;
}
