/*
 * camera.c: what every camera model shares: defaults, the checks of the
 * common fields, the registry of models, the frame (eye, axes, field of
 * view), the chief ray, chromatic focus, autofocus, and the offset-lens
 * form that the pinhole, the thin lens and the bracket are drawn with
 * (camera.h), in scalar and 16-wide versions side by side.
 */
#include "camera/camera.h"
#include "optics/lens.h"
#include "sampling/wavelength.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void lr_camera_default(lr_camera *cam)
{
    if (cam == NULL)
        return;
    *cam = (lr_camera){0};
    cam->model = LR_CAMERA_PINHOLE;
    cam->look_at[2] = -1.0;
    cam->up[1] = 1.0;
    cam->fov = 40.0;
    cam->focus_distance = 10.0;
    cam->aperture_radius = 0.0;
    cam->f_number = 0.0;
    cam->focal_length_mm = 0.0;
    cam->aperture_shape = LR_APERTURE_DISK;
    cam->aperture_blades = 6;
    cam->aperture_rotation = 0.0;
    cam->aperture_ratio = 1.0;
    cam->focus_on[0] = cam->focus_on[1] = -1;
    cam->image_plane_distance = 1.0;
    cam->focal_length = 9.0;
    cam->aperture = 0.0;
    cam->chromatic.mode = LR_CHROMATIC_OFF;
    cam->chromatic.focal_model = LR_FOCAL_PAPER;
    /* The paper's indices for red, green and blue light in glass. */
    cam->chromatic.ior[0] = 1.50917;
    cam->chromatic.ior[1] = 1.51534;
    cam->chromatic.ior[2] = 1.51690;
    cam->chromatic.glass = LR_GLASS_BK7;
    cam->chromatic.abbe_nd = 1.5168;
    cam->chromatic.abbe_vd = 64.17;
    cam->chromatic.amplify = 1.0;
    cam->chromatic.wavelengths = LR__WL_PER_SAMPLE;
    cam->chromatic.splat = 1;
    cam->lens = NULL;
    cam->sensor_width_mm = 36.0;
    cam->scene_unit_mm = 1000.0;
    for (int m = 0; lr__camera_models[m] != NULL; m++) {
        int base = lr__camera_param_base(lr__camera_models[m]);
        for (const lr__camera_key *k = lr__camera_models[m]->keys;
             k->name != NULL; k++)
            if (k->type == LR__KEY_PARAM &&
                base + (int)k->offset < LR_CAMERA_MODEL_PARAMS)
                cam->model_params[base + k->offset] = k->def;
    }
}

lr_camera *lr_camera_new(void)
{
    lr_camera *cam = malloc(sizeof *cam);
    if (cam != NULL)
        lr_camera_default(cam);
    return cam;
}

void lr_camera_free(lr_camera *cam)
{
    free(cam);
}

/* ---- the registry ----------------------------------------------------- */

/* The models, one line each, in the order of their ids: the first four
 * are lr_camera_model's named values.  A model is its file
 * (camera_<name>.c, defining lr__camera_<name>) and its line here. */
#define LR__CAMERA_MODELS(X) \
    X(pinhole)               \
    X(thinlens)              \
    X(bracket)               \
    X(lens)                  \
    X(orthographic)

#define DECLARE(name) extern const lr__camera_model lr__camera_##name;
#define ENTRY(name) &lr__camera_##name,
LR__CAMERA_MODELS(DECLARE)
const lr__camera_model *const lr__camera_models[] = {LR__CAMERA_MODELS(ENTRY)
                                                         NULL};

const lr__camera_model *lr__camera_model_named(const char *name)
{
    for (int i = 0; lr__camera_models[i] != NULL; i++)
        if (strcmp(lr__camera_models[i]->name, name) == 0)
            return lr__camera_models[i];
    return NULL;
}

const lr__camera_model *lr__camera_model_of(lr_camera_model id)
{
    for (int i = 0; lr__camera_models[i] != NULL; i++)
        if (i == (int)id)
            return lr__camera_models[i];
    return NULL;
}

lr_camera_model lr__camera_model_id(const lr__camera_model *m)
{
    int i = 0;
    while (lr__camera_models[i] != NULL && lr__camera_models[i] != m)
        i++;
    return (lr_camera_model)i;
}

int lr__camera_param_base(const lr__camera_model *m)
{
    int base = 0;
    for (int i = 0; lr__camera_models[i] != NULL && lr__camera_models[i] != m;
         i++)
        for (const lr__camera_key *k = lr__camera_models[i]->keys;
             k->name != NULL; k++)
            base += k->type == LR__KEY_PARAM;
    return base;
}

double lr__camera_param(const lr_camera *cam, const lr__camera_model *m,
                        const lr__camera_key *k)
{
    int at = lr__camera_param_base(m) + (int)k->offset;
    return at < LR_CAMERA_MODEL_PARAMS ? cam->model_params[at] : 0.0;
}

/* ---- validation ------------------------------------------------------- */

static int ok1(double x)
{
    return isfinite(x) && fabs(x) <= LR__MAX_COORD;
}

static int finite3(const double v[3])
{
    return ok1(v[0]) && ok1(v[1]) && ok1(v[2]);
}

#define BAD(path, ...) lr__fail(err, LR_ERR_INVALID, path, __VA_ARGS__)

lr_status lr__cam_check_length(const char *path, double v, int zero_ok,
                               int is_focus, lr_error *err)
{
    if (isfinite(v) && fabs(v) > LR__MAX_COORD)
        return BAD(path, "%s must be at most 1e15, got %g", path, v);
    /* Distances that set a focus are divided into: below 1e-6 the focus
     * power, and with it the rays' directions, would overflow floats. */
    if (is_focus && v > 0.0 && v < 1e-6)
        return BAD(path, "%s must be at least 1e-6, got %g", path, v);
    if (zero_ok && !(v >= 0.0 && isfinite(v)))
        return BAD(path, "%s must be >= 0, got %g", path, v);
    if (!zero_ok && !(v > 0.0 && isfinite(v)))
        return BAD(path, "%s must be > 0, got %g", path, v);
    return LR_OK;
}

/* Chromatic aberration: the same keys for every model with a lens. */
static lr_status validate_chromatic(const lr_chromatic *ch, lr_error *err)
{
    if (ch->mode != LR_CHROMATIC_OFF && ch->mode != LR_CHROMATIC_RGB &&
        ch->mode != LR_CHROMATIC_SPECTRAL)
        return BAD("camera.chromatic.mode",
                   "camera.chromatic.mode is not a known mode (%d)",
                   (int)ch->mode);
    if (ch->focal_model != LR_FOCAL_PAPER &&
        ch->focal_model != LR_FOCAL_LENSMAKER)
        return BAD("camera.chromatic.focal_model",
                   "camera.chromatic.focal_model is not a known model (%d)",
                   (int)ch->focal_model);
    static const char *const ior_path[3] = {"camera.chromatic.ior[0]",
                                            "camera.chromatic.ior[1]",
                                            "camera.chromatic.ior[2]"};
    for (int i = 0; i < 3; i++)
        if (!(ch->ior[i] > 1.0 && ch->ior[i] < 4.0))
            return BAD(ior_path[i],
                       "%s must be between 1 and 4 (exclusive), got %g",
                       ior_path[i], ch->ior[i]);
    if ((int)ch->glass < 0 || ch->glass > LR_GLASS_ABBE)
        return BAD("camera.chromatic.glass",
                   "camera.chromatic.glass is not a known glass (%d)",
                   (int)ch->glass);
    if (!(ch->abbe_nd > 1.0 && ch->abbe_nd < 4.0))
        return BAD("camera.chromatic.abbe.n_d",
                   "camera.chromatic.abbe.n_d must be between 1 and 4, got %g",
                   ch->abbe_nd);
    if (!(ch->abbe_vd >= 1.0 && ch->abbe_vd <= 1000.0))
        return BAD("camera.chromatic.abbe.V_d",
                   "camera.chromatic.abbe.V_d must be between 1 and 1000, "
                   "got %g",
                   ch->abbe_vd);
    if (!(ch->amplify >= 0.0 && ch->amplify <= 1e6))
        return BAD("camera.chromatic.amplify",
                   "camera.chromatic.amplify must be between 0 and 1e6, got %g",
                   ch->amplify);
    if (ch->wavelengths < 1 || ch->wavelengths > 64)
        return BAD("camera.chromatic.wavelengths",
                   "camera.chromatic.wavelengths must be between 1 and 64, "
                   "got %d",
                   ch->wavelengths);
    return LR_OK;
}

lr_status lr_camera_validate(const lr_camera *cam, lr_error *err)
{
    if (cam == NULL)
        return BAD("camera", "camera is NULL");
    const lr__camera_model *model = lr__camera_model_of(cam->model);
    if (model == NULL)
        return BAD("camera.model", "camera.model is not a known model (%d)",
                   (int)cam->model);
    if (!finite3(cam->position))
        return BAD("camera.position",
                   "camera.position must be finite and within +-1e15");
    if (!finite3(cam->look_at))
        return BAD("camera.look_at",
                   "camera.look_at must be finite and within +-1e15");
    if (!finite3(cam->up))
        return BAD("camera.up", "camera.up must be finite and within +-1e15");
    lr__v3 fwd = v3_sub(v3a(cam->look_at), v3a(cam->position));
    double flen = v3_len(fwd);
    if (!(flen > 0.0) || !isfinite(flen))
        return BAD("camera.look_at",
                   "camera.look_at must differ from camera.position");
    lr__v3 up = v3a(cam->up);
    double ulen = v3_len(up);
    if (!(ulen > 0.0) || !isfinite(ulen))
        return BAD("camera.up", "camera.up must not be the zero vector");
    /* sin of the angle between up and the view direction. */
    double s = v3_len(
        v3_cross(v3_scale(fwd, 1.0 / flen), v3_scale(up, 1.0 / ulen)));
    if (!(s > 1e-9))
        return BAD("camera.up", "camera.up must not be parallel to the view "
                                "direction (look_at - position)");
    if (!(cam->fov > 0.0 && cam->fov < 180.0))
        return BAD("camera.fov",
                   "camera.fov must be in (0, 180) degrees, got %g", cam->fov);
    /* Every model checks its fields, in use or not; the one in use last,
     * with its cross-checks. */
    for (int i = 0; lr__camera_models[i] != NULL; i++) {
        if (lr__camera_models[i] == model)
            continue;
        lr_status st = lr__camera_models[i]->validate(cam, 0, err);
        if (st != LR_OK)
            return st;
    }
    if ((cam->focus_on[0] < 0) != (cam->focus_on[1] < 0))
        return BAD("camera.focus_on",
                   "camera.focus_on must be a pixel [x, y] with x, y >= 0");
    lr_status st = validate_chromatic(&cam->chromatic, err);
    if (st != LR_OK)
        return st;
    return model->validate(cam, 1, err);
}

/* ---- the frame -------------------------------------------------------- */

void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height)
{
    *c = (lr__cam){0};
    c->model = lr__camera_model_of(cam->model);
    c->origin = v3a(cam->position);
    c->forward = v3_norm(v3_sub(v3a(cam->look_at), c->origin));
    c->right = v3_norm(v3_cross(c->forward, v3a(cam->up)));
    c->up = v3_cross(c->right, c->forward);
    c->half_h = tan(cam->fov * M_PI / 360.0);
    c->half_w = c->half_h * (double)width / (double)height;
    c->width = width;
    c->height = height;
    c->ratio = 1.0;
    c->shape = LR_APERTURE_DISK;
    c->blades = 6;
    c->chroma = cam->chromatic;
    c->nm_ref = LR__NM_d;
    c->model->setup(c, cam);
    /* The packet rays' constants, rounded as offset_lens_rays16 rounded
     * them per call. */
    c->f16.sw = (float)(2.0 / c->width);
    c->f16.sh = (float)(2.0 / c->height);
    c->f16.hw = (float)c->half_w;
    c->f16.hh = (float)c->half_h;
    const lr__v3 *frame[4] = {&c->forward, &c->right, &c->up, &c->origin};
    float *f16[4] = {c->f16.fw, c->f16.rt, c->f16.up, c->f16.e};
    for (int k = 0; k < 4; k++) {
        f16[k][0] = (float)frame[k]->x;
        f16[k][1] = (float)frame[k]->y;
        f16[k][2] = (float)frame[k]->z;
    }
    c->f16.rad = (float)c->radius;
    c->f16.w = (float)c->w;
    /* Without an aperture the bracket's rays start at the eye, as the
     * pinhole's and the scalar ray's do (lr__offset_lens_ray), not on
     * its image plane, which would hide what lies nearer. */
    c->f16.di = c->has_lens ? (float)c->base_di : 0.0f;

    /* Chromatic focus: the model has set the focus line w(n) = w_base +
     * w_slope scale(n); with the reference index the power is c->w. */
    const lr_chromatic *ch = &cam->chromatic;
    if (c->chroma_fixed)
        return;
    if (ch->mode == LR_CHROMATIC_RGB) {
        c->n_ref = ch->ior[1];
        for (int i = 0; i < 3; i++) {
            double n = c->n_ref + ch->amplify * (ch->ior[i] - c->n_ref);
            c->w_rgb[i] = c->w_base +
                          c->w_slope *
                              lr__power_scale(ch->focal_model, c->n_ref, n);
        }
        /* The green channel is the reference: exactly the camera's focus. */
        c->w_rgb[1] = c->w;
        c->chroma_active = c->has_lens && (c->w_rgb[0] != c->w_rgb[1] ||
                                           c->w_rgb[2] != c->w_rgb[1]);
    } else if (ch->mode == LR_CHROMATIC_SPECTRAL) {
        c->n_ref = lr__glass_index(ch->glass, ch->abbe_nd, ch->abbe_vd,
                                   LR__LAMBDA_D);
        c->chroma_active = c->has_lens && ch->amplify != 0.0;
    }
}

/* The chief ray's direction scaled so that its component along the view
 * axis is 1: the film point on the image plane at distance 1. */
static lr__v3 chief_ray(const lr__cam *c, double fx, double fy)
{
    /* Film to the image plane at distance 1: x right, y up. */
    double sx = (2.0 * fx / c->width - 1.0) * c->half_w;
    double sy = (1.0 - 2.0 * fy / c->height) * c->half_h;
    return v3_madd(v3_madd(c->forward, c->right, sx), c->up, sy);
}

void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir)
{
    if (c->model->chief != NULL) {
        c->model->chief(c, fx, fy, org, dir);
        return;
    }
    *org = c->origin;
    *dir = v3_norm(chief_ray(c, fx, fy));
}

double lr__cam_power_at(const lr__cam *c, double nm)
{
    const lr_chromatic *ch = &c->chroma;
    double n = lr__glass_index(ch->glass, ch->abbe_nd, ch->abbe_vd, nm);
    n = c->n_ref + ch->amplify * (n - c->n_ref);
    return c->w_base +
           c->w_slope * lr__power_scale(ch->focal_model, c->n_ref, n);
}

void lr__cam_bound(const lr__cam *c, lr__lens_bound *b)
{
    /* The colours differ from the reference only in focus power: the
     * model converts each as it converts its own (a scratch copy of the
     * camera with that power). */
    c->model->bound(c, b);
    b->n_w = 1;
    if (!c->chroma_active)
        return;
    double w1, w2;
    if (c->chroma.mode == LR_CHROMATIC_RGB) {
        w1 = c->w_rgb[0];
        w2 = c->w_rgb[2];
    } else {
        w1 = lr__cam_power_at(c, 380.0);
        w2 = lr__cam_power_at(c, 780.0);
    }
    lr__cam tmp = *c;
    lr__lens_bound bb;
    tmp.w = w1;
    c->model->bound(&tmp, &bb);
    b->ws[1] = bb.ws[0];
    tmp.w = w2;
    c->model->bound(&tmp, &bb);
    b->ws[2] = bb.ws[0];
    b->n_w = 3;
}

/* ---- the offset-lens form -------------------------------------------- */

double lr__offset_lens_ray(const lr__cam *c, double fx, double fy,
                           const double u[2], double w, double nm, lr__v3 *org,
                           lr__v3 *dir)
{
    (void)nm;
    /* D has axial component 1, so the point of the chief ray at axial
     * distance 1/w is e + D / w, and the ray from the lens point e + off
     * through it runs along D / w - off, i.e. D - off w (the cos factor
     * of camera.h's formula is folded into D's length). */
    lr__v3 D = chief_ray(c, fx, fy);
    if (!c->has_lens) {
        *org = c->origin;
        *dir = v3_norm(D);
        return 1.0;
    }
    double lx, ly;
    lr__aperture_sample(c->shape, c->blades, c->rotation, c->ratio, u, &lx,
                        &ly);
    lr__v3 off = v3_madd(v3_scale(c->right, lx * c->radius), c->up,
                         ly * c->radius);
    lr__v3 base = c->origin;
    if (c->base_di != 0.0)
        base = v3_madd(c->origin, D, c->base_di);
    *org = v3_add(base, off);
    *dir = v3_norm(v3_madd(D, off, -w));
    return 1.0;
}

/* The same rays for a packet, in single precision, lane by lane in loops
 * the compiler vectorises, since Embree traces floats anyway; hits are
 * completed on exactly the ray that was traced, read back from it.  Built
 * for AVX-512, AVX2 and any x86-64, chosen at load time (the float
 * arithmetic is the same in all, lane by lane: no FMA contraction, as
 * -ffp-contract=off in the Makefile keeps it). */
static inline __attribute__((always_inline)) void
offset_lens_rays16(const lr__cam *c, int use_lens, int n, const float *fx,
                   const float *fy, const float *lu, const float *lv,
                   const float *wl, struct RTCRayHit16 *rh)
{
    /* A copy in locals: the ray stores below could alias *c for all
     * the compiler knows, and through pointers into c it no longer
     * vectorises the loop. */
    const float sw = c->f16.sw, sh = c->f16.sh;
    const float hw = c->f16.hw, hh = c->f16.hh;
    const float fw[3] = {c->f16.fw[0], c->f16.fw[1], c->f16.fw[2]};
    const float rt[3] = {c->f16.rt[0], c->f16.rt[1], c->f16.rt[2]};
    const float up[3] = {c->f16.up[0], c->f16.up[1], c->f16.up[2]};
    const float e[3] = {c->f16.e[0], c->f16.e[1], c->f16.e[2]};
    const float rad = c->f16.rad, w = c->f16.w;
    const float di = c->f16.di;
    float lx[16], ly[16];
    struct RTCRay16 *r = &rh->ray;

    if (!c->has_lens || !use_lens) {
        for (int i = 0; i < 16; i++)
            lx[i] = ly[i] = 0.0f;
    } else {
        lr__aperture_sample16(c->shape, c->blades, c->rotation, c->ratio, n, lu,
                              lv, lx, ly);
    }
    for (int i = 0; i < 16; i++) {
        /* D: the chief ray scaled to axial length 1. */
        float sx = (fx[i] * sw - 1.0f) * hw, sy = (1.0f - fy[i] * sh) * hh;
        float dx = fw[0] + rt[0] * sx + up[0] * sy;
        float dy = fw[1] + rt[1] * sx + up[1] * sy;
        float dz = fw[2] + rt[2] * sx + up[2] * sy;
        float ox = rad * (rt[0] * lx[i] + up[0] * ly[i]);
        float oy = rad * (rt[1] * lx[i] + up[1] * ly[i]);
        float oz = rad * (rt[2] * lx[i] + up[2] * ly[i]);
        r->org_x[i] = e[0] + dx * di + ox;
        r->org_y[i] = e[1] + dy * di + oy;
        r->org_z[i] = e[2] + dz * di + oz;
        /* Each lane's own focus power (spectral), or the camera's. */
        float wi = wl != NULL ? wl[i] : w;
        float vx = dx - ox * wi, vy = dy - oy * wi, vz = dz - oz * wi;
        float inv = 1.0f / sqrtf(vx * vx + vy * vy + vz * vz);
        r->dir_x[i] = vx * inv;
        r->dir_y[i] = vy * inv;
        r->dir_z[i] = vz * inv;
        lr__ray16_open(rh, i);
    }
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__offset_lens_rays16(const lr__cam *c, int use_lens, int n, const float *fx,
                       const float *fy, const float *lu, const float *lv,
                       struct RTCRayHit16 *rh, float *wt)
{
    (void)wt; /* every ray weighs 1 */
    offset_lens_rays16(c, use_lens, n, fx, fy, lu, lv, NULL, rh);
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__offset_lens_rays16_w(const lr__cam *c, int n, const float *fx,
                         const float *fy, const float *lu, const float *lv,
                         const float *w, struct RTCRayHit16 *rh, float *wt)
{
    (void)wt;
    offset_lens_rays16(c, 1, n, fx, fy, lu, lv, w, rh);
}

void lr__offset_lens_shift16(const lr__cam *c, int n, const float *lu,
                             const float *lv, float *sx, float *sy)
{
    /* The ray through film point D (axial length 1) at power w has
     * direction D - off w from e + off (the top of camera.h); at power
     * w + t through D + t off it has the same direction from the same
     * point.  On the film, t off = t R (lx right + ly up) is t R fpx lx
     * pixels right and t R fpx ly up (rows grow downwards), with fpx =
     * H / (2 half_h) = W / (2 half_w).  The lens point is the one the
     * packet's rays take (lr__aperture_sample16 on the same numbers). */
    float lx[16], ly[16];
    lr__aperture_sample16(c->shape, c->blades, c->rotation, c->ratio, n, lu, lv,
                          lx, ly);
    double k = c->radius * c->height / (2.0 * c->half_h);
    for (int i = 0; i < 16; i++) {
        sx[i] = (float)(k * lx[i]);
        sy[i] = (float)(-k * ly[i]);
    }
}

lr__v3 lr__offset_lens_point(const lr__cam *c, const double u[2], double *ox,
                             double *oy)
{
    *ox = *oy = 0.0;
    if (!c->has_lens)
        return c->origin;
    double lx, ly;
    lr__aperture_sample(c->shape, c->blades, c->rotation, c->ratio, u, &lx,
                        &ly);
    *ox = lx * c->radius;
    *oy = ly * c->radius;
    return v3_madd(v3_madd(c->origin, c->right, *ox), c->up, *oy);
}

/* The camera ray from lens offset off runs along D - off w, D = (sx, sy,
 * 1) in the camera's frame (lr__offset_lens_ray), so a direction d with
 * components (dx, dy, dz) there comes from the film point whose chief
 * ray has sx = dx / dz + ox w, sy = dy / dz + oy w.  For a fixed lens
 * point the film, in image-plane units at distance 1, maps to directions
 * as a pinhole does, shifted: its area element is cos^3 theta per unit
 * solid angle (theta between d and the axis), and a pixel is 1 / fpx^2 of
 * image-plane area (fpx = width / (2 half_w)).  A pixel's value is the
 * mean over its area and the lens of the radiance its rays see, so
 * radiance L along d adds L fpx^2 / cos^3 theta per unit solid angle and
 * unit lens measure (Veach 1997, section 10.2, the importance of a
 * camera; pbrt-v4's PerspectiveCamera::We without its cos^4, since
 * lensray's thin lens weighs every ray alike). */
double lr__offset_lens_film(const lr__cam *c, double ox, double oy, lr__v3 d,
                            double *fx, double *fy)
{
    return lr__offset_lens_film_w(c, c->w, ox, oy, d, fx, fy);
}

double lr__offset_lens_film_rgb(const lr__cam *c, int k, double ox, double oy,
                                lr__v3 d, double *fx, double *fy)
{
    return lr__offset_lens_film_w(c, c->w_rgb[k], ox, oy, d, fx, fy);
}

double lr__offset_lens_film_wl(const lr__cam *c, double w, double nm, double ox,
                               double oy, lr__v3 d, double *fx, double *fy)
{
    (void)nm;
    return lr__offset_lens_film_w(c, w, ox, oy, d, fx, fy);
}

int lr__cam_lands_colours(const lr__cam *c)
{
    if (!c->chroma_active)
        return 1;
    if (c->chroma.mode == LR_CHROMATIC_RGB)
        return c->model->film_rgb != NULL;
    return c->chroma.mode == LR_CHROMATIC_SPECTRAL && c->model->film_wl != NULL;
}

void lr__cam_wl_table(const lr__cam *c, lr__wl_table *t)
{
    /* Sellmeier's formula for every ray cost as much as choosing its
     * wavelength.  Linear between whole nanometres, the index of SF11
     * (the most dispersive glass shipped) is off by at most 1.4e-6, 1.5e-5
     * of its range over the spectrum (checked against Sellmeier at 0.1
     * nm); the power is kept in float, as the rays are traced, anyway. */
    float power[LR__WL_NODES];
    int spectral = c->chroma.mode == LR_CHROMATIC_SPECTRAL;
    for (int j = 0; j < LR__WL_NODES; j++)
        power[j] = spectral ? (float)lr__cam_power_at(c, 380.0 + j)
                            : (float)c->w;
    lr__wl_table_init(t, power, c->w);
}

/* The next place of *ld: the pixel of film point (fx, fy), weights imp W
 * (W may be negative: spectral weights), if the film holds the point and
 * the camera's importance imp there is positive. */
static int land_at(const lr__cam *c, lr__landing *ld, double imp, double fx,
                   double fy, const double W[3])
{
    if (!(imp > 0.0) || !lr__cam_on_film(c, fx, fy))
        return 0;
    int j = ld->n++;
    ld->at[j].ix = (int)fx;
    ld->at[j].iy = (int)fy;
    for (int k = 0; k < 3; k++)
        ld->at[j].W[k] = imp * W[k];
    return 1;
}

/* Colour j's focus power and weights (rgb: channel j; spectral:
 * wavelength j of n_wl, from stratum (u_wl + j) / n_wl, spectral.c's
 * strata, each of probability 1 / n_wl); its wavelength in *nm. */
static double colour(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                     int j, double W[3], double *nm)
{
    if (c->chroma.mode == LR_CHROMATIC_RGB) {
        W[0] = W[1] = W[2] = 0.0;
        W[j] = 1.0;
        *nm = 0.0;
        return c->w_rgb[j];
    }
    int n_wl = c->chroma.wavelengths;
    float pw;
    *nm = lr__wl_sample(wl, (u_wl + j) / n_wl, W, &pw);
    for (int k = 0; k < 3; k++)
        W[k] /= n_wl;
    return pw;
}

/* Place j of *ld for colour j (lr__cam_colours_apart's modes). */
static void land_colour(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                        int j, double ox, double oy, lr__v3 d, lr__landing *ld)
{
    double W[3], nm, fx, fy, imp;
    double w = colour(c, wl, u_wl, j, W, &nm);
    if (c->chroma.mode == LR_CHROMATIC_RGB)
        imp = c->model->film_rgb(c, j, ox, oy, d, &fx, &fy);
    else
        imp = c->model->film_wl(c, w, nm, ox, oy, d, &fx, &fy);
    land_at(c, ld, imp, fx, fy, W);
}

int lr__cam_land(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                 double ox, double oy, lr__v3 d, lr__landing *ld)
{
    ld->n = 0;
    if (!c->chroma_active) {
        const double one[3] = {1.0, 1.0, 1.0};
        double fx, fy;
        double imp = c->model->film(c, ox, oy, d, &fx, &fy);
        return land_at(c, ld, imp, fx, fy, one);
    }
    int n = c->chroma.mode == LR_CHROMATIC_RGB ? 3 : c->chroma.wavelengths;
    for (int j = 0; j < n; j++)
        land_colour(c, wl, u_wl, j, ox, oy, d, ld);
    return ld->n > 0;
}

int lr__cam_colours_apart(const lr__cam *c)
{
    if (!c->chroma_active || c->model->lens_point_w == NULL)
        return 0;
    return c->chroma.mode == LR_CHROMATIC_RGB ? 3 : c->chroma.wavelengths;
}

lr__v3 lr__cam_colour_point(const lr__cam *c, const lr__wl_table *wl,
                            double u_wl, int j, const double u[2], double *ox,
                            double *oy)
{
    double W[3], nm;
    double w = colour(c, wl, u_wl, j, W, &nm);
    return c->model->lens_point_w(c, w, u, ox, oy);
}

int lr__cam_land_colour(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                        int j, double ox, double oy, lr__v3 d, lr__landing *ld)
{
    ld->n = 0;
    land_colour(c, wl, u_wl, j, ox, oy, d, ld);
    return ld->n > 0;
}

double lr__offset_lens_film_w(const lr__cam *c, double w, double ox, double oy,
                              lr__v3 d, double *fx, double *fy)
{
    double dz = v3_dot(d, c->forward);
    if (!(dz > 0.0))
        return 0.0;
    double sx = v3_dot(d, c->right) / dz + ox * w;
    double sy = v3_dot(d, c->up) / dz + oy * w;
    *fx = (sx / c->half_w + 1.0) * 0.5 * c->width;
    *fy = (1.0 - sy / c->half_h) * 0.5 * c->height;
    double fpx = 0.5 * c->height / c->half_h;
    return fpx * fpx / (dz * dz * dz);
}

void lr__offset_lens_bound(const lr__cam *c, lr__lens_bound *b)
{
    /* The aperture's farthest point from its centre. */
    double reach = c->shape == LR_APERTURE_SQUARE ? sqrt(2.0) : 1.0;
    double ratio = c->ratio > 1.0 ? c->ratio : 1.0;
    b->R = c->radius * reach * ratio;
    b->n_w = 1;
    b->ws[0] = c->w;
}
