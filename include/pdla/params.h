/*
 * params.h - the parameter table: one descriptor per run parameter, from
 * which everything that handles parameters is generated: the defaults
 * (pdla_params_default), the validation with its one-line errors
 * (pdla_params_validate), the CLI options, their --help lines and the scene
 * keys (src/cli/parse.c), the /parameters attributes of cluster.h5 and of a
 * checkpoint, the checkpoint's read-and-compare on resume, the JSON of
 * --stats-json and the parameter list of summary.txt.
 *
 * Adding a parameter to the DLA engine is one field in pdla_params (pdla.h),
 * one PDLA_PARAM_* bit and one row in src/core/params.c; tests/params walks the
 * table and checks every row end to end.
 *
 * The functions below take (table, count, struct) so that another model can
 * keep its own table of descriptors over its own parameter struct and reuse
 * the same machinery; `models` says which models a row applies to.
 */
#ifndef PDLA_PARAMS_H
#define PDLA_PARAMS_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Models a parameter applies to (pdla_param_desc.models). */
#define PDLA_MODEL_DLA (1u << 0)   /* off-lattice DLA / PDLA (the engine in pdla.h) */
#define PDLA_MODEL_DLCA (1u << 1)  /* lattice cluster-cluster aggregation (dlca.h) */
#define PDLA_MODEL_EVENT (1u << 2) /* event-driven sticky hard spheres (event.h) */

/* How a parameter is stored in its struct and written out. */
typedef enum pdla_param_type {
    PDLA_PT_INT,    /* int; HDF5 int32, JSON number */
    PDLA_PT_U64,    /* uint64_t; HDF5 uint64, JSON number */
    PDLA_PT_REAL,   /* double; HDF5 float64, JSON number */
    PDLA_PT_FLAG,   /* int 0 or 1; HDF5 int32, JSON number; a CLI flag without value */
    PDLA_PT_CHOICE, /* an enum stored as int, values 0..n-1; HDF5 and JSON: its word */
    PDLA_PT_STRING, /* char[hi_u + 1], length in [lo_u, hi_u]; HDF5: string ("(none)"
                       when empty), JSON: string */
    PDLA_PT_BOX     /* uint32_t[PDLA_PARAM_BOX_MAX] lengths, one per axis, of which the
                       int field at count_offset (the dimension) says how many are used;
                       each in [lo_u, hi_u]; one value (set_u, the default) fills every
                       entry; HDF5: uint64 array of the used ones; text "L1xL2x..." */
} pdla_param_type;

#define PDLA_PARAM_BOX_MAX 5

typedef struct pdla_param_desc {
    const char *name;    /* struct field, /parameters attribute and JSON key */
    const char *option;  /* CLI long option and scene key, without "--" */
    const char *label;   /* words naming it in messages, e.g. "kill ratio" */
    const char *unit;    /* unit of the value ("diameters", "units"), "" if none */
    const char *metavar; /* CLI placeholder ("N", "exact|kill"), NULL for a flag */
    const char *help;    /* its --help text */
    const char *group;   /* the --help heading it is listed under ("Walkers:") */
    const char *example; /* a valid value other than the default, as the CLI reads it
                            (a flag: "yes"); for tests and documentation */
    pdla_param_type type;
    size_t offset;       /* offsetof(the model's parameter struct, field) */
    uint32_t bit;        /* its bit in "given" masks (PDLA_PARAM_* for DLA) */
    uint32_t models;     /* PDLA_MODEL_* it applies to */
    int resumable;       /* 1: a resume may change it; 0: it must equal the checkpoint's */
    int show_default;    /* 1: --help shows "(default X)" */
    int absent_default;  /* 1: a /parameters group without its attribute (a file
                            written before the parameter existed) reads as the
                            default; 0: the file is damaged */
    int flag_value;      /* FLAG: the value the CLI flag sets (the default is the other) */
    /* INT, U64, FLAG, CHOICE: default and closed range [lo, hi]. */
    uint64_t def_u, lo_u, hi_u;
    /* REAL: default and range [lo, hi]; lo_open / hi_open exclude a bound. */
    double def_r, lo_r, hi_r;
    int lo_open;
    int hi_open;
    size_t count_offset; /* BOX: offsetof the int field giving how many lengths are used */
    const char *const *choices; /* CHOICE: the word of value 0, 1, ...; NULL-terminated */
    /* An extra rule run after the range check passed (power of two, a bound
     * that depends on another field), or NULL. Writes one line, returns non-zero
     * when the struct fails it. */
    int (*check)(const void *params, char *err, size_t errlen);
    const char *def_s; /* STRING: the default text */
    /* STRING whose value has more than one spelling (a list of numbers, a
     * path): 1 when a and b hold the same value, for pdla_param_equal and
     * so the resume rule; NULL: the texts must be equal. */
    int (*same)(const void *a, const void *b);
} pdla_param_desc;

/* The DLA engine's table (pdla_params); *n gets its length. */
PDLA_API const pdla_param_desc *pdla_param_table(size_t *n);

/* The row whose option (or, failing that, name) is `key`; '_' and '-' are
 * the same. NULL if none. */
PDLA_API const pdla_param_desc *pdla_param_find(const pdla_param_desc *t, size_t n,
                                                const char *key);

/* Every row's default into the struct s. */
PDLA_API void pdla_param_defaults(const pdla_param_desc *t, size_t n, void *s);

/* 0 if every row's value in s is valid, else PDLA_EINVAL, the first bad
 * row in *bad (when bad is not NULL) and a one-line reason in err. */
PDLA_API int pdla_param_validate(const pdla_param_desc *t, size_t n, const void *s,
                                 const pdla_param_desc **bad, char *err, size_t errlen);

/* Typed access to one row's field. INT, FLAG and CHOICE read as int; get_u
 * gives U64 as is and the int types as their (signed) value cast. */
PDLA_API uint64_t pdla_param_get_u(const pdla_param_desc *d, const void *s);
PDLA_API int64_t pdla_param_get_i(const pdla_param_desc *d, const void *s);
PDLA_API double pdla_param_get_real(const pdla_param_desc *d, const void *s);
PDLA_API void pdla_param_set_u(const pdla_param_desc *d, void *s, uint64_t v);
PDLA_API void pdla_param_set_real(const pdla_param_desc *d, void *s, double v);
/* 1 when a and b hold the same value of row d (REAL: bitwise equal). */
PDLA_API int pdla_param_equal(const pdla_param_desc *d, const void *a, const void *b);

/* The value as text, like snprintf: integers in decimal, reals with %g
 * (17 digits with exact = 1), a choice as its word ("invalid" when out of
 * range). */
PDLA_API int pdla_param_format(const pdla_param_desc *d, const void *s, int exact, char *buf,
                               size_t len);
/* Two values of row d that differ, as text for a message saying so: %g
 * unless that prints them alike (0.05 and 0.05000000000000001), then 17
 * digits; an empty string as "(none)". */
PDLA_API void pdla_param_format_two(const pdla_param_desc *d, const void *a, const void *b, char *abuf,
                                    char *bbuf, size_t len);
/* The value of `word` in a CHOICE row, or -1. */
PDLA_API int pdla_param_choice(const pdla_param_desc *d, const char *word);

/* Text as a user (CLI, scene, a text record) writes it into row d's field:
 * integers in decimal or as a whole number in exponent form ("1e5"), reals
 * finite decimal, a choice's word, a flag yes|no|true|false|1|0, a string as
 * is. The type only: the range is pdla_param_validate's. PDLA_OK, or
 * PDLA_EINVAL with "'TEXT' is not ..." in err (the caller names the row). */
PDLA_API int pdla_param_parse(const pdla_param_desc *d, void *s, const char *text, char *err,
                              size_t errlen);

/* A resume's rule, for any model: every row named in `given` (a mask of
 * bits) that is not resumable must hold in `asked` the value it has in
 * `have` (the checkpoint's). 0, or PDLA_EINVAL with "cannot resume with a
 * different physics parameter: LABEL is X in the checkpoint, Y asked". */
PDLA_API int pdla_param_check_asked(const pdla_param_desc *t, size_t n, uint32_t given,
                                    const void *have, const void *asked, char *err,
                                    size_t errlen);
/* Copy every resumable row named in `given` from src into dst. */
PDLA_API void pdla_param_apply_resumable(const pdla_param_desc *t, size_t n, uint32_t given,
                                         void *dst, const void *src);

#ifdef __cplusplus
}
#endif
#endif /* PDLA_PARAMS_H */
