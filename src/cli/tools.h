/*
 * tools.h - `pdla info`, `pdla render`, `pdla analyze`: subcommands that read
 * a cluster file written by pdla_output_write. Each takes argv with the
 * subcommand's name in argv[0], prints, and returns the exit status:
 * 0 done; 1 runtime failure (a read or write failed midway);
 * 2 bad usage or input (unknown option, missing, foreign or malformed file,
 * an output that exists without --force). Errors are one line on stderr,
 * "pdla COMMAND: ...".
 */
#ifndef PDLA_CLI_TOOLS_H
#define PDLA_CLI_TOOLS_H
#include <stdio.h>

enum { TOOL_OK = 0, TOOL_RUNTIME = 1, TOOL_USAGE = 2 };

int tool_info(int argc, char **argv);
int tool_render(int argc, char **argv);
int tool_analyze(int argc, char **argv);
int tool_export(int argc, char **argv);
int tool_check(int argc, char **argv);
/* 0 when stdout took every byte written to it (flushed, no error), else 1
 * with "pdla TOOL: cannot write to stdout" on stderr: a report that did
 * not reach a full disk or a closed pipe must not exit as passed
 * (h5read.c). */
int tools_stdout_done(const char *tool);
/* s as a JSON string (quoted, escaped; bytes that are not UTF-8 as
 * U+FFFD), for every tool's --json (info.c). */
void tool_json_str(FILE *o, const char *s);
/* v in JSON with `digits` significant digits, null when it is not finite
 * (JSON has no NaN or inf). */
void tool_json_num(FILE *o, double v, int digits);
/* `pdla analyze` of an ensemble file (ens_analyze.c). */
int ens_analyze_is_ensemble(const char *path);
int ens_analyze_main(const char *path, int json);

#endif
