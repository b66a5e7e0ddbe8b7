/*
 * rundir.h - making run directories, shared by the model commands (DLA,
 * DLCA, event) and `pdla ensemble`, so that every --out is made alike.
 */
#ifndef PDLA_CLI_RUNDIR_H
#define PDLA_CLI_RUNDIR_H
#include <stddef.h>

/* mkdir -p: make every missing directory of path. 0 or an errno. */
int cli_mkdir_p(const char *path);

/* The parents of dir (everything before its last '/'), as cli_mkdir_p.
 * 0 or an errno. */
int cli_mkdir_parents(const char *dir);

/* Is path, which the loader of model own_model (its root attribute `model`:
 * "event", "dlca-checkpoint") refused, another model's file: a root
 * attribute model other than own_model, or a DLA checkpoint whose root
 * reads (it has no such attribute)? 1 with what it is in what; 2 for a
 * directory or a device under the name (what says which); else 0 (a
 * damaged file of own_model). Such a file is another run's, or the user's,
 * to keep, not one to set aside as damaged. */
int cli_foreign_checkpoint(const char *path, const char *own_model, char *what, size_t whatlen);

/* Is path's last name one of the temporary names the model commands
 * write and sweep away under a run directory's lock (a killed
 * run's leftovers: .checkpoint.h5.tmp.PID, cluster.h5.tmp, .cluster.h5.new,
 * ...; not a longer name such as cluster.h5.tmpcopy)? 1 or 0. A --resume
 * that names one is refused before the sweep, which removed the file
 * named. */
int cli_is_temp_name(const char *path);

/* The sweep: the files of dir under those temporary names removed (hold
 * its lock, so no live writer owns them). */
void cli_remove_temp(const char *dir);

/* A --resume of a file (not a directory) under one of those names: the
 * sweep would remove it (before or after it is read). 1 with the line
 * printed (the caller exits 2), else 0. Every model's command calls it. */
int cli_refuse_temp_resume(const char *path);

/* Before a resume's sweep of dir (hold its lock): 1 with one line printed
 * (the caller exits 2, dir untouched) when the sweep would break a path the
 * resume depends on, else 0. Refused: a symbolic link in dir that leads, as
 * the kernel resolves it, to a file of dir under a temporary name
 * (checkpoint.h5 -> .checkpoint.h5.tmp.1234, or through a chain) or through
 * one as a directory step (checkpoint.h5 -> .checkpoint.h5.new/x), past
 * the kernel's 40 links too; a chain that does not end within 1000 links or
 * whose path outgrows the check's buffer (not proven safe); not a loop
 * that meets no such name (junk -> junk: the kernel fails it before and
 * after the sweep alike); dir itself named through such a name
 * (--resume D/.checkpoint.h5.new, a link to "."). Why: the sweep unlinks
 * those names, so the link dangled after it (the event command fell back
 * to checkpoint.prev.h5; DLA and DLCA loaded through the link, then lost
 * the file) or every later write through dir failed. Every model's command
 * calls it. */
int cli_refuse_temp_links(const char *dir);

/* The same for a sweep of the names swept() takes (`pdla ensemble
 * --resume`: clusters.journal.tmp.*, ...), the line starting "who: ". */
int cli_refuse_links_through(const char *dir, int (*swept)(const char *name), const char *who);

/* A new run's run directory (--out, --force into an existing folder; a
 * DLCA resume into --out elsewhere), after it is made and locked, before
 * the sweep: 1 with one line printed (the caller exits 2, nothing written
 * or removed) when dir is named through a name of its own that the run
 * removes, a temporary name or the older run's checkpoint or summary
 * (--out X/.checkpoint.h5.new or X/checkpoint.h5 with that a link to "."
 * or to X): the sweep or the older run's removal took the link, and the
 * run's writes after it failed. Else 0. */
int cli_refuse_temp_out(const char *dir);

/* The same for the names swept() takes (`pdla ensemble --out`), temp()
 * saying which are temporary ones, the line starting "who: ". */
int cli_refuse_out_through(const char *dir, int (*swept)(const char *name), int (*temp)(const char *name),
                           const char *who);

#endif
