/*
 * check_event.c - `pdla check FILE [--json]` for a cluster.h5 or
 * checkpoint.h5 of the event model: the library's ev_check_file
 * (pdla/event.h) checks it, this file words the report (text or JSON) and
 * the exit status: 0 the file passes, 1 it fails a check, cannot be read
 * as the engine writes it, or the checkpoint loader refuses it.
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "check_event.h"
#include "pdla/event.h"
#include "pdla/h5check.h"
#include "tools.h"

const char check_event_help[] =
    "An event-model file (pdla --model event: cluster.h5, or checkpoint.h5 loaded\n"
    "and verified as --resume does) is checked from its rows: arrival times in\n"
    "order within [0, time]; each stuck particle at contact with its parent, a\n"
    "seed or an earlier stuck particle; indices distinct; no two bodies (seeds,\n"
    "stuck, free) overlapping and every one inside the box; rows, /results and\n"
    "/species counts equal; the free kinetic energy summed again and the total\n"
    "conserved; the series in order, ending at /results. Lengths are compared to\n"
    "1e-10 of a contact distance plus the round-off of a position.\n";

static const char *ok_text(const ev_check_report *r, int k, char *buf, size_t len)
{
    switch (k) {
    case EV_CHECK_OVERLAP:
        if (r->pairs)
            snprintf(buf, len, "none (%" PRIu64 " pairs compared; deepest %.3g of a contact distance)", r->pairs,
                     r->worst_overlap);
        else snprintf(buf, len, "none (no two bodies near each other)");
        break;
    case EV_CHECK_CONTACT:
        snprintf(buf, len, "every stuck particle at contact with its parent (largest offset %.3g of it)",
                 r->worst_contact);
        break;
    case EV_CHECK_ENERGY:
        if (isnan(r->ke_balance)) snprintf(buf, len, "kinetic_energy_free as summed again (%.17g)", r->ke_free);
        else
            snprintf(buf, len, "kinetic_energy_free as summed again (%.17g); free + stuck = the series' first row "
                     "to %.3g", r->ke_free, r->ke_balance);
        break;
    case EV_CHECK_SERIES:
        snprintf(buf, len, "%" PRIu64 " rows in order%s", r->series_rows,
                 r->series_at_end ? ", the last one at /results (the run ended)"
                                  : " (the last one not compared: an interval may be open)");
        break;
    default: snprintf(buf, len, "ok");
    }
    return buf;
}

static void print_text(FILE *o, const char *path, const ev_check_report *r)
{
    fprintf(o, "file         %s\n", path);
    fprintf(o, "model        event, %dD, %s, %s\n", r->dim, r->periodic ? "periodic box" : "elastic walls",
            r->checkpoint ? "checkpoint (loaded: the loader's own checks passed)" : "cluster file");
    fprintf(o, "bodies       %" PRIu64 " seeds, %" PRIu64 " stuck and %" PRIu64 " free of %" PRIu64
               " particles; box side %.17g, time %.17g\n", r->seeds, r->stuck, r->free_rows, r->particles, r->box,
            r->time);
    fprintf(o, "tolerance    %.3g of a contact distance + round-off %.3g (at most 1e-2 of it)\n", EV_CHECK_TOL,
            r->round_off);
    char buf[400];
    for (int k = 0; k < EV_CHECK_NKINDS; k++) {
        const ev_check_item *it = &r->item[k];
        if (it->count)
            fprintf(o, "%-12s %" PRIu64 " FAILED; first: %s\n", ev_check_kind_name(k), it->count, it->first);
        else if (r->stopped) /* the checks left when it stopped found nothing because they did not run */
            fprintf(o, "%-12s no failure before checking stopped\n", ev_check_kind_name(k));
        else fprintf(o, "%-12s %s\n", ev_check_kind_name(k), ok_text(r, k, buf, sizeof buf));
    }
    if (r->stopped) fprintf(o, "stopped      after %u failures, the rest not checked\n", EV_CHECK_MAX_FAILURES);
    fprintf(o, "result       %s\n", r->pass ? "pass" : "FAIL");
}

static void json_item(FILE *o, const ev_check_item *it, const char *name, int last)
{
    fprintf(o, "    \"%s\": {\"failures\": %" PRIu64 ", \"first\": ", name, it->count);
    if (!it->count) fputs("null", o);
    else {
        fprintf(o, "{\"a\": %" PRId64 ", \"b\": %" PRId64 ", \"value\": ", it->a, it->b);
        tool_json_num(o, it->value, 17);
        fputs(", \"limit\": ", o);
        tool_json_num(o, it->limit, 17);
        fputs(", \"text\": ", o);
        tool_json_str(o, it->first);
        fputc('}', o);
    }
    fputs(last ? "}\n" : "},\n", o);
}

static void json_num(FILE *o, const char *name, double v)
{
    fprintf(o, "  \"%s\": ", name);
    tool_json_num(o, v, 17);
    fputs(",\n", o);
}

static void print_json(FILE *o, const char *path, const ev_check_report *r)
{
    fputs("{\n  \"file\": ", o);
    tool_json_str(o, path);
    fprintf(o, ",\n  \"model\": \"event\",\n  \"checkpoint\": %s,\n  \"pass\": %s,\n", r->checkpoint ? "true" : "false",
            r->pass ? "true" : "false");
    fprintf(o, "  \"dim\": %d,\n  \"periodic\": %s,\n", r->dim, r->periodic ? "true" : "false");
    fprintf(o, "  \"particles\": %" PRIu64 ",\n  \"seeds\": %" PRIu64 ",\n  \"stuck\": %" PRIu64
               ",\n  \"free\": %" PRIu64 ",\n", r->particles, r->seeds, r->stuck, r->free_rows);
    json_num(o, "box_side", r->box);
    json_num(o, "time", r->time);
    json_num(o, "tolerance", EV_CHECK_TOL);
    json_num(o, "round_off", r->round_off);
    json_num(o, "worst_overlap", r->worst_overlap);
    json_num(o, "worst_contact", r->worst_contact);
    json_num(o, "kinetic_energy_free", r->ke_free);
    json_num(o, "energy_balance", r->ke_balance);
    fprintf(o, "  \"pairs\": %" PRIu64 ",\n  \"series_rows\": %" PRIu64 ",\n  \"series_at_end\": %s,\n", r->pairs,
            r->series_rows, r->series_at_end ? "true" : "false");
    fprintf(o, "  \"stopped\": %s,\n", r->stopped ? "true" : "false");
    fprintf(o, "  \"failures\": %" PRIu64 ",\n  \"checks\": {\n", r->failures);
    for (int k = 0; k < EV_CHECK_NKINDS; k++)
        json_item(o, &r->item[k], ev_check_kind_name(k), k == EV_CHECK_NKINDS - 1);
    fputs("  }\n}\n", o);
}

/* The one stderr line of a failed check: the kinds that failed. */
static void print_fail_line(const char *path, const ev_check_report *r)
{
    char kinds[400] = "";
    size_t used = 0;
    for (int k = 0; k < EV_CHECK_NKINDS && used < sizeof kinds; k++)
        if (r->item[k].count)
            used += (size_t)snprintf(kinds + used, sizeof kinds - used, "%s%s %" PRIu64, used ? ", " : "",
                                     ev_check_kind_name(k), r->item[k].count);
    fprintf(stderr, "pdla check: %s fails the check (%s%s)\n", path, kinds, r->stopped ? "; checking stopped" : "");
}

int check_event(const char *path, int json)
{
    char model[64];
    if (pdla_h5_file_model(path, model, sizeof model) != 0 || strcmp(model, "event") != 0) return -1;
    ev_check_report r;
    char err[1400];
    const int rc = ev_check_file(path, &r, err, sizeof err);
    if (rc) {
        fprintf(stderr, "pdla check: %s\n", err);
        return rc == EV_CHECK_NOT_EVENT ? TOOL_USAGE : TOOL_RUNTIME;
    }
    if (json) print_json(stdout, path, &r);
    else print_text(stdout, path, &r);
    if (tools_stdout_done("check")) return TOOL_RUNTIME;
    if (r.pass) return TOOL_OK;
    print_fail_line(path, &r);
    return TOOL_RUNTIME;
}
