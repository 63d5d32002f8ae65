# Raspberry Pi 5: Cortex-A76 (Armv8.2-A, NEON + dotprod; no i8mm), 4 cores, camera through
# libcamera (the Pi's CSI cameras) with a V4L2 webcam as the usual alternative.
# Cross-built with gcc-aarch64-linux-gnu; tests run under qemu-aarch64 -cpu cortex-a76.
BOARD_ARCH     := aarch64
BOARD_CPU      := cortex-a76
CROSS_COMPILE  ?= aarch64-linux-gnu-
CC             := $(CROSS_COMPILE)gcc
CXX            := $(CROSS_COMPILE)g++
AR             := $(CROSS_COMPILE)ar
BOARD_CFLAGS   := -march=armv8.2-a -mtune=cortex-a76
BOARD_THREADS  := 4
BOARD_INPUT    := 192x256
BOARD_CAMERA   := libcamera:0
BOARD_PKG_CONFIG_LIBDIR := /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig
BOARD_DEB_ARCH := arm64
BOARD_QEMU_CPU := cortex-a76
# tools/bench/arm/predict.py (make bench-arm, docs/PERFORMANCE.md "Arm predicted by simulation"):
# the A76 at 2.4 GHz, LPDDR4X-4267 on a 32-bit bus (17 GB/s peak; ~9 GB/s sustained). llvm-mca has
# no Cortex-A76 model of its own (-mcpu=cortex-a76 falls back to the A57's): Neoverse N1 is the
# A76's core (same pipelines: two 128-bit ASIMD, sdot on both).
BOARD_PREDICT_CLOCK_GHZ := 2.4
BOARD_PREDICT_DRAM_GBS  := 9
BOARD_PREDICT_MCA_CPU   := neoverse-n1
BOARD_PREDICT_ISA       := dotprod
BOARD_RUNNER   := qemu-aarch64 -cpu $(BOARD_QEMU_CPU) -L /usr/aarch64-linux-gnu
# Debian 12's aarch64 gcc 12.2 crashes (ICE in vect_transform_reduction) when it vectorises an
# fmax() reduction over doubles, a pattern the tests use (test_sg.c, test_eval.c): no loop
# vectorisation for the test programs only; the library and kernels keep it.
BOARD_TEST_CFLAGS := -fno-tree-loop-vectorize
# What `make test BOARD=...` runs under qemu (docs/PORTING.md): the unit tests, the CMSIS-NN golden
# vectors, the float network against PyTorch (N = 3, 2 frames), the int8 network's byte-identity
# across ISAs (one thread), the Arm int8 kernels under -cpu max (i8mm) and cortex-a72, and
# model-file validation. Not run: the sink and V4L2 unit tests (OS interfaces, the same code on
# every Linux: qemu-user does not emulate V4L2 ioctls, and Debian 12's qemu-aarch64 7.2 hangs
# here in any program that starts a second thread, docs/PORTING.md) and the CLI/pipeline tests
# (covered natively). Names end with (\.sh)?$ so test_eval does not pull in test_eval_cli.sh.
BOARD_TESTS    := ^test_(arm_qemu_cpus|crop|eval|extract|extract_real|hdr_io|image_io|image_codec|json|kernels_s8|kernels_simd_s8|kernels_simd_f32|pixfmt|quant_fold|relight|render|requant|resize|sg|sh|source|temporal|fuse|nn_vectors|golden|isa_exact|model_files)(\.sh)?$
BOARD_TEST_ENV := PL_GOLDEN_N=3 PL_GOLDEN_MAX_FRAMES=2
