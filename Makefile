# parlight — one build for the library, the CLI and the tests.
#
#   make              build build/parlight (and build/libparlight.a)
#   make demo         install what is missing, build, run the shipped model on the sample frames
#   make test         install what is missing, build, run the whole suite (tests/run.sh)
#   make clean        remove build/
#   make BOARD=name   build for boards/name.mk (default: host)
#
# Everything is built out of tree under $(BUILD). Sources are found by directory, so a new
# file in model/, kernels/, quant/, light/ or port/ joins the library without editing this file;
# tests/*.c each become one program in $(BUILD)/tests/ (tests/run.sh runs the test_* ones).

.DEFAULT_GOAL := all
BOARD ?= host
ifeq ($(wildcard boards/$(BOARD).mk),)
$(error unknown BOARD '$(BOARD)': no boards/$(BOARD).mk (have: $(basename $(notdir $(wildcard boards/*.mk)))))
endif
include boards/$(BOARD).mk

ifeq ($(BOARD),host)
BUILD ?= build
else
BUILD ?= build/$(BOARD)
endif

PKG_CONFIG ?= pkg-config
OPENCV_CFLAGS := $(shell $(PKG_CONFIG) --cflags opencv4 2>/dev/null)
OPENCV_LIBS   := -lopencv_videoio -lopencv_imgcodecs -lopencv_imgproc -lopencv_core
EXR_CFLAGS    := $(shell $(PKG_CONFIG) --cflags OpenEXR 2>/dev/null)
EXR_LIBS      := $(shell $(PKG_CONFIG) --libs OpenEXR 2>/dev/null)
# libcamera (optional: without it port/source_libcamera.cpp builds stubs that say so)
LIBCAMERA_CFLAGS := $(shell $(PKG_CONFIG) --cflags libcamera 2>/dev/null)
LIBCAMERA_LIBS   := $(shell $(PKG_CONFIG) --libs libcamera 2>/dev/null)
ifneq ($(LIBCAMERA_LIBS),)
LIBCAMERA_CFLAGS += -DPL_HAVE_LIBCAMERA=1
endif

WARN     := -Wall -Wextra -Wshadow -Wvla -Wpointer-arith -Wstrict-prototypes -Wmissing-prototypes \
            -Wformat=2 -Wundef
OPT      ?= -O2 -g
CPPFLAGS += -Iinclude -I. -D_GNU_SOURCE
CFLAGS   += -std=c11 $(OPT) $(WARN) -fno-strict-aliasing $(BOARD_CFLAGS) -pthread
CXXFLAGS += -std=c++17 $(OPT) -Wall -Wextra -Wshadow $(BOARD_CFLAGS) -pthread \
            $(OPENCV_CFLAGS) $(EXR_CFLAGS) $(LIBCAMERA_CFLAGS)
LDLIBS   += $(OPENCV_LIBS) $(EXR_LIBS) $(LIBCAMERA_LIBS) -lstdc++ -lm -pthread

LIB_C   := $(sort $(wildcard model/*.c kernels/*.c kernels/ref/*.c quant/*.c light/*.c port/*.c))

# SIMD kernels: kernels/x86/ joins x86-64 builds, kernels/arm/ AArch64 builds. A file's ISA
# flags come from its name (nn_conv1x1_s8__avx512vnni.c): the build stays portable and
# kernels/isa.c picks the path at run time.
TARGET_ARCH_NAME := $(shell $(CC) -dumpmachine)
ifneq ($(findstring x86_64,$(TARGET_ARCH_NAME)),)
LIB_C += $(sort $(wildcard kernels/x86/*.c))
endif
ifneq ($(findstring aarch64,$(TARGET_ARCH_NAME)),)
LIB_C += $(sort $(wildcard kernels/arm/*.c))
endif
ISA_FLAGS_avx2       := -mavx2 -mfma -mf16c
ISA_FLAGS_avxvnni    := $(ISA_FLAGS_avx2) -mavxvnni
ISA_FLAGS_avx512vnni := $(ISA_FLAGS_avx2) -mavx512f -mavx512bw -mavx512dq -mavx512vl -mavx512vnni
ISA_FLAGS_amx        := $(ISA_FLAGS_avx512vnni) -mamx-tile -mamx-int8
ISA_FLAGS_neon       :=
ISA_FLAGS_dotprod    := -march=armv8.2-a+dotprod
ISA_FLAGS_i8mm       := -march=armv8.6-a+dotprod+i8mm
isa_of = $(lastword $(subst __, ,$(basename $(notdir $(1)))))
LIB_CXX := $(sort $(wildcard port/*.cpp light/*.cpp))
APP_C   := $(sort $(wildcard app/*.c))
TEST_C  := $(sort $(wildcard tests/*.c))

LIB_OBJ  := $(LIB_C:%.c=$(BUILD)/obj/%.o) $(LIB_CXX:%.cpp=$(BUILD)/obj/%.o)
APP_OBJ  := $(APP_C:%.c=$(BUILD)/obj/%.o)
TEST_BIN := $(TEST_C:tests/%.c=$(BUILD)/tests/%)
LIB      := $(BUILD)/libparlight.a
CLI      := $(BUILD)/parlight

# Models exported from seeded random weights (tools/export.py), for the tests and, until a
# trained model ships, the demo. Board-independent, so they live in build/models/.
# The camera rig's guests run a 96x128 one: the same network, 4x fewer MACs under TCG.
SEEDED := build/models/seeded-n3.plm build/models/seeded-n3-96x128.plm
build/models/seeded-n3-96x128.plm: tools/export.py tools/model.py tools/plm.py
	@mkdir -p $(dir $@)
	/usr/bin/python3 tools/export.py --n-lights 3 --seed 1 --input 96x128 --out $@ --force
build/models/seeded-n%.plm: tools/export.py tools/model.py tools/plm.py
	@mkdir -p $(dir $@)
	/usr/bin/python3 tools/export.py --n-lights $* --seed 1 --out $@ --force

.PHONY: all deps demo test tests clean format-check test-camera
all: $(CLI) tests

tests: $(TEST_BIN)

deps:
	@tools/install-deps.sh

# Kernels are where the time goes: let the compiler vectorise their inner loops fully.
$(BUILD)/obj/kernels/%.o: OPT := -O3 -g

$(BUILD)/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) $(CFLAGS) $(ISA_FLAGS_$(call isa_of,$<)) -MMD -MP -c $< -o $@

$(BUILD)/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -MMD -MP -c $< -o $@

$(LIB): $(LIB_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@
	$(AR) rcs $@ $^

$(CLI): $(APP_OBJ) $(LIB)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $(APP_OBJ) $(LIB) $(LDLIBS)

$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< $(LIB) $(LDLIBS)

# The camera rig's userspace UVC webcam (tools/camrig/uvc-gadget.c; built by tools/camrig/build.sh)
$(BUILD)/tools/uvc-gadget: $(BUILD)/obj/tools/camrig/uvc-gadget.o $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< $(LIB) $(LDLIBS)

# The demo runs whatever model is shipped; until a trained one exists it exports one from seeded
# weights into build/ and says so (tools/demo.sh).
demo:
	@tools/install-deps.sh
	@$(MAKE) --no-print-directory all
	@$(MAKE) --no-print-directory $(SEEDED)
	@BUILD=$(BUILD) tools/demo.sh

test:
	@tools/install-deps.sh
	@$(MAKE) --no-print-directory all $(SEEDED)
	@BUILD=$(BUILD) tests/run.sh

# The camera tests alone: pixel conversions, the QEMU + vivid rig and the QEMU + UVC webcam rig
# (tools/camrig, ~1.5 + 1 min).
test-camera:
	@tools/install-deps.sh
	@$(MAKE) --no-print-directory all $(SEEDED)
	@BUILD=$(BUILD) TEST_FILTER='^test_(camera|pixfmt|v4l2)' tests/run.sh

format-check:
	@git diff --name-only --diff-filter=AM HEAD -- '*.c' '*.h' '*.cpp' | xargs -r clang-format --dry-run -Werror

clean:
	rm -rf build

-include $(LIB_OBJ:.o=.d) $(APP_OBJ:.o=.d) $(TEST_C:tests/%.c=$(BUILD)/obj/tests/%.d)
