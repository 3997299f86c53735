/*
 * ui.c: the page's files, served from the arrays that the build makes of
 * service/ui/ (service/ui/embed.sh -> BUILD/gen/ui_files.c), so the daemon
 * stays one binary and never reads the page from disk.  --no-ui hides
 * them all.
 */
#include "lensrayd.h"

#include <string.h>

const lrd_ui_file *lrd_ui_find(const char *path)
{
    if (lrd_cfg.no_ui)
        return NULL;
    for (const lrd_ui_file *f = lrd_ui_files; f->path != NULL; f++)
        if (strcmp(f->path, path) == 0)
            return f;
    return NULL;
}
