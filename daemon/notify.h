/* systemd readiness notification (sd_notify protocol: one datagram to $NOTIFY_SOCKET). */
#pragma once

/* Send state (e.g. "READY=1\nSTATUS=...") if $NOTIFY_SOCKET is set; 0 if sent or
 * not under systemd, -1 on error. No libsystemd: the protocol is the API. */
int notify_send(const char *state);
