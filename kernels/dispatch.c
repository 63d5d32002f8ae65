/* The kernel table (kernels/dispatch.h). */
#include "kernels/dispatch.h"

#include <pthread.h>
#include <stdio.h>

#include "core/util.h"

int pl_kernels_for(pl_isa isa, pl_kernels *out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_kernels_for: out is NULL");
    if (!pl_isa_supported(isa))
        return pl_error(PL_E_UNSUPPORTED, "instruction-set path '%s' not available on this CPU",
                        pl_isa_name(isa));
    out->isa = isa;
    pl_kernels_s8_fill(&out->s8, isa);
    pl_kernels_f32_fill(&out->f32, isa);
    return PL_OK;
}

static pl_kernels table;
static int table_rc;
static char table_err[256];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

static void fill_table(void)
{
    pl_isa isa;
    table_rc = pl_isa_select(&isa);
    if (table_rc == PL_OK) table_rc = pl_kernels_for(isa, &table);
    if (table_rc < 0) snprintf(table_err, sizeof table_err, "%s", pl_last_error());
}

int pl_kernels_get(const pl_kernels **out)
{
    pthread_once(&table_once, fill_table);
    if (table_rc < 0) return pl_error(table_rc, "%s", table_err);
    *out = &table;
    return PL_OK;
}
