/*
 * lens_ghosts.c: lr_lens_ghosts and lr_lens_ghosts_at, each ghost
 * path's flux for a distant point on the axis or off it (`lensray lens
 * FILE --ghosts [--field-angles A]`, issue 29), from ghost_flux.c's grid
 * of rays.
 */
#include "optics/ghost.h"
#include "json/json_util.h"
#include "optics/transmit.h"

#include <math.h>
#include <stdlib.h>

/* The beam's rays across the front element (as docs/lenses.md's table),
 * and the frame they must land in: a 36 x 24 mm sensor's half
 * diagonal. */
#define GRID 61
#define HALF_DIAG 21.633307652783937

static cJSON *ghosts_json(const lr__rx *rx, double nm, double field_deg,
                          int coating)
{
    lr__ghost_flux *f = malloc(sizeof *f * LR__GHOST_MAX);
    cJSON *o = cJSON_CreateObject();
    if (f == NULL || o == NULL) {
        free(f);
        cJSON_Delete(o);
        return NULL;
    }
    static const char *const names[] = {"prescription", "none", "mgf2"};
    double main = 0.0;
    int n = lr__ghost_fluxes(rx, lr__coating_override(coating), field_deg, nm,
                             GRID, HALF_DIAG, f, &main);
    cJSON_AddStringToObject(o, "name", rx->name);
    cJSON_AddNumberToObject(o, "wavelength_nm", nm);
    cJSON_AddStringToObject(o, "coating", names[coating]);
    cJSON_AddNumberToObject(o, "field_deg", field_deg);
    cJSON_AddNumberToObject(o, "frame_radius_mm", HALF_DIAG);
    cJSON_AddNumberToObject(o, "main_transmission", main);
    double total = 0.0;
    cJSON *arr = cJSON_AddArrayToObject(o, "ghosts");
    for (int k = 0; k < n && arr != NULL; k++) {
        cJSON *g = cJSON_CreateObject();
        int s[2] = {f[k].path.j, f[k].path.i};
        double c[2] = {f[k].cx, f[k].cy};
        cJSON_AddItemToObject(g, "surfaces", cJSON_CreateIntArray(s, 2));
        cJSON_AddNumberToObject(g, "flux", f[k].flux);
        cJSON_AddItemToObject(g, "centroid_mm", cJSON_CreateDoubleArray(c, 2));
        cJSON_AddNumberToObject(g, "rms_radius_mm", f[k].rms);
        cJSON_AddItemToArray(arr, g);
        total += f[k].flux;
    }
    cJSON_AddNumberToObject(o, "ghost_paths", n);
    cJSON_AddNumberToObject(o, "total_flux", total);
    free(f);
    return o;
}

lr_status lr_lens_ghosts(const char *lens, const char *base_dir, double nm,
                         lr_lens_coating coating, char **json, lr_error *err)
{
    return lr_lens_ghosts_at(lens, base_dir, nm, 0.0, coating, json, err);
}

lr_status lr_lens_ghosts_at(const char *lens, const char *base_dir, double nm,
                            double field_deg, lr_lens_coating coating,
                            char **json, lr_error *err)
{
    if (json != NULL)
        *json = NULL;
    if (lens == NULL || json == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_lens_ghosts: a lens name and an output pointer "
                        "are required");
    LR_TRY(lr__lens_check_args(&field_deg, 1, nm, err));
    if ((int)coating < 0 || (int)coating > 2)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_lens_ghosts: coating %d is not an lr_lens_coating",
                        (int)coating);
    lr__rx *rx;
    LR_TRY(lr__rx_load_named(lens, base_dir, &rx, err));
    cJSON *o = ghosts_json(rx, nm, field_deg, (int)coating);
    free(rx);
    return lr__json_print_owned(o, json, err);
}
