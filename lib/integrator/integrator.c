/*
 * integrator.c: the registry of integrators (integrator.h).  Everything
 * that names an integrator reads this table: the render loop picks the
 * row render.integrator names, the settings' parser, writer and check
 * take the names and the valid values from it, and the daemon's
 * GET /v1/options lists them (through lr_render_settings_json).
 */
#include "integrator/integrator.h"
#include "scene/light.h"

/* Indexed by lr_integrator_kind, whose values run from 0 without gaps:
 * a new integrator is its file, a value in lr_integrator_kind and a row
 * here. */
const lr__integrator *const lr__integrators[] = {
    [LR_INTEGRATOR_WHITTED] = &lr__whitted,
    [LR_INTEGRATOR_PATH] = &lr__path_tracer,
    [LR_INTEGRATOR_LIGHT] = &lr__light_tracer,
    NULL,
};

_Static_assert(sizeof lr__integrators / sizeof *lr__integrators <=
                   LR__MAX_INTEGRATORS + 1,
               "raise LR__MAX_INTEGRATORS");

const lr__integrator *lr__integrator_for(lr_integrator_kind kind)
{
    for (int i = 0; lr__integrators[i] != NULL; i++)
        if (i == (int)kind)
            return lr__integrators[i];
    return NULL;
}

void lr__integrator_names(const char *names[LR__MAX_INTEGRATORS + 1])
{
    int n = 0;
    for (; lr__integrators[n] != NULL; n++)
        names[n] = lr__integrators[n]->name;
    names[n] = NULL;
}

lr_status lr__integrators_prepare(lr_scene *s, lr_error *err)
{
    LR_TRY(lr__emitters_build(s, err));
    for (int i = 0; lr__integrators[i] != NULL; i++)
        if (lr__integrators[i]->prepare != NULL)
            LR_TRY(lr__integrators[i]->prepare(s, err));
    return LR_OK;
}
