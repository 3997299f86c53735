/*
 * lens_load.h: loaded real lenses (lr_lens), shared by every camera that
 * names them (lens_load.c).
 *
 * Ownership: lenses are interned, one per distinct prescription, and
 * never freed (lensray.h, lr_lens), so cameras hold plain pointers.  The
 * cache of exit-pupil tables inside each lens is guarded by its mutex.
 */
#ifndef LR_LENS_LOAD_H
#define LR_LENS_LOAD_H

#include "optics/prescription.h"

#include <pthread.h>

struct cJSON;

/* First-order data at the d line from real rays of tiny height (the
 * limit the paraxial trace computes; these go through the same code as
 * every camera ray). */
typedef struct lr__lens_first {
    double efl;        /* mm */
    double z_F, z_Fp;  /* front and rear focal points, lens coordinates */
    double enp_radius; /* entrance pupil radius with the stop fully open */
} lr__lens_first;

/* Where the rays from a film point at one distance from the axis that
 * get through the lens cross the rear vertex's plane (camera_lens.c): in
 * the frame of the radial direction, inside the disk of radius `rad`
 * about (cx, 0), and inside the rectangle |x - cx| <= hx, |y| <= hy. */
typedef struct lr__pupil {
    double cx, rad, hx, hy;
} lr__pupil;

/* The exit-pupil bounds are kept at LR__PUPIL_N + 1 film radii from the
 * axis to the corner. */
#define LR__PUPIL_N 48

/* One cached exit-pupil table (camera_lens.c fills it). */
typedef struct lr__pupil_entry {
    double key[7]; /* z_sensor, stop_scale, rmax, colour set, the
                      dispersion's amplification, z_rear, the camera's
                      coating (E0 holds its 1 - R) */
    lr__pupil p[LR__PUPIL_N + 1];
    double inv_E0;
} lr__pupil_entry;

#define LR__PUPIL_CACHE 64
#define LR__BLUR_CACHE 64

struct lr_lens {
    lr__rx rx;
    char *ref;  /* the name or file as given; NULL for an inline lens */
    char *json; /* an inline lens: its object as compact JSON text */
    double z[LR__RX_MAX_SURFACES + 1]; /* lr__rx_layout */
    int dispersive;                    /* some glass's index varies */
    lr__lens_first first;
    pthread_mutex_t mu;
    int n_pupils, next_pupil;
    lr__pupil_entry pupils[LR__PUPIL_CACHE];
    /* lr__lens_front_slope's bound, made on first use under mu;
     * front_slope_set is read and written atomically (acquire, release). */
    double front_slope;
    int front_slope_set;
    /* The planner's blur tables (camera.h, lr__lens_blur), made by
     * lens_blur.c on first use under mu and kept for the lens's life
     * (lenses are never freed: lens_load.c's table), so every job of a
     * daemon shares them.  Opaque here: the camera layer's type.  Past
     * LR__BLUR_CACHE of them a new focus or f-number gets no table, and
     * the plan samples the lens everywhere (right, slower): 32 filled
     * within the unit tests' one process. */
    int n_blur;
    void *blur[LR__BLUR_CACHE];
};

/* A bound on the slope (tan of the angle to the axis) of any ray from the
 * object side that gets through the lens at the d line with the stop
 * open, at most 4 (76 degrees, the light side's former fixed bound): a
 * search over slopes from 4 down (a 32 x 32 grid of points a slope over
 * the disk such rays can cross the first vertex's plane in) until a ray
 * gets through; then the last slope that let none through, times 1.5,
 * plus 0.1 (at steep slopes only slivers of the disk get through, and the
 * grid can miss them: 1.25 times was short on fisheye-10).  4 when the
 * search finds no ray at all (a small pupil behind a wide front falls
 * between the grid's points).  Computed once for the process and kept in
 * the lens; safe from any thread.  The light side draws its lens points
 * from the disk this bounds (camera_lens.c, front_disk);
 * test_camera_lens.c checks that random rays outside it never get
 * through, on every shipped lens whose bound is under 4. */
double lr__lens_front_slope(const lr_lens *L);

/* camera.lens from the scene format: a string (a file relative to
 * base_dir, or a shipped lens's name) or an inline prescription object.
 * With base_dir NULL (a job's or an API caller's override, which have no
 * scene directory) only shipped names and inline objects are accepted, so
 * a daemon never opens a path a client chose.  Errors name `path`. */
lr_status lr__lens_from_json(const struct cJSON *v, const char *path,
                             const char *base_dir, const lr_lens **out,
                             lr_error *err);

/* lr__rx_find (prescription.h) for such an override: a shipped lens or
 * an asset only, never a file of the working directory, which is the
 * server's.  Defined in rx_file.c. */
lr_status lr__rx_find_shipped(const char *name, char *out, size_t cap,
                              lr_error *err);

/* The value to write back for camera.lens: a string or an object;
 * NULL when out of memory. */
struct cJSON *lr__lens_to_json(const lr_lens *lens);

#endif
