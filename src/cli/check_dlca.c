/*
 * check_dlca.c - `pdla check FILE [--json]` of a DLCA cluster.h5 or
 * checkpoint (check.c hands such a file over here): the library's
 * dlca_check_file does the checks (pdla/dlca.h); this prints its report,
 * a line per check, as text or JSON. Exit 0 when the file passes; 1 when
 * it fails a check (one line on stderr), the checkpoint loader refuses it
 * or a read fails midway; 2 for a file pdla cannot have written (a
 * dataset missing or forged in shape or size, /parameters out of range).
 */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "dlca_cmd.h"
#include "pdla/dlca.h"
#include "tools.h"

/* The line of each check when it holds. */
static const char *holds(const dlca_check_report *r, int k, char *buf, size_t len)
{
    switch (k) {
    case DLCA_CK_BOX: return "every monomer inside the box";
    case DLCA_CK_SITE: return r->checkpoint ? "the sites are the state's" : "every /monomers/site the site of its position";
    case DLCA_CK_SHARED: return "no two monomers on one site";
    case DLCA_CK_NUMBERING: return "clusters numbered 0, 1, ... in monomer order";
    case DLCA_CK_PIECES: return "every cluster one face-connected piece (on the torus)";
    case DLCA_CK_TOUCH:
        return r->sticking >= 1 ? "no two clusters face-adjacent (sticking 1)"
                                : "not checked: with sticking < 1 a contact may stay unjoined";
    case DLCA_CK_SPANNING:
        snprintf(buf, len, "%" PRIu64 " clusters span the box (stop: %s)", r->spanning, r->stop);
        return buf;
    case DLCA_CK_SIZE: return r->checkpoint ? "the state's sizes as counted" : "/clusters/size as counted";
    case DLCA_CK_RG:
        snprintf(buf, len, "%" PRIu64 " recomputed bit for bit, %" PRIu64 " of spanning clusters bounded", r->rg_exact,
                 r->rg_bounded);
        return buf;
    case DLCA_CK_RESULTS: return "totals, mean and weight-average size, D_f as recomputed";
    case DLCA_CK_STOP: return "the stop follows the stops asked";
    case DLCA_CK_SERIES:
        snprintf(buf, len, "%" PRIu64 " rows in range and order, the last the final state", r->series_rows);
        return buf;
    default:
        snprintf(buf, len, "%" PRIu64 " checked as a resume does, their positions and their clusters", r->snapshots);
        return buf;
    }
}

static void print_text(FILE *o, const char *path, const dlca_check_report *r)
{
    fprintf(o, "file         %s\n", path);
    fprintf(o, "kind         DLCA %s\n", r->checkpoint ? "checkpoint (loaded and verified as --resume does)" : "cluster.h5");
    fprintf(o, "monomers     %" PRIu64 " in %dD, box %" PRIu64, r->monomers, r->dim, r->box[0]);
    for (int a = 1; a < r->dim; a++) fprintf(o, "x%" PRIu64, r->box[a]);
    fprintf(o, ", sticking %.17g; %" PRIu64 " clusters, largest %" PRIu64 "; stop %s\n", r->sticking, r->clusters,
            r->largest, r->stop[0] ? r->stop : "(none)");
    if (r->stopped) fprintf(o, "reading      STOPPED after %u failures: the checks after it did not run\n", DLCA_CHECK_MAX_FAILURES);
    const int broken = r->fail[DLCA_CK_NUMBERING] > 0;
    for (int k = 0; k < DLCA_CK_KINDS; k++) {
        char buf[160];
        fprintf(o, "%-12s ", dlca_check_kind_name(k));
        if (r->fail[k]) fprintf(o, "%" PRIu64 " FAILED; first: %s\n", r->fail[k], r->first[k]);
        else if (r->stopped) fputs("not checked to the end\n", o);
        else if (broken && k >= DLCA_CK_PIECES && k <= DLCA_CK_RG && k != DLCA_CK_TOUCH)
            fputs("not checked: the cluster numbers are not the writer's\n", o);
        else fprintf(o, "%s\n", holds(r, k, buf, sizeof buf));
    }
    fprintf(o, "result       %s\n", r->pass ? "pass" : "FAIL");
}

static void print_json(FILE *o, const char *path, const dlca_check_report *r)
{
    fputs("{\n  \"file\": ", o);
    tool_json_str(o, path);
    fprintf(o, ",\n  \"model\": \"dlca\",\n  \"checkpoint\": %s,\n  \"pass\": %s,\n  \"dim\": %d,\n  \"box\": [",
            r->checkpoint ? "true" : "false", r->pass ? "true" : "false", r->dim);
    for (int a = 0; a < r->dim; a++) fprintf(o, "%s%" PRIu64, a ? ", " : "", r->box[a]);
    fputs("],\n  \"sticking\": ", o);
    tool_json_num(o, r->sticking, 17);
    fprintf(o, ",\n  \"monomers\": %" PRIu64 ",\n  \"clusters\": %" PRIu64 ",\n  \"largest\": %" PRIu64 ",\n  \"stop\": ",
            r->monomers, r->clusters, r->largest);
    tool_json_str(o, r->stop);
    fprintf(o, ",\n  \"spanning_clusters\": %" PRIu64 ",\n  \"rg_exact\": %" PRIu64 ",\n  \"rg_bounded\": %" PRIu64
               ",\n  \"series_rows\": %" PRIu64 ",\n  \"snapshots\": %" PRIu64 ",\n  \"stopped\": %s,\n  \"failures\": {",
            r->spanning, r->rg_exact, r->rg_bounded, r->series_rows, r->snapshots, r->stopped ? "true" : "false");
    for (int k = 0; k < DLCA_CK_KINDS; k++) {
        fprintf(o, "%s\n    \"%s\": {\"count\": %" PRIu64 ", \"first\": ", k ? "," : "", dlca_check_kind_name(k),
                r->fail[k]);
        if (r->fail[k]) tool_json_str(o, r->first[k]);
        else fputs("null", o);
        fputc('}', o);
    }
    fputs("\n  }\n}\n", o);
}

int dlca_check_main(const char *path, int json)
{
    char err[1024];
    dlca_check_report r;
    const int rc = dlca_check_file(path, &r, err, sizeof err);
    if (rc) {
        fprintf(stderr, "pdla check: %s\n", err);
        return rc == PDLA_EINVAL ? TOOL_USAGE : TOOL_RUNTIME;
    }
    if (json) print_json(stdout, path, &r);
    else print_text(stdout, path, &r);
    if (tools_stdout_done("check")) return TOOL_RUNTIME;
    if (r.pass) return TOOL_OK;
    char kinds[512] = "";
    size_t k = 0;
    for (int i = 0; i < DLCA_CK_KINDS && k < sizeof kinds; i++)
        if (r.fail[i])
            k += (size_t)snprintf(kinds + k, sizeof kinds - k, "%s%s %" PRIu64, k ? ", " : "", dlca_check_kind_name(i),
                                  r.fail[i]);
    fprintf(stderr, "pdla check: %s fails the check (%s%s)\n", path, kinds, r.stopped ? "; reading stopped" : "");
    return TOOL_RUNTIME;
}
