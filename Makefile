# parlight — one build for the library, the CLI and the tests.
#
#   make              build build/parlight, build/libparlight.a and build/libparlight.so.*
#   make install      install the CLI, the libraries, the header, parlight.pc, the plugins, the
#                     man pages and the models under PREFIX (default /usr/local), staged in
#                     DESTDIR when set (docs/LIBRARY.md)
#   make demo         install what is missing, build, run the shipped model on the sample frames
#   make test         install what is missing, build, run the whole suite (tests/run.sh)
#   make bench        parlight vs PyTorch and ONNX Runtime, same weights (tools/bench/run.sh)
#   make clean        remove build/ and build-san/
#   make BOARD=name   build for boards/name.mk (default: host)
#   make test SAN=1   the same suite built with ASan + UBSan into build-san/ (docs/TESTING.md)
#   make fuzz         libFuzzer targets (tests/fuzz/, clang) into build/fuzz/, each run
#                     FUZZ_SECONDS (default 60) from its corpus (docs/TESTING.md)
#
# The targets that build for you (demo, test, fuzz, bench, test-camera) compile on every core
# (JOBS, default nproc) unless you chose: `make -j1 test` builds one file at a time, `make -j8
# test` shares make's own job slots.
#
# Everything is built out of tree under $(BUILD). Sources are found by directory, so a new file
# in core/, model/, kernels/, quant/, light/ or port/ joins the library without editing this
# file; tests/*.c each become one program in $(BUILD)/tests/ (tests/run.sh runs the test_* ones).

.DEFAULT_GOAL := all
BOARD ?= host

# The sub-make of the targets that build for you: -j$(JOBS) unless the command line (or
# MAKEFLAGS) already holds a -j. A serial build of the suite's three trees took most of CI's time
# on a 2-core machine (docs/TESTING.md, "How long CI takes").
JOBS ?= $(shell nproc 2>/dev/null || echo 1)
SUBMAKE = $(MAKE) --no-print-directory $(if $(filter -j%,$(MAKEFLAGS)),,-j$(JOBS))

# ---- sanitizer and fuzz builds (docs/TESTING.md) ----------------------------------------------
# SAN=1: every object, the library, the CLI, the plugins and the tests are built with ASan and
#   UBSan (any undefined behaviour aborts) into build-san/, never mixed with build/.
# FUZZ=1 (what `make fuzz` sets): clang with -fsanitize=fuzzer-no-link,address,undefined into
#   build/fuzz/, host only, without OpenCV and libcamera (their plugins are not what is fuzzed).
SAN  ?= 0
FUZZ ?= 0
SAN_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
ifeq ($(FUZZ),1)
ifneq ($(BOARD),host)
$(error make fuzz builds for the host only)
endif
CC  := clang
CXX := clang++
WITH_OPENCV    := 0
WITH_LIBCAMERA := 0
SAN_FLAGS := -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer \
             -fno-sanitize-recover=undefined
BUILD := build/fuzz
else ifneq ($(SAN),1)
SAN_FLAGS :=
endif
ifeq ($(wildcard boards/$(BOARD).mk),)
$(error unknown BOARD '$(BOARD)': no boards/$(BOARD).mk (have: $(basename $(notdir $(wildcard boards/*.mk)))))
endif
include boards/$(BOARD).mk

BUILD_ROOT := $(if $(filter 1,$(SAN)),build-san,build)
ifeq ($(BOARD),host)
BUILD ?= $(BUILD_ROOT)
else
BUILD ?= $(BUILD_ROOT)/$(BOARD)
endif

# ---- optional libraries: the target's pkg-config decides (docs/PORTING.md) ---------------------
# A cross board sets BOARD_PKG_CONFIG_LIBDIR to its multiarch .pc folder, so only libraries
# installed for that architecture count. WITH_<LIB>=0 turns one off (e.g. WITH_OPENCV=0 to build
# the host without OpenCV, as a board build would be); without a library its functions return
# PL_E_UNSUPPORTED saying "this build has no ..." and the tests that need it skip.
#   libjpeg, libpng: JPEG/PNG files and MJPEG frames (port/jpeg_codec.c, port/png_codec.c)
#   OpenCV:          other image formats, videos, test fixtures (port/image_io.cpp, video_cv.cpp)
#   OpenEXR:         .exr panoramas and maps (port/exr_io.cpp)
#   libcamera:       the libcamera source (port/source_libcamera.cpp)
#   libwebsockets:   the ws:// sink (port/sink_ws.c), feature word "ws"
#   libmosquitto:    the mqtt:// sink (port/sink_mqtt.c), feature word "mqtt"
ifneq ($(BOARD_PKG_CONFIG_LIBDIR),)
PKG_CONFIG ?= PKG_CONFIG_LIBDIR=$(BOARD_PKG_CONFIG_LIBDIR) pkg-config
else
PKG_CONFIG ?= pkg-config
endif
WITH_LIBJPEG   ?= 1
WITH_LIBPNG    ?= 1
WITH_OPENCV    ?= 1
WITH_OPENEXR   ?= 1
WITH_LIBCAMERA ?= 1
WITH_LWS       ?= 1
WITH_MOSQUITTO ?= 1
# $(call pc_have,WITH_X,module): 1 when wanted and pkg-config finds it for the target
pc_have = $(if $(filter 1,$($(1))),$(shell $(PKG_CONFIG) --exists $(2) 2>/dev/null && echo 1))
HAVE_LIBJPEG   := $(call pc_have,WITH_LIBJPEG,libjpeg)
HAVE_LIBPNG    := $(call pc_have,WITH_LIBPNG,libpng)
HAVE_OPENCV    := $(call pc_have,WITH_OPENCV,opencv4)
HAVE_OPENEXR   := $(call pc_have,WITH_OPENEXR,OpenEXR)
HAVE_LIBCAMERA := $(call pc_have,WITH_LIBCAMERA,libcamera)
HAVE_LWS       := $(call pc_have,WITH_LWS,libwebsockets)
HAVE_MOSQUITTO := $(call pc_have,WITH_MOSQUITTO,libmosquitto)
FEATURE_FLAGS  := $(if $(HAVE_LIBJPEG),-DPL_HAVE_LIBJPEG=1) $(if $(HAVE_LIBPNG),-DPL_HAVE_LIBPNG=1) \
                  $(if $(HAVE_OPENCV),-DPL_HAVE_OPENCV=1) $(if $(HAVE_OPENEXR),-DPL_HAVE_OPENEXR=1) \
                  $(if $(HAVE_LIBCAMERA),-DPL_HAVE_LIBCAMERA=1) \
                  $(if $(HAVE_LWS),-DPL_HAVE_LWS=1) $(if $(HAVE_MOSQUITTO),-DPL_HAVE_MOSQUITTO=1)
FEATURES       := $(strip $(if $(HAVE_LIBJPEG),libjpeg) $(if $(HAVE_LIBPNG),libpng) \
                  $(if $(HAVE_OPENCV),opencv) $(if $(HAVE_OPENEXR),openexr) \
                  $(if $(HAVE_LIBCAMERA),libcamera) $(if $(HAVE_LWS),ws) \
                  $(if $(HAVE_MOSQUITTO),mqtt))
pc_cflags = $(if $(2),$(shell $(PKG_CONFIG) --cflags $(1) 2>/dev/null))
pc_libs   = $(if $(2),$(shell $(PKG_CONFIG) --libs $(1) 2>/dev/null))
OPENCV_CFLAGS := $(call pc_cflags,opencv4,$(HAVE_OPENCV))
OPENCV_LIBS   := $(if $(HAVE_OPENCV),-lopencv_videoio -lopencv_imgcodecs -lopencv_imgproc -lopencv_core)
EXR_CFLAGS    := $(call pc_cflags,OpenEXR,$(HAVE_OPENEXR))
EXR_LIBS      := $(call pc_libs,OpenEXR,$(HAVE_OPENEXR))
LIBCAMERA_CFLAGS := $(call pc_cflags,libcamera,$(HAVE_LIBCAMERA))
LIBCAMERA_LIBS   := $(call pc_libs,libcamera,$(HAVE_LIBCAMERA))
CODEC_CFLAGS  := $(call pc_cflags,libjpeg,$(HAVE_LIBJPEG)) $(call pc_cflags,libpng,$(HAVE_LIBPNG))
CODEC_LIBS    := $(call pc_libs,libpng,$(HAVE_LIBPNG)) $(call pc_libs,libjpeg,$(HAVE_LIBJPEG))
NET_CFLAGS    := $(call pc_cflags,libwebsockets,$(HAVE_LWS)) $(call pc_cflags,libmosquitto,$(HAVE_MOSQUITTO))
NET_LIBS      := $(call pc_libs,libwebsockets,$(HAVE_LWS)) $(call pc_libs,libmosquitto,$(HAVE_MOSQUITTO))

# ---- plugins (port/plugin.h) ------------------------------------------------------------------
# PLUGINS=1 (default): OpenCV's and libcamera's sides are built as $(BUILD)/parlight-opencv.so
# and $(BUILD)/parlight-libcamera.so, loaded with dlopen only when an input needs them (a video,
# a BMP/TIFF/... image, a libcamera camera), so that estimating on JPEG/PNG frames does not load
# ~240 shared libraries. PLUGINS=0 links them into the binary as before.
PLUGINS ?= 1
ifeq ($(PLUGINS),1)
PLUGIN_OPENCV_SRC    := $(if $(HAVE_OPENCV),port/image_io.cpp port/video_cv.cpp port/test_helpers_cv.cpp)
PLUGIN_LIBCAMERA_SRC := $(if $(HAVE_LIBCAMERA),port/source_libcamera.cpp)
endif
FEATURE_FLAGS += $(if $(PLUGIN_OPENCV_SRC),-DPL_OPENCV_PLUGIN=1) \
                 $(if $(PLUGIN_LIBCAMERA_SRC),-DPL_LIBCAMERA_PLUGIN=1)
PLUGIN_SO := $(if $(PLUGIN_OPENCV_SRC),$(BUILD)/parlight-opencv.so) \
             $(if $(PLUGIN_LIBCAMERA_SRC),$(BUILD)/parlight-libcamera.so)
CORE_LIBS := $(if $(PLUGIN_OPENCV_SRC),,$(OPENCV_LIBS)) $(EXR_LIBS) \
             $(if $(PLUGIN_LIBCAMERA_SRC),,$(LIBCAMERA_LIBS)) $(CODEC_LIBS) $(NET_LIBS) \
             $(if $(PLUGIN_SO),-ldl)

WARN     := -Wall -Wextra -Wshadow -Wvla -Wpointer-arith -Wstrict-prototypes -Wmissing-prototypes \
            -Wformat=2 -Wundef
OPT      ?= -O2 -g
CPPFLAGS += -Iinclude -I. -D_GNU_SOURCE $(FEATURE_FLAGS)
# -ffp-contract=off (what -std=c11 already means to gcc, spelled out for other compilers): the
# SIMD kernels that equal the reference bit for bit (pooling, nn_fc_w8_f32) need a*b + c to stay
# two roundings on every path; the fp32 GEMMs ask for their fused multiply-adds explicitly.
CFLAGS   += -std=c11 -ffp-contract=off $(OPT) $(WARN) -fno-strict-aliasing $(BOARD_CFLAGS) -pthread \
            $(SAN_FLAGS)
CXXFLAGS += -std=c++17 $(OPT) -Wall -Wextra -Wshadow $(BOARD_CFLAGS) -pthread \
            $(OPENCV_CFLAGS) $(EXR_CFLAGS) $(LIBCAMERA_CFLAGS) $(SAN_FLAGS)
LDFLAGS  += $(SAN_FLAGS)
LDLIBS   += $(CORE_LIBS) -lstdc++ -lm -pthread

# port/plugin_guest.c is linked into each plugin, never into the library (port/plugin.h).
LIB_C   := $(filter-out port/plugin_guest.c,\
             $(sort $(wildcard core/*.c model/*.c kernels/*.c kernels/ref/*.c quant/*.c light/*.c port/*.c)))

# SIMD kernels: kernels/x86/ joins x86-64 builds, kernels/arm/ AArch64 builds. A file's ISA
# flags come from its name, which says the instructions it needs (nn_fc_f32__avx512f.c,
# nn_conv_packed_s8_14x32c4__avx512vnni.c): the build stays portable and kernels/isa.c runs a
# file only on a path that guarantees exactly those features.
#   avx2       AVX2 + FMA                       avx512f     avx2 + AVX-512F
#   avx512skx  avx2 + AVX-512 F/BW/DQ/VL        avx512vnni  avx512skx + AVX512_VNNI
#   avxvnni    avx2 + AVX-VNNI (VEX)            amx         avx512vnni + AMX-TILE/INT8
#   neon       AArch64 baseline                 neondot     + dotprod       neoni8mm  + i8mm
TARGET_ARCH_NAME := $(shell $(CC) -dumpmachine)
ifneq ($(findstring x86_64,$(TARGET_ARCH_NAME)),)
LIB_C += $(sort $(wildcard kernels/x86/*.c))
endif
ifneq ($(findstring aarch64,$(TARGET_ARCH_NAME)),)
LIB_C += $(sort $(wildcard kernels/arm/*.c))
endif
ISA_FLAGS_avx2       := -mavx2 -mfma
ISA_FLAGS_avx512f    := $(ISA_FLAGS_avx2) -mavx512f
ISA_FLAGS_avx512skx  := $(ISA_FLAGS_avx512f) -mavx512bw -mavx512dq -mavx512vl
ISA_FLAGS_avx512vnni := $(ISA_FLAGS_avx512skx) -mavx512vnni
ISA_FLAGS_avxvnni    := $(ISA_FLAGS_avx2) -mavxvnni
ISA_FLAGS_amx        := $(ISA_FLAGS_avx512vnni) -mamx-tile -mamx-int8
ISA_FLAGS_neon       :=
ISA_FLAGS_neondot    := -march=armv8.2-a+dotprod
ISA_FLAGS_neoni8mm   := -march=armv8.6-a+dotprod+i8mm
isa_of = $(lastword $(subst __, ,$(basename $(notdir $(1)))))
LIB_CXX := $(filter-out $(PLUGIN_OPENCV_SRC) $(PLUGIN_LIBCAMERA_SRC),\
                        $(sort $(wildcard port/*.cpp light/*.cpp)))
# The AMX kernel with its tiles emulated is for tests/test_kernels_simd_s8.c only: linked into
# that test, not into the library, so no program pays for it and `make fuzz` never compiles it
# (clang with the fuzzer's sanitizers takes minutes over its fully unrolled tiles).
KERNEL_TEST_C := $(filter %_amxemu__avx512vnni.c,$(LIB_C))
LIB_C   := $(filter-out $(KERNEL_TEST_C),$(LIB_C))
APP_C   := $(sort $(wildcard app/*.c))
TEST_C  := $(sort $(wildcard tests/*.c))
FUZZ_C  := $(sort $(wildcard tests/fuzz/fuzz_*.c))

LIB_OBJ  := $(LIB_C:%.c=$(BUILD)/obj/%.o) $(LIB_CXX:%.cpp=$(BUILD)/obj/%.o)
APP_OBJ  := $(APP_C:%.c=$(BUILD)/obj/%.o)
TEST_BIN := $(TEST_C:tests/%.c=$(BUILD)/tests/%)
# Each fuzz target twice: under libFuzzer in build/fuzz/ (make fuzz), and in every other build
# with tests/fuzz/replay.c as its main, which runs it once on every input of its corpus
# (tests/test_fuzz_corpus.sh: the regression inputs are replayed by `make test`, no clang needed).
FUZZ_BIN   := $(FUZZ_C:tests/fuzz/%.c=$(BUILD)/%)
REPLAY_BIN := $(FUZZ_C:tests/fuzz/%.c=$(BUILD)/tests/fuzz/%)
LIB      := $(BUILD)/libparlight.a
CLI      := $(BUILD)/parlight

# The shared library (docs/LIBRARY.md): the same sources compiled again with -fPIC and
# -fvisibility=hidden into $(BUILD)/pic/ (the static objects, the CLI and the tests are not
# touched), exporting only what include/parlight.h marks PL_API (include/parlight.map: pl_*
# names only). SONAME libparlight.so.MAJOR, MAJOR being PARLIGHT_VERSION_MAJOR. SHARED=0 skips it;
# SAN=1 does by default (no test loads a sanitized libparlight.so: an app without the sanitizer
# runtime cannot, and it would double the sanitizer build), SHARED=1 SAN=1 builds it anyway.
SHARED ?= $(if $(filter 1,$(SAN)),0,1)
PL_VERSION := $(shell sed -n 's/^\#define PARLIGHT_VERSION "\(.*\)"/\1/p' include/parlight.h)
PL_MAJOR   := $(firstword $(subst ., ,$(PL_VERSION)))
SONAME     := libparlight.so.$(PL_MAJOR)
SHLIB      := $(BUILD)/libparlight.so.$(PL_VERSION)
LIB_PIC_OBJ := $(LIB_C:%.c=$(BUILD)/pic/%.o) $(LIB_CXX:%.cpp=$(BUILD)/pic/%.o)
SHLIB_ALL  := $(if $(filter 1,$(SHARED)),$(SHLIB) $(BUILD)/$(SONAME) $(BUILD)/libparlight.so)

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

.PHONY: all deps demo test tests clean format-check test-camera bench fuzz fuzz-build FORCE \
        install uninstall
all: $(CLI) tests $(BUILD)/features $(PLUGIN_SO) $(SHLIB_ALL) $(BUILD)/tools/zdump

# The optional libraries this build has, one word each (tests/run.sh skips the tests that need
# a missing one); rewritten only when the list changes.
$(BUILD)/features: FORCE
	@mkdir -p $(dir $@)
	@echo '$(FEATURES)' | cmp -s - $@ || echo '$(FEATURES)' > $@

tests: $(TEST_BIN) $(REPLAY_BIN)

deps:
	@BOARD=$(BOARD) tools/install-deps.sh

# Kernels are where the time goes: let the compiler vectorise their inner loops fully.
$(BUILD)/obj/kernels/%.o $(BUILD)/pic/kernels/%.o: OPT := -O3 -g

# Test programs may need a workaround on a board's compiler (boards/*.mk, BOARD_TEST_CFLAGS).
$(BUILD)/obj/tests/%.o: CFLAGS += $(BOARD_TEST_CFLAGS)

# Codec files see their libraries' headers (libpng16's live in a subfolder).
$(BUILD)/obj/port/png_codec.o $(BUILD)/obj/port/jpeg_codec.o: CFLAGS += $(CODEC_CFLAGS)
$(BUILD)/obj/port/sink_ws.o $(BUILD)/obj/port/sink_mqtt.o: CFLAGS += $(NET_CFLAGS)
# parlight view serves the viewer page from the source tree (--www overrides it).
$(BUILD)/obj/app/cmd_view.o: CFLAGS += -DPL_VIEWER_DIR='"$(CURDIR)/app/viewer"'
$(BUILD)/pic/port/png_codec.o $(BUILD)/pic/port/jpeg_codec.o: CFLAGS += $(CODEC_CFLAGS)
$(BUILD)/pic/port/sink_ws.o $(BUILD)/pic/port/sink_mqtt.o: CFLAGS += $(NET_CFLAGS)

$(BUILD)/obj/%.o: %.c $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) $(CFLAGS) $(ISA_FLAGS_$(call isa_of,$<)) -MMD -MP -c $< -o $@

ifeq ($(FUZZ),1)
# The x86 SIMD micro-kernels build without ASan and UBSan in the fuzz build (coverage stays):
# clang took 339 s on nn_conv_packed_s8_14x32c4__avx512vnni.c and 553 s on the AMX kernel with
# them, 6 s without (2026-12-07, AMD EPYC), most of `make fuzz`. They read and write only the
# buffers that instrumented code (the executors, kernels/*.c packing) sized from the model, and
# their own memory safety is checked by `make test SAN=1` (gcc ASan + UBSan, test_kernels_simd_*
# over edge shapes) and by bit-exactness against kernels/ref/ (instrumented here too).
$(BUILD)/obj/kernels/x86/%.o: CFLAGS += -fno-sanitize=address,undefined
endif

$(BUILD)/obj/%.o: %.cpp $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/pic/%.o: %.c $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) $(CFLAGS) $(ISA_FLAGS_$(call isa_of,$<)) -fPIC -fvisibility=hidden \
	    -MMD -MP -c $< -o $@

$(BUILD)/pic/%.o: %.cpp $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -fPIC -fvisibility=hidden -fvisibility-inlines-hidden \
	    -MMD -MP -c $< -o $@

# Linked by the C++ driver (port/exr_io.cpp needs its runtime); --no-undefined: every symbol the
# library uses is in it or in the libraries named here.
$(SHLIB): $(LIB_PIC_OBJ) include/parlight.map
	$(CXX) -shared -Wl,-soname,$(SONAME) -Wl,--version-script=include/parlight.map \
	    -Wl,--no-undefined $(LDFLAGS) -o $@ $(LIB_PIC_OBJ) $(CORE_LIBS) -lm -pthread
$(BUILD)/$(SONAME): $(SHLIB)
	ln -sf $(notdir $<) $@
$(BUILD)/libparlight.so: $(BUILD)/$(SONAME)
	ln -sf $(notdir $<) $@

# Plugins: position-independent objects, linked against their library. They call the core
# through the table the loader hands them (port/plugin.h, port/plugin_guest.c), so they resolve
# nothing from whatever loads them: the static CLI and apps linked either way load the same file.
$(BUILD)/obj-pic/%.o: %.cpp $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -fPIC -MMD -MP -c $< -o $@

$(BUILD)/obj-pic/%.o: %.c $(BUILD)/features
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) $(CFLAGS) -fPIC -MMD -MP -c $< -o $@

PLUGIN_GUEST := $(BUILD)/obj-pic/port/plugin_guest.o
$(BUILD)/parlight-opencv.so: $(PLUGIN_OPENCV_SRC:%.cpp=$(BUILD)/obj-pic/%.o) $(PLUGIN_GUEST)
	$(CXX) -shared -Wl,-Bsymbolic -Wl,--no-undefined $(LDFLAGS) -o $@ $^ $(OPENCV_LIBS) -lm -pthread

$(BUILD)/parlight-libcamera.so: $(PLUGIN_LIBCAMERA_SRC:%.cpp=$(BUILD)/obj-pic/%.o) $(PLUGIN_GUEST)
	$(CXX) -shared -Wl,-Bsymbolic -Wl,--no-undefined $(LDFLAGS) -o $@ $^ $(LIBCAMERA_LIBS) -lm -pthread

$(LIB): $(LIB_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@
	$(AR) rcs $@ $^

$(CLI): $(APP_OBJ) $(LIB)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $(APP_OBJ) $(LIB) $(LDLIBS)

$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $< $(LIB) $(LDLIBS)

$(BUILD)/tests/test_kernels_simd_s8: $(BUILD)/obj/tests/test_kernels_simd_s8.o \
                                     $(KERNEL_TEST_C:%.c=$(BUILD)/obj/%.o) $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $(filter %.o,$^) $(LIB) $(LDLIBS)

$(BUILD)/tests/fuzz/%: $(BUILD)/obj/tests/fuzz/%.o $(BUILD)/obj/tests/fuzz/replay.o $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $^ $(LDLIBS)

# linked by the C++ driver: UBSan's C++ checks in port/exr_io.cpp need its C++ runtime
$(BUILD)/fuzz_%: $(BUILD)/obj/tests/fuzz/fuzz_%.o $(LIB)
	$(CXX) $(CXXFLAGS) $(LDFLAGS) -fsanitize=fuzzer -o $@ $< $(LIB) $(LDLIBS)

# The int8 (or float) executor's latent z of a list of frames, for tools/train/heads.py --int8
$(BUILD)/tools/zdump: $(BUILD)/obj/tools/train/zdump.o $(LIB)
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
	@$(SUBMAKE) all
	@$(SUBMAKE) $(SEEDED)
	@BUILD=$(BUILD) tools/demo.sh

# On a cross board the programs run under the board's BOARD_RUNNER (qemu-aarch64 with its CPU
# model); BOARD_TESTS (a grep pattern on test names) narrows what runs when set, and
# BOARD_TEST_ENV (VAR=value ...) sizes the heavy tests for the emulator.
# SAN=1 runs the suite on build-san/ with the sanitizers' options below; tests/run.sh skips the
# tests that only run Python or boot VMs there (PL_SAN, and the reason it prints).
SAN_ENV := $(if $(filter 1,$(SAN)),PL_SAN=1 \
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp)
test:
	@BOARD=$(BOARD) tools/install-deps.sh
	@$(SUBMAKE) all $(SEEDED)
	@$(BOARD_TEST_ENV) $(SAN_ENV) BUILD=$(BUILD) PL_RUNNER='$(BOARD_RUNNER)' \
	    TEST_FILTER='$(or $(value TEST_FILTER),$(BOARD_TESTS))' tests/run.sh

# libFuzzer: builds build/fuzz/fuzz_<target> for every tests/fuzz/fuzz_<target>.c and runs each
# FUZZ_SECONDS from tests/fuzz/corpus/<target>/ (new inputs go to build/fuzz/corpus/<target>/,
# crashes to build/fuzz/artifacts/<target>/; tests/fuzz/run.sh), FUZZ_JOBS targets at once (one
# core each; default JOBS). FUZZ_TARGETS narrows the list.
FUZZ_SECONDS ?= 60
FUZZ_JOBS ?= $(JOBS)
FUZZ_TARGETS ?= $(FUZZ_C:tests/fuzz/fuzz_%.c=%)
fuzz:
	@BOARD=host tools/install-deps.sh
	@$(SUBMAKE) FUZZ=1 fuzz-build
	@FUZZ_SECONDS=$(FUZZ_SECONDS) FUZZ_JOBS=$(FUZZ_JOBS) tests/fuzz/run.sh $(FUZZ_TARGETS)

fuzz-build: $(FUZZ_BIN)

# The camera tests alone: pixel conversions, the QEMU + vivid rig and the QEMU + UVC webcam rig
# (tools/camrig, ~1.5 + 1 min).
test-camera:
	@tools/install-deps.sh
	@$(SUBMAKE) all $(SEEDED)
	@BUILD=$(BUILD) TEST_FILTER='^test_(camera|pixfmt|v4l2)' tests/run.sh

# parlight fp32/int8 at 1 and 2 threads against PyTorch and ONNX Runtime (npm) on the same weights:
# a table on stdout and JSON in build/bench/ (docs/PERFORMANCE.md, "Benchmark"; a few minutes).
bench:
	@tools/install-deps.sh
	@$(SUBMAKE) $(CLI) build/models/seeded-n3.plm
	@BUILD=$(BUILD) tools/bench/run.sh

# Raspberry Pi 4, Pi 5 and Jetson Orin frame times predicted here, without a board: qemu counts the
# instructions of a real frame, llvm-mca prices each block for the board's core
# (tools/bench/arm/run.sh; docs/PERFORMANCE.md, "Arm predicted by simulation"; ~15 min).
.PHONY: bench-arm
bench-arm:
	@BOARD=rpi5 tools/install-deps.sh
	@tools/bench/arm/run.sh
# ---- install (docs/LIBRARY.md) ------------------------------------------------------------------
# GNU layout under PREFIX, every path staged under DESTDIR when set (packaging): nothing is
# written outside $(DESTDIR)$(PREFIX). The plugins go to LIBDIR/parlight, where both the CLI
# (BINDIR/../lib/parlight) and libparlight.so (its own folder + /parlight) look for them; the
# models to DATADIR/parlight/models. parlight.pc's prefix is PREFIX, not DESTDIR.
PREFIX     ?= /usr/local
BINDIR     ?= $(PREFIX)/bin
LIBDIR     ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
DATADIR    ?= $(PREFIX)/share
MANDIR     ?= $(DATADIR)/man
INSTALL    ?= install
# What a static link needs besides libparlight.a (pkg-config --static --libs parlight).
PC_LIBS_PRIVATE := $(strip $(CORE_LIBS) -lstdc++ -lm -pthread)
MODEL_FILES := $(wildcard models/*.plm models/*.json) models/MODEL_CARD.md

# rewritten only when its text changes (PREFIX, LIBDIR, ... are part of it)
$(BUILD)/parlight.pc: FORCE
	@mkdir -p $(dir $@)
	@printf '%s\n' 'prefix=$(PREFIX)' 'libdir=$(LIBDIR)' 'includedir=$(INCLUDEDIR)' \
	    'modeldir=$(DATADIR)/parlight/models' '' 'Name: parlight' \
	    'Description: indoor lighting estimation from one camera frame (N lights + ambient)' \
	    'Version: $(PL_VERSION)' 'Cflags: -I$${includedir}' 'Libs: -L$${libdir} -lparlight' \
	    'Libs.private: $(PC_LIBS_PRIVATE)' >$@.tmp
	@cmp -s $@.tmp $@ && rm -f $@.tmp || mv -f $@.tmp $@

install: $(CLI) $(LIB) $(SHLIB_ALL) $(PLUGIN_SO) $(BUILD)/parlight.pc
	$(INSTALL) -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR) \
	    $(DESTDIR)$(MANDIR)/man1 $(DESTDIR)$(MANDIR)/man3 $(DESTDIR)$(DATADIR)/parlight/models \
	    $(DESTDIR)$(DATADIR)/doc/parlight
	$(INSTALL) -m 755 $(CLI) $(DESTDIR)$(BINDIR)/parlight
	$(INSTALL) -m 644 $(LIB) $(DESTDIR)$(LIBDIR)/libparlight.a
ifeq ($(SHARED),1)
	$(INSTALL) -m 755 $(SHLIB) $(DESTDIR)$(LIBDIR)/$(notdir $(SHLIB))
	ln -sf $(notdir $(SHLIB)) $(DESTDIR)$(LIBDIR)/$(SONAME)
	ln -sf $(SONAME) $(DESTDIR)$(LIBDIR)/libparlight.so
endif
ifneq ($(PLUGIN_SO),)
	$(INSTALL) -d $(DESTDIR)$(LIBDIR)/parlight
	$(INSTALL) -m 755 $(PLUGIN_SO) $(DESTDIR)$(LIBDIR)/parlight/
endif
	$(INSTALL) -m 644 include/parlight.h $(DESTDIR)$(INCLUDEDIR)/parlight.h
	$(INSTALL) -m 644 $(BUILD)/parlight.pc $(DESTDIR)$(LIBDIR)/pkgconfig/parlight.pc
	$(INSTALL) -m 644 docs/man/parlight.1 $(DESTDIR)$(MANDIR)/man1/parlight.1
	$(INSTALL) -m 644 docs/man/parlight.3 $(DESTDIR)$(MANDIR)/man3/parlight.3
	$(INSTALL) -m 644 $(MODEL_FILES) $(DESTDIR)$(DATADIR)/parlight/models/
	$(INSTALL) -m 644 LICENSE $(DESTDIR)$(DATADIR)/doc/parlight/LICENSE

uninstall:
	rm -f $(DESTDIR)$(BINDIR)/parlight $(DESTDIR)$(LIBDIR)/libparlight.a \
	    $(DESTDIR)$(LIBDIR)/libparlight.so* $(DESTDIR)$(INCLUDEDIR)/parlight.h \
	    $(DESTDIR)$(LIBDIR)/pkgconfig/parlight.pc $(DESTDIR)$(MANDIR)/man1/parlight.1 \
	    $(DESTDIR)$(MANDIR)/man3/parlight.3
	rm -rf $(DESTDIR)$(LIBDIR)/parlight $(DESTDIR)$(DATADIR)/parlight $(DESTDIR)$(DATADIR)/doc/parlight

format-check:
	@git diff --name-only --diff-filter=AM HEAD -- '*.c' '*.h' '*.cpp' | xargs -r clang-format --dry-run -Werror

clean:
	rm -rf build build-san

-include $(PLUGIN_OPENCV_SRC:%.cpp=$(BUILD)/obj-pic/%.d) $(PLUGIN_LIBCAMERA_SRC:%.cpp=$(BUILD)/obj-pic/%.d) \
         $(PLUGIN_GUEST:.o=.d) $(LIB_PIC_OBJ:.o=.d)
-include $(LIB_OBJ:.o=.d) $(APP_OBJ:.o=.d) $(TEST_C:tests/%.c=$(BUILD)/obj/tests/%.d) \
         $(KERNEL_TEST_C:%.c=$(BUILD)/obj/%.d) $(FUZZ_C:%.c=$(BUILD)/obj/%.d) \
         $(BUILD)/obj/tests/fuzz/replay.d
