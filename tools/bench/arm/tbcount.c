/* A qemu-user TCG plugin for tools/bench/arm/predict.py: counts how often each translation block
 * (TB) runs and writes, at exit, one line per TB that ran: "vaddr n_insns count" (hex, decimal,
 * decimal), after a header line "start_code <hex>" (where the guest program's text was loaded,
 * so that addresses map back to the ELF file's symbols).
 *
 *   qemu-aarch64 -plugin build/tbcount.so,out=FILE -cpu cortex-a76 ... prog args
 *
 * Debian 12's qemu 7.2 is built with plugin support but ships neither qemu-plugin.h nor the
 * contrib plugins, so the few declarations used here are written out below, as
 * include/qemu/qemu-plugin.h of qemu 7.2 has them (plugin API version 1). The counter is an
 * inline add per TB, not a callback: one thread only (qemu 7.2 user mode hangs with two here,
 * docs/PORTING.md), so the plain adds are exact. */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct {
    const char *target_name;
    struct {
        int min, cur;
    } version;
    bool system_emulation;
    union {
        struct {
            int smp_vcpus, max_vcpus;
        } system;
    };
} qemu_info_t;
struct qemu_plugin_tb;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
uint64_t qemu_plugin_start_code(void);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

/* One record per (vaddr, n_insns): a TB retranslated with the same extent adds to the same one. */
typedef struct rec {
    uint64_t vaddr, count;
    size_t n;
    struct rec *next;
} rec;
enum { NBUCKET = 1 << 16 };
static rec *bucket[NBUCKET];
static char out_path[4096];

static rec *find(uint64_t vaddr, size_t n)
{
    const size_t h = (size_t)((vaddr >> 2) ^ (vaddr >> 18)) & (NBUCKET - 1);
    for (rec *r = bucket[h]; r; r = r->next)
        if (r->vaddr == vaddr && r->n == n) return r;
    rec *r = calloc(1, sizeof *r);
    if (!r) abort();
    r->vaddr = vaddr;
    r->n = n;
    r->next = bucket[h];
    bucket[h] = r;
    return r;
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    rec *r = find(qemu_plugin_tb_vaddr(tb), qemu_plugin_tb_n_insns(tb));
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &r->count, 1);
}

static void write_counts(qemu_plugin_id_t id, void *p)
{
    (void)id;
    (void)p;
    FILE *f = fopen(out_path, "w");
    if (!f) return;
    fprintf(f, "start_code %" PRIx64 "\n", qemu_plugin_start_code());
    for (size_t h = 0; h < NBUCKET; h++)
        for (const rec *r = bucket[h]; r; r = r->next)
            if (r->count) fprintf(f, "%" PRIx64 " %zu %" PRIu64 "\n", r->vaddr, r->n, r->count);
    fclose(f);
}

__attribute__((visibility("default"))) int
qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv);
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    snprintf(out_path, sizeof out_path, "tbcount.txt");
    for (int i = 0; i < argc; i++)
        if (strncmp(argv[i], "out=", 4) == 0)
            snprintf(out_path, sizeof out_path, "%s", argv[i] + 4);
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, write_counts, NULL);
    return 0;
}
