/*
 * event_cmd.h - the event model's command line (event_cmd.c) and its
 * `pdla info` reader (event_info.c), reached from main.c's dispatch.
 */
#ifndef PDLA_CLI_EVENT_CMD_H
#define PDLA_CLI_EVENT_CMD_H

/* 1 when argv asks for the event model (--model event, or a --scene file
 * with `model = event`). */
int event_cmd_wanted(int argc, char **argv);
int event_cmd_main(int argc, char **argv);
/* argv as `pdla info` gets it (argv[0] = "info"): 1 when its FILE was
 * written by the event model. */
int event_info_wanted(int argc, char **argv);
int event_info_main(int argc, char **argv);
/* 1, with one line printed, when that event FILE is no cluster file (a
 * checkpoint): the readers' bad input (exit 2). */
int event_checkpoint_refused(const char *tool, int argc, char **argv);
/* `pdla render` for event files (argv[0] = "render"). */
int event_render_main(int argc, char **argv);
/* `pdla analyze` for event files (argv[0] = "analyze", event_analyze.c). */
int event_analyze_main(int argc, char **argv);

#endif
