/*
 * fail_note.h - a run's write failures, kept to be printed once at the end
 * as one line (the DLCA and event commands): the first failure's message,
 * then what else failed ("; also failed: cluster.h5, the final checkpoint").
 * Before, each failed checkpoint, cluster.h5 and sidecar printed a line of
 * its own (up to six for a full disk).
 */
#ifndef PDLA_CLI_FAIL_NOTE_H
#define PDLA_CLI_FAIL_NOTE_H

typedef struct cli_fail {
    char why[1200]; /* the first failure's message ("": none) */
    char also[96];  /* what failed after it */
} cli_fail;

/* Note a failure of `what` (NULL: nothing to name after the first): the
 * first one's message is fmt with msg; later ones add what to the list. */
void cli_fail_note(cli_fail *f, const char *what, const char *fmt, const char *msg);

#endif
