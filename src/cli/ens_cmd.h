/*
 * ens_cmd.h - `pdla ensemble` (ens_cmd.c).
 */
#ifndef PDLA_CLI_ENS_CMD_H
#define PDLA_CLI_ENS_CMD_H
/* argv[0] is "ensemble"; returns the exit status. */
int ens_cmd_main(int argc, char **argv);
#endif
