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
BOARD_RUNNER   := qemu-aarch64 -cpu $(BOARD_QEMU_CPU) -L /usr/aarch64-linux-gnu
# Debian 12's aarch64 gcc 12.2 crashes (ICE in vect_transform_reduction) when it vectorises an
# fmax() reduction over doubles, a pattern the tests use (test_sg.c, test_eval.c): no loop
# vectorisation for the test programs only; the library and kernels keep it.
BOARD_TEST_CFLAGS := -fno-tree-loop-vectorize
