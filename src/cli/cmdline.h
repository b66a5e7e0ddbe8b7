/*
 * cmdline.h - the command line as typed, for provenance (/Code
 * command_line, checkpoints, summaries): one copy for every model, shell-
 * quoted so that it can be pasted back into a POSIX shell.
 */
#ifndef PDLA_CLI_CMDLINE_H
#define PDLA_CLI_CMDLINE_H

/* prefix (NULL: none), then argv[0..argc-1], joined by spaces; a word that
 * holds anything but letters, digits and %+,-./:=@_^ (or is empty) is put in
 * single quotes, with each ' written as '\'' (the first word also when it
 * holds '=', which the shell took for an assignment). Call it before getopt
 * permutes argv. A malloc'd string, or NULL when out of memory. */
char *cli_command_line(const char *prefix, int argc, char **argv);

#endif
