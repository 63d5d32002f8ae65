# Raspberry Pi 4: Cortex-A72 (Armv8.0-A, NEON; no dotprod, no i8mm), 4 cores.
# Cross-built on the host with Debian's gcc-aarch64-linux-gnu; tests run under qemu-aarch64
# with the same CPU model (make test BOARD=rpi4). See docs/PORTING.md.
BOARD_ARCH     := aarch64
BOARD_CPU      := cortex-a72
CROSS_COMPILE  ?= aarch64-linux-gnu-
CC             := $(CROSS_COMPILE)gcc
CXX            := $(CROSS_COMPILE)g++
AR             := $(CROSS_COMPILE)ar
# Baseline ISA of the board for the whole build; kernels/arm/*__neondot.c / __neoni8mm.c add their
# own -march per file and are only dispatched when the CPU reports the feature.
BOARD_CFLAGS   := -march=armv8-a+crc -mtune=cortex-a72
BOARD_THREADS  := 4
BOARD_INPUT    := 192x256
BOARD_CAMERA   := v4l2:/dev/video0
# The target's libraries (Debian multiarch arm64 -dev packages) decide the optional features.
BOARD_PKG_CONFIG_LIBDIR := /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig
BOARD_DEB_ARCH := arm64
# How tests run on this machine: user-mode emulation of the board's CPU.
BOARD_QEMU_CPU := cortex-a72
# tools/bench/arm/predict.py (make bench-arm, docs/PERFORMANCE.md "Arm predicted by simulation"):
# the Pi 4 B's A72 at 1.8 GHz (1.5 GHz on boards before rev 1.4 / 2020 firmware), LPDDR4-3200 on a
# 32-bit bus (12.8 GB/s peak; ~4 GB/s is what one core streams), the A72 as llvm-mca models it
# (LLVM's Cortex-A57 model: the A72 is its revision, same F0/F1 ASIMD pipes).
BOARD_PREDICT_CLOCK_GHZ := 1.8
BOARD_PREDICT_DRAM_GBS  := 4
BOARD_PREDICT_MCA_CPU   := cortex-a72
BOARD_PREDICT_ISA       := neon
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
