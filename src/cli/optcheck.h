/*
 * optcheck.h - refuse abbreviated long options. getopt_long accepts any
 * unambiguous prefix ("--targ 100" for --target), which hides typos and would
 * change meaning when a new option shares the prefix; pdla wants exact names.
 */
#ifndef PDLA_CLI_OPTCHECK_H
#define PDLA_CLI_OPTCHECK_H

#include <getopt.h>
#include <stddef.h>

/* Walk argv as getopt_long would (values of options that take one are
 * skipped; "--" ends the options) and check that every "--name" or
 * "--name=value" names a long option exactly. shortopts is getopt's string
 * (':' after a letter that takes a value). 0, or -1 with "unknown option
 * '--x' (see --help)" in err. */
int optcheck_exact(int argc, char *const *argv, const struct option *longopts,
                   const char *shortopts, char *err, size_t errlen);

#endif
