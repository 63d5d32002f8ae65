# x86-64-v4 machines (Skylake-SP / Ice Lake / Sapphire Rapids, Zen 4): AVX-512 F/BW/DQ/VL/CD
# for the whole build; VNNI and AMX kernels still come from their per-file flags and dispatch.
# Native toolchain, no runner (needs an AVX-512 host to run the tests: this machine has one).
BOARD_ARCH     := x86_64
BOARD_CPU      := x86-64-v4
CC             := gcc
CXX            := g++
BOARD_CFLAGS   := -march=x86-64-v4 -mtune=generic
BOARD_THREADS  := 2
BOARD_INPUT    := 192x256
BOARD_CAMERA   := v4l2:/dev/video0
