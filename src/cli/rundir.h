/*
 * rundir.h - making run directories, shared by the model commands (DLA,
 * DLCA, event) and `pdla ensemble`, so that every --out is made alike.
 */
#ifndef PDLA_CLI_RUNDIR_H
#define PDLA_CLI_RUNDIR_H

/* mkdir -p: make every missing directory of path. 0 or an errno. */
int cli_mkdir_p(const char *path);

/* The parents of dir (everything before its last '/'), as cli_mkdir_p.
 * 0 or an errno. */
int cli_mkdir_parents(const char *dir);

#endif
