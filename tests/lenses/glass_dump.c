/*
 * glass_dump.c: every catalogue glass's refractive index at a few
 * wavelengths, as lensray computes it, for tests/lenses/glass.py to set
 * against opticalglass (the makers' own spreadsheets, read by another
 * program).  One line a glass: "MAKER<TAB>NAME<TAB>n(400) ... n(700)",
 * at the wavelengths of the first line, "nm<TAB><TAB>400 ...".
 */
#include "optics/prescription.h"

#include <stdio.h>

int main(void)
{
    /* 400 nm, the g, F, e, d and C lines, 700 nm. */
    static const double nm[] = {400.0,    435.8343, 486.1327, 546.074,
                                587.5618, 656.2725, 700.0};
    const size_t n_nm = sizeof nm / sizeof nm[0];
    printf("nm\t");
    for (size_t k = 0; k < n_nm; k++)
        printf("\t%.4f", nm[k]);
    printf("\n");
    for (size_t i = 0; i < lr__glass_rows; i++) {
        const lr__glass_row *row = &lr__glass_catalogue[i];
        char name[96];
        lr__glass g;
        snprintf(name, sizeof name, "%s %s", row->maker, row->name);
        if (lr__glass_find(name, NULL, &g, NULL, 0) != 0) {
            fprintf(stderr, "glass_dump: %s not found\n", name);
            return 1;
        }
        printf("%s\t%s", row->maker, row->name);
        for (size_t k = 0; k < n_nm; k++)
            printf("\t%.9f", lr__glass_n(&g, nm[k]));
        printf("\n");
    }
    return 0;
}
