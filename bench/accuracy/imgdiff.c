/*
 * imgdiff.c: error measures between rendered float EXR images and a
 * reference, for `make accuracy` (bench/accuracy/run.py, docs/accuracy.md).
 *
 *     imgdiff [--eps E] [--map OUT.pgm] REF.exr IMG.exr [IMG.exr ...]
 *
 * prints one JSON line per IMG:
 *
 *     {"file": "...", "relmse": ..., "grad_relmse": ..., "dssim": ...,
 *      "mse": ..., "width": W, "height": H}
 *
 * The measures (defined in docs/accuracy.md, section "Measures"):
 *
 *   relmse       mean over pixels p and channels c of
 *                  (x_pc - r_pc)^2 / (r_pc^2 + eps),   eps = 1e-2
 *                (the per-pixel relative MSE of Rousselle et al. 2011 and
 *                pbrt's imgtool; eps keeps dark pixels from dominating).
 *   grad_relmse  the same with x and r replaced by their forward
 *                differences in x and in y (both summed), and r^2 by the
 *                reference's local mean squared value over the two
 *                pixels: an edge-aware error, which weighs misplaced,
 *                blurred or aliased edges and high-frequency noise.
 *   dssim        1 - mean SSIM (Wang et al. 2004; 11 x 11 Gaussian window,
 *                sigma 1.5, K1 0.01, K2 0.03) on display luminance: Rec.709
 *                luminance clamped to [0, 1] and sRGB-encoded.
 *   mse          the plain MSE over pixels and channels.
 *
 * --map writes, for the last IMG, a binary PGM of the per-pixel relative
 * error (mean over the channels), 255 at 0.1 and above, on a square-root
 * scale: where the error is.
 *
 * EXR files are read with OpenEXRCore (the C API of OpenEXR 3), every
 * channel widened to float; R, G and B are required.  Exit status 0 on
 * success, 1 on a usage error, 2 when a file cannot be read or the sizes
 * differ.
 */
#include <openexr.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct image {
    int width, height;
    float *rgb[3]; /* planes R, G, B, width * height each */
} image;

static void image_free(image *im)
{
    for (int c = 0; c < 3; c++)
        free(im->rgb[c]);
    memset(im, 0, sizeof *im);
}

/* Reads the R, G and B channels of a single-part scanline EXR as float.
 * Returns 0 on success; on failure prints why and returns -1. */
static int read_exr(const char *path, image *out)
{
    memset(out, 0, sizeof *out);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctxt = NULL;
    if (exr_start_read(&ctxt, path, &init) != EXR_ERR_SUCCESS) {
        fprintf(stderr, "imgdiff: %s: cannot read as OpenEXR\n", path);
        return -1;
    }
    int rc = -1;
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t spc = 0;
    if (exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS ||
        storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(ctxt, 0, &dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctxt, 0, &chl) != EXR_ERR_SUCCESS ||
        exr_get_scanlines_per_chunk(ctxt, 0, &spc) != EXR_ERR_SUCCESS) {
        fprintf(stderr, "imgdiff: %s: not a scanline image\n", path);
        goto done;
    }
    out->width = dw.max.x - dw.min.x + 1;
    out->height = dw.max.y - dw.min.y + 1;
    if (out->width <= 0 || out->height <= 0) {
        fprintf(stderr, "imgdiff: %s: empty data window\n", path);
        goto done;
    }
    size_t n = (size_t)out->width * (size_t)out->height;
    for (int c = 0; c < 3; c++) {
        out->rgb[c] = calloc(n, sizeof(float));
        if (out->rgb[c] == NULL) {
            fprintf(stderr, "imgdiff: out of memory\n");
            goto done;
        }
    }
    static const char *const names[3] = {"R", "G", "B"};
    int found[3] = {0, 0, 0};
    for (int i = 0; i < chl->num_channels; i++)
        for (int c = 0; c < 3; c++)
            if (strcmp(chl->entries[i].name.str, names[c]) == 0)
                found[c] = 1;
    if (!found[0] || !found[1] || !found[2]) {
        fprintf(stderr, "imgdiff: %s: needs channels R, G and B\n", path);
        goto done;
    }
    for (int y = dw.min.y; y <= dw.max.y; y += spc) {
        exr_chunk_info_t ci;
        exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
        if (exr_read_scanline_chunk_info(ctxt, 0, y, &ci) != EXR_ERR_SUCCESS ||
            exr_decoding_initialize(ctxt, 0, &ci, &dec) != EXR_ERR_SUCCESS) {
            fprintf(stderr, "imgdiff: %s: bad chunk at line %d\n", path, y);
            goto done;
        }
        size_t first = (size_t)(ci.start_y - dw.min.y) * (size_t)out->width;
        for (int i = 0; i < dec.channel_count; i++) {
            exr_coding_channel_info_t *ch = &dec.channels[i];
            int c = -1;
            for (int k = 0; k < 3; k++)
                if (strcmp(ch->channel_name, names[k]) == 0)
                    c = k;
            if (c < 0) {
                /* Other channels (Z) are not needed: skip decoding them. */
                ch->decode_to_ptr = NULL;
                continue;
            }
            ch->decode_to_ptr = (uint8_t *)(out->rgb[c] + first);
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * out->width;
        }
        int ok = exr_decoding_choose_default_routines(ctxt, 0, &dec) ==
                     EXR_ERR_SUCCESS &&
                 exr_decoding_run(ctxt, 0, &dec) == EXR_ERR_SUCCESS;
        exr_decoding_destroy(ctxt, &dec);
        if (!ok) {
            fprintf(stderr, "imgdiff: %s: cannot decode line %d\n", path, y);
            goto done;
        }
    }
    rc = 0;
done:
    exr_finish(&ctxt);
    if (rc != 0)
        image_free(out);
    return rc;
}

/* ---- measures ---------------------------------------------------------- */

static double rel_mse(const image *x, const image *r, double eps, double *mse)
{
    size_t n = (size_t)x->width * (size_t)x->height;
    double sum = 0.0, sq = 0.0;
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < n; i++) {
            double d = (double)x->rgb[c][i] - (double)r->rgb[c][i];
            double ref = r->rgb[c][i];
            sum += d * d / (ref * ref + eps);
            sq += d * d;
        }
    *mse = sq / (3.0 * (double)n);
    return sum / (3.0 * (double)n);
}

/* Relative MSE of the forward differences: for each pair of neighbours
 * (i, j) along x and along y, the error of (x_j - x_i) against
 * (r_j - r_i), divided by (r_i^2 + r_j^2) / 2 + eps. */
static double grad_rel_mse(const image *x, const image *r, double eps)
{
    int w = x->width, h = x->height;
    double sum = 0.0;
    size_t count = 0;
    for (int c = 0; c < 3; c++) {
        const float *xp = x->rgb[c], *rp = r->rgb[c];
        for (int py = 0; py < h; py++)
            for (int px = 0; px < w; px++) {
                size_t i = (size_t)py * (size_t)w + (size_t)px;
                for (int dir = 0; dir < 2; dir++) {
                    if (dir == 0 && px + 1 >= w)
                        continue;
                    if (dir == 1 && py + 1 >= h)
                        continue;
                    size_t j = dir == 0 ? i + 1 : i + (size_t)w;
                    double gx = (double)xp[j] - (double)xp[i];
                    double gr = (double)rp[j] - (double)rp[i];
                    double m = 0.5 *
                               ((double)rp[i] * rp[i] + (double)rp[j] * rp[j]);
                    sum += (gx - gr) * (gx - gr) / (m + eps);
                    count++;
                }
            }
    }
    return count ? sum / (double)count : 0.0;
}

static double srgb_encode(double v)
{
    if (v <= 0.0)
        return 0.0;
    if (v >= 1.0)
        return 1.0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

/* Display luminance: Rec.709 / sRGB luminance, clamped and encoded. */
static double *display_luma(const image *im)
{
    size_t n = (size_t)im->width * (size_t)im->height;
    double *y = malloc(n * sizeof *y);
    if (y == NULL)
        return NULL;
    for (size_t i = 0; i < n; i++)
        y[i] = srgb_encode(0.2126 * im->rgb[0][i] + 0.7152 * im->rgb[1][i] +
                           0.0722 * im->rgb[2][i]);
    return y;
}

/* Separable Gaussian blur of `in` into `out` (both w x h), with the
 * window renormalised at the borders. */
static void gauss_blur(const double *in, double *out, double *tmp, int w, int h,
                       const double *k, int rad)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0, ws = 0.0;
            for (int d = -rad; d <= rad; d++) {
                int xx = x + d;
                if (xx < 0 || xx >= w)
                    continue;
                s += k[d + rad] * in[(size_t)y * w + xx];
                ws += k[d + rad];
            }
            tmp[(size_t)y * w + x] = s / ws;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0, ws = 0.0;
            for (int d = -rad; d <= rad; d++) {
                int yy = y + d;
                if (yy < 0 || yy >= h)
                    continue;
                s += k[d + rad] * tmp[(size_t)yy * w + x];
                ws += k[d + rad];
            }
            out[(size_t)y * w + x] = s / ws;
        }
}

/* 1 - mean SSIM on display luminance; -1 when out of memory. */
static double dssim(const image *x, const image *r)
{
    enum { RAD = 5 };
    int w = x->width, h = x->height;
    size_t n = (size_t)w * (size_t)h;
    double k[2 * RAD + 1];
    for (int d = -RAD; d <= RAD; d++)
        k[d + RAD] = exp(-(double)(d * d) / (2.0 * 1.5 * 1.5));
    double *a = display_luma(x), *b = display_luma(r);
    double *buf = malloc(7 * n * sizeof *buf);
    if (a == NULL || b == NULL || buf == NULL) {
        free(a);
        free(b);
        free(buf);
        return -1.0;
    }
    double *ma = buf, *mb = buf + n, *saa = buf + 2 * n, *sbb = buf + 3 * n,
           *sab = buf + 4 * n, *prod = buf + 5 * n, *tmp = buf + 6 * n;
    gauss_blur(a, ma, tmp, w, h, k, RAD);
    gauss_blur(b, mb, tmp, w, h, k, RAD);
    for (size_t i = 0; i < n; i++)
        prod[i] = a[i] * a[i];
    gauss_blur(prod, saa, tmp, w, h, k, RAD);
    for (size_t i = 0; i < n; i++)
        prod[i] = b[i] * b[i];
    gauss_blur(prod, sbb, tmp, w, h, k, RAD);
    for (size_t i = 0; i < n; i++)
        prod[i] = a[i] * b[i];
    gauss_blur(prod, sab, tmp, w, h, k, RAD);
    const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        double va = saa[i] - ma[i] * ma[i], vb = sbb[i] - mb[i] * mb[i];
        double cov = sab[i] - ma[i] * mb[i];
        sum += ((2 * ma[i] * mb[i] + c1) * (2 * cov + c2)) /
               ((ma[i] * ma[i] + mb[i] * mb[i] + c1) * (va + vb + c2));
    }
    free(a);
    free(b);
    free(buf);
    return 1.0 - sum / (double)n;
}

/* Prints s as a JSON string (file names are the harness's own, but quote
 * the two characters that would break the line anyway). */
static void print_json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        if (*s == '"' || *s == '\\')
            putchar('\\');
        putchar(*s);
    }
    putchar('"');
}

/* Writes the per-pixel relative error map (see the top of the file). */
static int write_map(const char *path, const image *x, const image *r,
                     double eps)
{
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        fprintf(stderr, "imgdiff: cannot write %s\n", path);
        return -1;
    }
    fprintf(f, "P5\n%d %d\n255\n", x->width, x->height);
    size_t n = (size_t)x->width * (size_t)x->height;
    for (size_t i = 0; i < n; i++) {
        double e = 0.0;
        for (int c = 0; c < 3; c++) {
            double d = (double)x->rgb[c][i] - (double)r->rgb[c][i];
            double ref = r->rgb[c][i];
            e += d * d / (ref * ref + eps) / 3.0;
        }
        double v = sqrt(e / 0.1) * 255.0;
        fputc(v >= 255.0 ? 255 : (int)v, f);
    }
    return fclose(f) == 0 ? 0 : -1;
}

int main(int argc, char **argv)
{
    double eps = 1e-2;
    const char *map = NULL;
    int i = 1;
    while (i + 1 < argc && argv[i][0] == '-') {
        if (strcmp(argv[i], "--eps") == 0) {
            char *end = NULL;
            eps = strtod(argv[i + 1], &end);
            if (end == argv[i + 1] || *end != '\0' || !(eps > 0.0)) {
                fprintf(stderr, "imgdiff: --eps needs a number > 0\n");
                return 1;
            }
        } else if (strcmp(argv[i], "--map") == 0) {
            map = argv[i + 1];
        } else {
            fprintf(stderr, "imgdiff: unknown option %s\n", argv[i]);
            return 1;
        }
        i += 2;
    }
    if (argc - i < 2) {
        fprintf(stderr, "usage: imgdiff [--eps E] [--map OUT.pgm] REF.exr "
                        "IMG.exr [IMG.exr ...]\n");
        return 1;
    }
    image ref;
    if (read_exr(argv[i], &ref) != 0)
        return 2;
    int status = 0;
    for (int k = i + 1; k < argc; k++) {
        image im;
        if (read_exr(argv[k], &im) != 0) {
            status = 2;
            continue;
        }
        if (im.width != ref.width || im.height != ref.height) {
            fprintf(stderr, "imgdiff: %s is %d x %d, the reference %d x %d\n",
                    argv[k], im.width, im.height, ref.width, ref.height);
            image_free(&im);
            status = 2;
            continue;
        }
        double mse = 0.0;
        double rel = rel_mse(&im, &ref, eps, &mse);
        double grad = grad_rel_mse(&im, &ref, eps);
        double ds = dssim(&im, &ref);
        if (ds < 0.0) {
            fprintf(stderr, "imgdiff: out of memory\n");
            image_free(&im);
            status = 2;
            continue;
        }
        printf("{\"file\": ");
        print_json_string(argv[k]);
        printf(", \"relmse\": %.6e, \"grad_relmse\": %.6e, \"dssim\": %.6e, "
               "\"mse\": %.6e, \"width\": %d, \"height\": %d}\n",
               rel, grad, ds, mse, im.width, im.height);
        if (map != NULL && k == argc - 1 && write_map(map, &im, &ref, eps) != 0)
            status = 2;
        image_free(&im);
    }
    image_free(&ref);
    return status;
}
