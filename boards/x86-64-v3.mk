# x86-64-v3 PCs (Haswell and later, Zen 1 and later): the whole build may use AVX2, FMA, BMI2
# and F16C; the AVX-512 / AVX-VNNI / AMX kernels keep their per-file flags and run-time dispatch.
# Native toolchain: the binaries run here (this machine is v4), no runner.
BOARD_ARCH     := x86_64
BOARD_CPU      := x86-64-v3
CC             := gcc
CXX            := g++
BOARD_CFLAGS   := -march=x86-64-v3 -mtune=generic
BOARD_THREADS  := 4
BOARD_INPUT    := 192x256
BOARD_CAMERA   := v4l2:/dev/video0
