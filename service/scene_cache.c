/*
 * scene_cache.c: loaded scenes (parsed and built into Embree), shared.
 *
 * Loading a scene is the expensive part of a small render, so scenes are
 * kept by the SHA-256 of their JSON text: a focal sweep that sends the same
 * scene a hundred times with different cameras builds it once, whether it
 * names a scene of the scenes directory or sends it inline.  Named scenes
 * also have a by-name index keyed on the file's identity (device, inode,
 * size, modification time), so that a hit does not even read the file, and
 * an edited file is noticed and reloaded.  A hit whose scene's own files
 * (meshes, textures, ...) have changed since it was loaded
 * (lr_scene_files_changed) is dropped and loaded again: the JSON's hash
 * alone kept an edited mesh's old geometry until a restart.
 *
 * Ownership: an entry's reference count counts its holders plus one while
 * it is in the cache.  Eviction (least recently used, beyond
 * lrd_cfg.scene_cache entries) only drops the cache's reference, so a
 * scene that a render is using is freed when that render releases it.
 */
#include "lensrayd.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Names remembered by the by-name index. */
#define MAX_NAMES 256

struct lrd_scene {
    unsigned char hash[32];
    lr_scene *scene;   /* owned */
    int refs;          /* guarded by cache.mu */
    int cached;        /* still reachable from cache.list */
    uint64_t last_use; /* cache.clock at the last hit */
    struct lrd_scene *next;
};

typedef struct name_entry {
    char name[72];
    dev_t dev;
    ino_t ino;
    off_t size;
    struct timespec mtime;
    unsigned char hash[32];
    uint64_t last_use;
    struct name_entry *next;
} name_entry;

static struct {
    pthread_mutex_t mu;
    lrd_scene *list; /* cached entries */
    long n;
    name_entry *names;
    long n_names;
    uint64_t clock;
    lrd_scene_stats stats;
} cache = {.mu = PTHREAD_MUTEX_INITIALIZER};

static void entry_free(lrd_scene *s)
{
    if (s == NULL)
        return;
    lr_scene_free(s->scene);
    free(s);
}

int lrd_scenes_init(void)
{
    return 0;
}

void lrd_scenes_shutdown(void)
{
    pthread_mutex_lock(&cache.mu);
    lrd_scene *s = cache.list;
    cache.list = NULL;
    cache.n = 0;
    name_entry *ne = cache.names;
    cache.names = NULL;
    pthread_mutex_unlock(&cache.mu);
    while (s != NULL) {
        lrd_scene *next = s->next;
        /* Every job has been freed before this runs, so the cache holds
         * the only reference. */
        entry_free(s);
        s = next;
    }
    while (ne != NULL) {
        name_entry *next = ne->next;
        free(ne);
        ne = next;
    }
}

lrd_scene *lrd_scene_ref(lrd_scene *s)
{
    pthread_mutex_lock(&cache.mu);
    s->refs++;
    pthread_mutex_unlock(&cache.mu);
    return s;
}

void lrd_scene_release(lrd_scene *s)
{
    if (s == NULL)
        return;
    pthread_mutex_lock(&cache.mu);
    int last = --s->refs == 0;
    pthread_mutex_unlock(&cache.mu);
    /* Freeing an Embree scene can take a while; never under the lock. */
    if (last)
        entry_free(s);
}

const lr_scene *lrd_scene_get(const lrd_scene *s)
{
    return s->scene;
}

void lrd_scenes_stats(lrd_scene_stats *out)
{
    pthread_mutex_lock(&cache.mu);
    *out = cache.stats;
    out->entries = cache.n;
    pthread_mutex_unlock(&cache.mu);
}

/* Called with cache.mu held: the cached entry with this hash, now
 * referenced by the caller, or NULL. */
static lrd_scene *find_locked(const unsigned char hash[32])
{
    for (lrd_scene *s = cache.list; s != NULL; s = s->next)
        if (memcmp(s->hash, hash, 32) == 0) {
            s->refs++;
            s->last_use = ++cache.clock;
            return s;
        }
    return NULL;
}

/* Called with cache.mu held: adds `s` (refs already counts the caller)
 * and returns the entries evicted to make room whose last reference was
 * the cache's, for the caller to free after unlocking. */
static lrd_scene *insert_locked(lrd_scene *s)
{
    s->refs++; /* the cache's own reference */
    s->cached = 1;
    s->last_use = ++cache.clock;
    s->next = cache.list;
    cache.list = s;
    cache.n++;
    lrd_scene *to_free = NULL;
    long cap = lrd_cfg.scene_cache > 0 ? lrd_cfg.scene_cache : 1;
    while (cache.n > cap) {
        lrd_scene **victim = NULL;
        for (lrd_scene **pp = &cache.list; *pp != NULL; pp = &(*pp)->next)
            if (victim == NULL || (*pp)->last_use < (*victim)->last_use)
                victim = pp;
        lrd_scene *v = *victim;
        *victim = v->next;
        v->next = NULL;
        v->cached = 0;
        cache.n--;
        cache.stats.evictions++;
        if (--v->refs == 0) {
            v->next = to_free;
            to_free = v;
        }
    }
    return to_free;
}

/* Called with cache.mu held: takes `s` out of the cache (if still in
 * it), dropping the cache's reference (never its last: the caller
 * holds one). */
static void uncache_locked(lrd_scene *s)
{
    if (!s->cached)
        return;
    for (lrd_scene **pp = &cache.list; *pp != NULL; pp = &(*pp)->next)
        if (*pp == s) {
            *pp = s->next;
            break;
        }
    s->next = NULL;
    s->cached = 0;
    cache.n--;
    s->refs--;
}

/* Takes `s` (the caller's reference) out of the cache and releases it:
 * its files changed since it was loaded.  NULL. */
static lrd_scene *drop(lrd_scene *s)
{
    pthread_mutex_lock(&cache.mu);
    uncache_locked(s);
    pthread_mutex_unlock(&cache.mu);
    lrd_scene_release(s);
    return NULL;
}

/* `hit` (found, the caller's reference) when its scene's files are as it
 * was loaded from, counted a hit; otherwise NULL, `hit` taken out of the
 * cache and the caller's reference released, for the caller to load the
 * scene again.  Counted only once checked: a hit taken back made the
 * hits counter go down between two scrapes of /metrics. */
static lrd_scene *fresh(lrd_scene *hit)
{
    if (hit != NULL && lr_scene_files_changed(hit->scene))
        return drop(hit);
    if (hit != NULL) {
        pthread_mutex_lock(&cache.mu);
        cache.stats.hits++;
        pthread_mutex_unlock(&cache.mu);
    }
    return hit;
}

static void free_chain(lrd_scene *s)
{
    while (s != NULL) {
        lrd_scene *next = s->next;
        entry_free(s);
        s = next;
    }
}

/* ---- the loaders ------------------------------------------------------------
 *
 * Scenes are loaded (and built into Embree) on LOADERS long-lived threads,
 * not on the request's connection thread: Embree keeps some state for
 * every thread that commits a scene, for the device's life, and a daemon
 * that starts a thread a connection grew by some 380 bytes for every
 * scene a new connection loaded (RSS +3.0 MiB over 8000, an independent
 * soak; flat on one keep-alive connection).  A request hands its text
 * over and waits; loads of different requests still overlap, LOADERS at a
 * time. */
#define LOADERS 2

typedef struct load_req {
    const char *text;
    size_t len;
    lr_scene *scene;
    lr_error err;
    lr_status st;
    int done;
    struct load_req *next;
} load_req;

static struct {
    pthread_mutex_t mu;
    pthread_cond_t work, done;
    load_req *head, *tail;
    int started;
} loader = {.mu = PTHREAD_MUTEX_INITIALIZER,
            .work = PTHREAD_COND_INITIALIZER,
            .done = PTHREAD_COND_INITIALIZER};

static void *loader_main(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&loader.mu);
    for (;;) {
        while (loader.head == NULL)
            pthread_cond_wait(&loader.work, &loader.mu);
        load_req *r = loader.head;
        loader.head = r->next;
        if (loader.head == NULL)
            loader.tail = NULL;
        pthread_mutex_unlock(&loader.mu);
        r->st = lr_scene_load_json(r->text, r->len, lrd_cfg.scenes_dir, NULL, 0,
                                   &r->scene, &r->err);
        pthread_mutex_lock(&loader.mu);
        r->done = 1;
        pthread_cond_broadcast(&loader.done);
    }
    return NULL;
}

/* lr_scene_load_json of the text on a loader thread; on this one if no
 * loader could be started. */
static lr_status load_on_loader(const char *text, size_t len, lr_scene **out,
                                lr_error *err)
{
    load_req r = {text, len, NULL, {0}, LR_OK, 0, NULL};
    pthread_mutex_lock(&loader.mu);
    for (; loader.started < LOADERS; loader.started++) {
        pthread_t t;
        pthread_attr_t a;
        pthread_attr_init(&a);
        pthread_attr_setdetachstate(&a, PTHREAD_CREATE_DETACHED);
        int rc = pthread_create(&t, &a, loader_main, NULL);
        pthread_attr_destroy(&a);
        if (rc != 0)
            break;
    }
    if (loader.started == 0) {
        pthread_mutex_unlock(&loader.mu);
        return lr_scene_load_json(text, len, lrd_cfg.scenes_dir, NULL, 0, out,
                                  err);
    }
    if (loader.tail != NULL)
        loader.tail->next = &r;
    else
        loader.head = &r;
    loader.tail = &r;
    pthread_cond_signal(&loader.work);
    while (!r.done)
        pthread_cond_wait(&loader.done, &loader.mu);
    pthread_mutex_unlock(&loader.mu);
    *out = r.scene;
    *err = r.err;
    return r.st;
}

/* Loads `text` into a new entry, or returns the cached one that another
 * thread loaded meanwhile.  The text stays the caller's; `named` is the
 * scene file's name for a named scene (its errors name it), else NULL. */
static lrd_scene *load_and_insert(const char *text, size_t len,
                                  const unsigned char hash[32],
                                  const char *named, lrd_err *e)
{
    lr_scene *sc = NULL;
    lr_error le;
    lr_status st = load_on_loader(text, len, &sc, &le);
    if (st != LR_OK) {
        pthread_mutex_lock(&cache.mu);
        cache.stats.misses++;
        cache.stats.loads_failed++;
        pthread_mutex_unlock(&cache.mu);
        lrd_fail_lr(e, &le, "scene", named);
        return NULL;
    }
    lrd_scene *s = calloc(1, sizeof *s);
    if (s == NULL) {
        lr_scene_free(sc);
        lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
        return NULL;
    }
    memcpy(s->hash, hash, 32);
    s->scene = sc;
    s->refs = 1;
    pthread_mutex_lock(&cache.mu);
    cache.stats.misses++;
    /* Two requests may have loaded the same scene at once; the first to
     * get here wins and the other copy is dropped. */
    lrd_scene *other = find_locked(hash);
    pthread_mutex_unlock(&cache.mu);
    /* ... unless its files changed after it read them and before this
     * load did: then this copy, the newer, replaces it (a request sent
     * after an edit rendered the old file). */
    if (other != NULL && lr_scene_files_changed(other->scene))
        other = drop(other);
    if (other != NULL) {
        entry_free(s);
        return other;
    }
    pthread_mutex_lock(&cache.mu);
    /* (Another copy may have come in meanwhile: this one goes in too and
     * the older is found less, as both hold the same files.) */
    lrd_scene *to_free = insert_locked(s);
    pthread_mutex_unlock(&cache.mu);
    free_chain(to_free);
    return s;
}

/* Scene names: letters, digits, '_' and '-', so that a name can never
 * leave the scenes directory or name a hidden file. */
static int valid_name(const char *name)
{
    size_t n = 0;
    for (; name[n] != '\0'; n++) {
        char c = name[n];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
              (c >= '0' && c <= '9') || c == '_' || c == '-'))
            return 0;
    }
    return n >= 1 && n <= 64;
}

static int same_file(const name_entry *ne, const struct stat *st)
{
    return ne->dev == st->st_dev && ne->ino == st->st_ino &&
           ne->size == st->st_size && ne->mtime.tv_sec == st->st_mtim.tv_sec &&
           ne->mtime.tv_nsec == st->st_mtim.tv_nsec;
}

/* Called with cache.mu held: remembers that `name` with identity `st`
 * has content `hash`. */
static void remember_name_locked(const char *name, const struct stat *st,
                                 const unsigned char hash[32])
{
    name_entry *ne = NULL;
    for (name_entry *p = cache.names; p != NULL; p = p->next)
        if (strcmp(p->name, name) == 0)
            ne = p;
    if (ne == NULL && cache.n_names >= MAX_NAMES) {
        /* Reuse the least recently used slot. */
        for (name_entry *p = cache.names; p != NULL; p = p->next)
            if (ne == NULL || p->last_use < ne->last_use)
                ne = p;
    }
    if (ne == NULL) {
        ne = calloc(1, sizeof *ne);
        if (ne == NULL)
            return; /* the index is only an optimisation */
        ne->next = cache.names;
        cache.names = ne;
        cache.n_names++;
    }
    snprintf(ne->name, sizeof ne->name, "%s", name);
    ne->dev = st->st_dev;
    ne->ino = st->st_ino;
    ne->size = st->st_size;
    ne->mtime = st->st_mtim;
    memcpy(ne->hash, hash, 32);
    ne->last_use = ++cache.clock;
}

lrd_scene *lrd_scene_named(const char *name, lrd_err *e)
{
    if (!valid_name(name)) {
        lrd_fail(e, 422, "invalid_value", "scene",
                 "scene must be the name of a scene (letters, digits, '_' "
                 "and '-', at most 64) or an inline scene object");
        return NULL;
    }
    char path[4200];
    snprintf(path, sizeof path, "%s/%s.json", lrd_cfg.scenes_dir, name);
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) {
        lrd_fail(e, 404, "scene_not_found", "scene",
                 "there is no scene named \"%s\" (GET /v1/scenes lists "
                 "them)",
                 name);
        return NULL;
    }

    pthread_mutex_lock(&cache.mu);
    for (name_entry *ne = cache.names; ne != NULL; ne = ne->next)
        if (strcmp(ne->name, name) == 0 && same_file(ne, &st)) {
            lrd_scene *hit = find_locked(ne->hash);
            if (hit != NULL) {
                ne->last_use = cache.clock;
                pthread_mutex_unlock(&cache.mu);
                hit = fresh(hit);
                if (hit != NULL)
                    return hit;
                pthread_mutex_lock(&cache.mu);
                break;
            }
        }
    pthread_mutex_unlock(&cache.mu);

    size_t len = 0;
    char *text = lrd_read_file(path, LRD_MAX_SCENE_FILE, &len);
    if (text == NULL) {
        lrd_fail(e, 500, "scene_broken", "scene",
                 "the scene file of \"%s\" cannot be read: %s", name,
                 strerror(errno));
        return NULL;
    }
    unsigned char hash[32];
    lrd_sha256(text, len, hash);
    pthread_mutex_lock(&cache.mu);
    lrd_scene *hit = find_locked(hash);
    if (hit != NULL) {
        remember_name_locked(name, &st, hash);
        pthread_mutex_unlock(&cache.mu);
        hit = fresh(hit);
        if (hit != NULL) {
            free(text);
            return hit;
        }
    } else {
        pthread_mutex_unlock(&cache.mu);
    }

    char file[80];
    snprintf(file, sizeof file, "%s.json", name);
    lrd_scene *s = load_and_insert(text, len, hash, file, e);
    free(text);
    if (s != NULL) {
        pthread_mutex_lock(&cache.mu);
        remember_name_locked(name, &st, hash);
        pthread_mutex_unlock(&cache.mu);
    }
    return s;
}

lrd_scene *lrd_scene_inline(const char *text, size_t len, lrd_err *e)
{
    unsigned char hash[32];
    lrd_sha256(text, len, hash);
    pthread_mutex_lock(&cache.mu);
    lrd_scene *hit = find_locked(hash);
    pthread_mutex_unlock(&cache.mu);
    hit = fresh(hit);
    if (hit != NULL)
        return hit;
    return load_and_insert(text, len, hash, NULL, e);
}
