/*
 * check_event.h - `pdla check` of an event-model file (check_event.c), the
 * dispatch check.c makes before its DLA checks.
 */
#ifndef PDLA_CLI_CHECK_EVENT_H
#define PDLA_CLI_CHECK_EVENT_H

/* The paragraph of `pdla check --help` on event files. */
extern const char check_event_help[];

/* -1 when path is not an event-model file (root attribute model =
 * "event": a cluster.h5 or checkpoint.h5 of `pdla --model event`); else
 * the check's exit status after its report (TOOL_OK pass, TOOL_RUNTIME a
 * failed check, a damaged file or a checkpoint the loader refuses). */
int check_event(const char *path, int json);

#endif
