/* libFuzzer target: the .plm model loader (model/plm.c) and the model's checks of its metadata
 * and tensors (model/model.c, model/binder.c, the executors' load steps), through
 * pl_model_load_memory (the same validation as pl_model_load, without a file per input; the
 * file path's reading is covered by tests/test_model_files.sh and tests/plm_corrupt.c).
 *
 * Before loading, the header's file size (bytes 16..23) and CRC-32 (bytes 56..59) are set to
 * what the mutated input has, so that mutations reach the checks behind them; truncation and
 * checksum errors are covered by tests/plm_corrupt.c. A refused input must come with a message;
 * a model that loads is run once on a small grey frame. Seeds: tests/fuzz/corpus/plm
 * (tools/fuzz-corpus.py). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "model/plm.h"
#include "parlight.h"
#include "tests/fuzz/fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > (16u << 20)) return 0;
    uint8_t *b = malloc(size ? size : 1);
    if (!b) return 0;
    memcpy(b, data, size);
    if (size >= PL_PLM_HEADER_SIZE) {
        for (int k = 0; k < 8; k++)
            b[16 + k] = (uint8_t)((uint64_t)size >> (8 * k));
        uint32_t crc = pl_crc32(pl_crc32(0, b, 56), b + 60, size - 60);
        for (int k = 0; k < 4; k++)
            b[56 + k] = (uint8_t)(crc >> (8 * k));
    }
    pl_model *m = NULL;
    int rc = pl_model_load_memory(b, size, &m);
    free(b); /* the model keeps its own copy */
    fuzz_expect_message(rc, pl_last_error());
    if (rc < 0) return 0;
    pl_model_info info;
    if (pl_model_get_info(m, &info) < 0) abort();
    static uint8_t frame[48 * 64 * 3];
    memset(frame, 128, sizeof frame);
    pl_lighting L;
    rc = pl_estimate_rgb8(m, frame, 64, 48, 64 * 3, &L, NULL);
    fuzz_expect_message(rc, pl_last_error());
    if (rc == 0 && (L.n_lights < 1 || L.n_lights > PL_MAX_LIGHTS)) abort();
    pl_model_free(m);
    return 0;
}
