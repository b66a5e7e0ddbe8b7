/*
 * dlca_cmd.h - the DLCA model's entry points in the CLI: `pdla --model dlca`
 * (dlca_cmd.c), `pdla info` of a DLCA cluster.h5 (dlca_info.c), and its
 * render and analyze (dlca_tools.c).
 */
#ifndef PDLA_CLI_DLCA_CMD_H
#define PDLA_CLI_DLCA_CMD_H

#include <stddef.h>
#include <stdint.h>

#include <hdf5.h>

/* 1 if argv asks for model dlca (--model dlca, or a scene saying so). */
int dlca_cmd_wanted(int argc, char **argv);
/* Run it; returns the exit status. */
int dlca_cmd_main(int argc, char **argv);
/* 1 if path is an HDF5 file whose root attribute model is "dlca". */
int dlca_info_is_dlca(const char *path);
/* Print what the file holds (text, or JSON); returns the exit status. */
int dlca_info_main(const char *path, int json);
/* 1 if a non-option argument of `pdla render|analyze ...` is a DLCA file. */
int dlca_tool_file(int argc, char **argv);
/* `pdla render` and `pdla analyze` of a DLCA file (dlca_tools.c). */
int dlca_render_main(int argc, char **argv);
int dlca_analyze_main(int argc, char **argv);
/* `pdla check` of a DLCA cluster.h5 or checkpoint (check_dlca.c; check.c
 * hands over a file for which dlca_check_wanted holds); the exit status. */
int dlca_check_main(const char *path, int json);
/* /parameters dim (2..DLCA_MAX_DIM) and box (L, dim lengths of 1 to
 * DLCA_MAX_AXIS, fewer than 2^31 sites) of the open DLCA file f, through
 * the checked readers (dlca_tools.c; export reads it too). 0, or -1 with
 * one line in err. */
int dlca_file_box(hid_t f, const char *path, int *dim, uint64_t *L, char *err, size_t errlen);
#endif
