/*
 * http_query.c: query parameters (http.h): whole numbers in a range, and
 * the refusal of a parameter a route does not know or one given twice.
 */
#include "http.h"

#include <stdio.h>
#include <string.h>

/* A whole number in [lo, hi] from query argument `name`; *out keeps its
 * value when the argument is absent.  0, or -1 with *e (422). */
int lrd_query_long(struct MHD_Connection *c, const char *name, long lo, long hi,
                   long *out, lrd_err *e)
{
    const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, name);
    uint64_t n = 0;
    if (v == NULL)
        return 0;
    if (lrd_parse_u64(v, 0, &n) != 0 || n < (uint64_t)lo || n > (uint64_t)hi)
        return lrd_fail(e, 422, "invalid_value", name,
                        "%s must be a whole number from %ld to %ld, got "
                        "\"%.40s\"",
                        name, lo, hi, v);
    *out = (long)n;
    return 0;
}

/* The first query parameter a route does not know, or one that came
 * twice (?status=done&status=failed would list done jobs only, as if the
 * second were not there). */
typedef struct query_check {
    const char *const *known;
    size_t n_known;
    unsigned seen; /* a bit per known parameter */
    int twice;     /* the bad one came twice, rather than being unknown */
    int bare;      /* the bad one came without a value (?wait) */
    char bad[64];
} query_check;

static enum MHD_Result check_arg(void *cls, enum MHD_ValueKind kind,
                                 const char *key, const char *value)
{
    (void)kind;
    query_check *q = cls;
    if (q->bad[0] != '\0')
        return MHD_YES;
    for (size_t i = 0; i < q->n_known; i++)
        if (key != NULL && strcmp(key, q->known[i]) == 0) {
            q->twice = (q->seen >> i) & 1u;
            q->seen |= 1u << i;
            /* (libmicrohttpd gives a bare ?wait no value: it was read as
             * absent, and a long poll answered at once.) */
            q->bare = !q->twice && value == NULL;
            if (q->twice || q->bare)
                snprintf(q->bad, sizeof q->bad, "%s", key);
            return MHD_YES;
        }
    snprintf(q->bad, sizeof q->bad, "%s",
             key != NULL && key[0] ? key : "(empty)");
    return MHD_YES;
}

/* Refuses (422) a query parameter that is not one of `known` (`list`
 * names them for the message), one given twice, or one without a value
 * (?wait, not ?wait=10), rather than ignoring
 * it: a misspelt filter would list everything, a misspelt ?wait would
 * answer at once.  0, or -1 with *e filled. */
int lrd_check_query(struct MHD_Connection *c, const char *const *known,
                    size_t n_known, const char *list, lrd_err *e)
{
    query_check q = {known, n_known, 0, 0, 0, ""};
    MHD_get_connection_values(c, MHD_GET_ARGUMENT_KIND, check_arg, &q);
    if (q.bare)
        return lrd_fail(e, 422, "invalid_value", q.bad,
                        "the query parameter \"%s\" has no value; give one "
                        "(%s=...)",
                        q.bad, q.bad);
    if (q.twice)
        return lrd_fail(e, 422, "invalid_value", q.bad,
                        "the query parameter \"%s\" is given twice; give it "
                        "once",
                        q.bad);
    if (q.bad[0] != '\0')
        return lrd_fail(e, 422, "invalid_value", NULL,
                        "unknown query parameter \"%s\" (expected %s)", q.bad,
                        list);
    return 0;
}
