/* SQLite connection set-up for the daemon: pragmas, migrations by PRAGMA user_version. */
#pragma once

#include <sqlite3.h>

/*
 * Contract
 * - db_open() opens (creating if needed) the database at path (":memory:"
 *   for tests), sets WAL, synchronous=FULL, foreign_keys=ON,
 *   busy_timeout=5000, and applies every migration newer than the file's
 *   user_version, each in one BEGIN IMMEDIATE transaction together with the
 *   new user_version (a failed migration leaves the file as it was).
 * - A database newer than this binary (user_version > DB_SCHEMA_VERSION) is
 *   refused: downgrades would silently misread it.
 * - Returns NULL on failure with the reason in err. The caller closes the
 *   handle with sqlite3_close_v2().
 */

#define DB_SCHEMA_VERSION 5
#define DB_APPLICATION_ID 0x47524e4c  /* "GRNL": lets file(1) and tools tell our database apart */

sqlite3 *db_open(const char *path, char *err, size_t errlen);
