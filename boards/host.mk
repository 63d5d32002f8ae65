# The machine that builds: native toolchain, portable baseline flags (no -march=native;
# SIMD kernels get their ISA flags per file and are picked at run time).
CC            ?= cc
CXX           ?= c++
BOARD_CFLAGS  :=
BOARD_THREADS := 2
BOARD_INPUT   := 192x256
BOARD_CAMERA  := v4l2:/dev/video0
