/* One core's arithmetic peak, measured: the rate of independent AVX-512 vpdpbusd (int8 VNNI,
 * 64 multiply-accumulates each) and vfmadd231ps (fp32, 16 each) on registers, 16 chains of each,
 * the best of ~1 ms runs repeated for 0.4 s each (on a busy machine most runs are interrupted;
 * the best is the one that was not). `make bench` (tools/bench/run.sh) builds and runs it so that the
 * report's "floor here" column is this machine's: a core that issues one 512-bit VNNI or FMA per
 * cycle (AMD Zen 4 splits them over two 256-bit pipes) has half the peak of one that issues two
 * (Intel Xeon with two 512-bit FMA ports), whatever its clock.
 *
 *   cc -O2 -o build/bench/peak tools/bench/peak.c && build/bench/peak
 *
 * Prints one JSON object: vnni_gmac_s, fma_gmac_s, and clock_ghz (dependent adds, one a cycle).
 * Exit 77 where the CPU or the OS lacks AVX-512 VNNI (nothing is measured). */
#include <stdio.h>
#include <time.h>

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#if defined(__x86_64__) && defined(__GNUC__)
#define X2(i) X(i) X(1##i)
#define ALL X2(2) X2(3) X2(4) X2(5) X2(6) X2(7) X2(8) X2(9)

#define AVX512 __attribute__((target("avx512f,avx512vnni")))

/* A function running n loop iterations of 16 independent `op`s (dst zmm2..9, 12..19, sources
 * zmm0 and zmm1 set by `init`); it returns seconds. */
#define X(i) OP " %%zmm0, %%zmm1, %%zmm" #i "\n"
#define PEAK_LOOP(name, init)                                                                      \
    AVX512 static double name(long n)                                                              \
    {                                                                                              \
        const double t0 = now_s();                                                                 \
        __asm__ volatile(init "vpxord %%zmm1, %%zmm1, %%zmm1\n"                                    \
                              "1:\n" ALL "dec %0\n jnz 1b\n"                                       \
                         : "+r"(n)                                                                 \
                         :                                                                         \
                         : "memory", "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6",       \
                           "xmm7", "xmm8", "xmm9", "xmm12", "xmm13", "xmm14", "xmm15", "xmm16",    \
                           "xmm17", "xmm18", "xmm19");                                             \
        return now_s() - t0;                                                                       \
    }

#define OP "vpdpbusd"
PEAK_LOOP(run_vnni, "vpternlogd $0xff, %%zmm0, %%zmm0, %%zmm0\n")
#undef OP
#define OP "vfmadd231ps"
PEAK_LOOP(run_fma, "vpxord %%zmm0, %%zmm0, %%zmm0\n")
#undef OP
#undef X

static double run_adds(long n)
{
    const double t0 = now_s();
    long c = 0;
    __asm__ volatile("1:\n add $1, %1\n add $1, %1\n add $1, %1\n add $1, %1\n dec %0\n jnz 1b\n"
                     : "+r"(n), "+r"(c)
                     :
                     : "memory");
    return now_s() - t0;
}

static double best(double (*fn)(long), long n)
{
    double b = 1e9;
    const double t0 = now_s();
    for (int r = 0; r < 10000 && now_s() - t0 < 0.4; r++) {
        const double t = fn(n);
        if (t < b) b = t;
    }
    return b;
}

int main(void)
{
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("avx512f") || !__builtin_cpu_supports("avx512vnni")) {
        fprintf(stderr, "peak: this CPU (or OS) has no AVX-512 VNNI; nothing measured\n");
        return 77;
    }
    const long n = 200000; /* 3.2 M ops: ~1-3 ms */
    const double tv = best(run_vnni, n), tf = best(run_fma, n), ta = best(run_adds, n);
    printf("{\"vnni_gmac_s\": %.1f, \"fma_gmac_s\": %.1f, \"clock_ghz\": %.2f}\n",
           (double)n * 16 * 64 / tv * 1e-9, (double)n * 16 * 16 / tf * 1e-9,
           (double)n * 4 / ta * 1e-9);
    return 0;
}
#else
int main(void)
{
    (void)now_s;
    fprintf(stderr, "peak: x86-64 only (AVX-512 VNNI and FMA)\n");
    return 77;
}
#endif
