# NVIDIA Jetson Orin (Nano/NX/AGX): Cortex-A78AE (Armv8.2-A, NEON + dotprod; no i8mm: that is
# Armv8.6), 6 to 12 cores (6 on the Orin Nano), CSI cameras through V4L2 (Argus aside).
# Cross-built with gcc-aarch64-linux-gnu. qemu 7.2 has no Cortex-A78 model: tests run on
# neoverse-n1, the closest it has (Armv8.2-A + dotprod, no i8mm, the A76's core).
BOARD_ARCH     := aarch64
BOARD_CPU      := cortex-a78ae
CROSS_COMPILE  ?= aarch64-linux-gnu-
CC             := $(CROSS_COMPILE)gcc
CXX            := $(CROSS_COMPILE)g++
AR             := $(CROSS_COMPILE)ar
BOARD_CFLAGS   := -march=armv8.2-a -mtune=cortex-a78ae
BOARD_THREADS  := 6
BOARD_INPUT    := 192x256
BOARD_CAMERA   := v4l2:/dev/video0
BOARD_PKG_CONFIG_LIBDIR := /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig
BOARD_DEB_ARCH := arm64
BOARD_QEMU_CPU := neoverse-n1
# tools/bench/arm/predict.py (make bench-arm, docs/PERFORMANCE.md "Arm predicted by simulation"):
# the Orin Nano's A78AE at 1.5 GHz (1.73 in its "super" mode; NX 2.0, AGX 2.2), LPDDR5 on a
# 128-bit bus (68 GB/s peak, shared with the GPU; ~25 GB/s for the CPU cluster). llvm-mca has no
# Cortex-A78 model (-mcpu=cortex-a78 falls back to the A57's): Neoverse N1's stands in (the same
# two 128-bit ASIMD pipes with sdot on both; the A78's front end is wider, so this errs slow).
BOARD_PREDICT_CLOCK_GHZ := 1.5
BOARD_PREDICT_DRAM_GBS  := 25
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
BOARD_TESTS    := ^test_(arm_qemu_cpus|crop|eval|extract|extract_real|hdr_io|image_io|image_codec|json|kernels_s8|kernels_simd_s8|kernels_simd_f32|pixfmt|quant_fold|relight|render|requant|resize|sg|sh|source|temporal|nn_vectors|golden|isa_exact|model_files)(\.sh)?$
BOARD_TEST_ENV := PL_GOLDEN_N=3 PL_GOLDEN_MAX_FRAMES=2
