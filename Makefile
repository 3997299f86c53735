# lensray: the one entry point.  `make` builds the library and the CLI,
# `make test` runs every test, `make render` renders the default scene.
# Everything generated goes under build/ (and scenes/meshes/*.obj, which
# is fetched, never committed).

PREFIX   ?= /usr/local
BUILD    ?= build
CC       ?= cc
OPT      ?= -O2
SANITIZE ?=
# Empty: the SIMD functions are compiled for AVX-512, AVX2 and the
# baseline, and the CPU picks (target_clones, __builtin_cpu_supports).
# make test-isa's second build sets it to SIMD_BASE: the baseline code
# alone, as a CPU without AVX2 runs it.
SIMD     ?=
SIMD_BASE = -D'target_clones(...)=unused' -D'__builtin_cpu_supports(x)=0'
# And to SIMD_AVX2: every clone and run-time choice takes its AVX2 code,
# as a CPU with AVX2 and without AVX-512 runs it (for a CPU that has
# AVX2, whatever else it has).
SIMD_AVX2 = -D'target_clones(...)=target("avx2")' \
            -D'__builtin_cpu_supports(x)=(__builtin_strcmp((x), "avx2") == 0)'

VERSION  := 0.1.0
SOMAJOR  := 0

# What the build and the tests need: a file or a command, and the Debian 12
# package that provides it.  Commands are checked as commands, so that a
# node/npm installed some other way counts too.
DEPS := /usr/include/embree3/rtcore.h:libembree-dev \
        /usr/include/OpenEXR/openexr.h:libopenexr-dev \
        /usr/include/cjson/cJSON.h:libcjson-dev \
        /usr/include/assimp/cimport.h:libassimp-dev \
        /usr/include/png.h:libpng-dev \
        /usr/include/jpeglib.h:libjpeg62-turbo-dev \
        /usr/include/libdeflate.h:libdeflate-dev \
        /usr/include/microhttpd.h:libmicrohttpd-dev \
        /usr/include/openssl/evp.h:libssl-dev \
        /usr/include/cmocka.h:libcmocka-dev \
        curl-config:libcurl4-openssl-dev \
        /usr/sbin/nginx:nginx \
        pkg-config:pkg-config bats:bats curl:curl node:nodejs npm:npm \
        python3:python3 /usr/share/i18n/locales/de_DE:locales \
        clang-format:clang-format

# Recursive (=) so that pkg-config runs after the dependency check.
PKG_CFLAGS = $(shell pkg-config --cflags OpenEXR libcjson libpng assimp 2>/dev/null)
LIB_LIBS   = -lembree3 -lOpenEXRCore-3_1 -lcjson -lpng16 -ljpeg -ldeflate -lz -lpthread -lm \
             $(shell pkg-config --libs assimp 2>/dev/null || echo -lassimp)

CFLAGS   ?=
CFLAGS   += -std=c11 $(OPT) -g -Wall -Wextra -Werror -fPIC -D_GNU_SOURCE \
            -fvisibility=hidden -Wno-format-truncation -ffp-contract=off \
            $(SANITIZE) $(SIMD)
# lib/ by concept (docs/architecture.md); a file includes another by its
# path under lib/ ("camera/camera.h"), so the layer shows in the include.
CPPFLAGS += -Iinclude -Ilib
LDFLAGS  += $(SANITIZE)

LIB_SRC  := $(wildcard lib/*/*.c lib/*/*/*.c)
SVC_SRC  := $(wildcard service/*.c)
LIB_OBJ  := $(LIB_SRC:%.c=$(BUILD)/obj/%.o)
TEST_SRC := $(wildcard tests/*.c)
TEST_OBJ := $(TEST_SRC:%.c=$(BUILD)/obj/%.o)

DEPS_OK  := $(BUILD)/.deps-ok
BUNNY    := scenes/meshes/bunny.obj
TEXTURES := $(patsubst %,scenes/textures/%.png,tiles globe sign scratches)

.PHONY: all deps test test-suite render serve clean install bunny test-sanitize figures test-api compare-path

all: $(BUILD)/liblensray.a $(BUILD)/liblensray.so $(BUILD)/lensray $(BUNNY) \
     $(TEXTURES) $(if $(SVC_SRC),$(BUILD)/lensrayd)

# ---- dependencies -------------------------------------------------------
# Installs what is missing when run as root; otherwise names the packages.
deps: $(DEPS_OK)
$(DEPS_OK): Makefile
	@missing=""; \
	for d in $(DEPS); do \
	  what=$${d%%:*}; pkg=$${d##*:}; \
	  case $$what in \
	    /*) [ -e "$$what" ] || missing="$$missing $$pkg" ;; \
	    *) command -v "$$what" >/dev/null 2>&1 || missing="$$missing $$pkg" ;; \
	  esac; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "make: installing missing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null || exit 1; \
	  else \
	    echo "make: missing Debian packages:$$missing"; \
	    echo "make: run 'sudo apt-get install$$missing' (or run make as root) and try again"; \
	    exit 1; \
	  fi; \
	fi
	@mkdir -p $(BUILD) && touch $@

# ---- library ------------------------------------------------------------
$(BUILD)/obj/%.o: %.c $(DEPS_OK)
	@mkdir -p $(dir $@)
	@echo "  CC      $<"
	@$(CC) $(CPPFLAGS) $(PKG_CFLAGS) $(CFLAGS) -MMD -MP -c $< -o $@

# The packet path's lane loops are written for the vectoriser, which
# GCC runs in full at -O3 (unless OPT says otherwise, e.g. -O0 to debug).
# (-fno-math-errno: sqrtf need not set errno, which would stop it;
# -fno-trapping-math lets it if-convert the lane loops' selects; neither
# changes a result.  The AVX-512 clones use 512-bit vectors: 4% faster
# on the bench scene than 256.)
$(BUILD)/obj/lib/integrator/whitted.o $(BUILD)/obj/lib/integrator/whitted16.o $(BUILD)/obj/lib/accel/trace.o \
$(BUILD)/obj/lib/camera/camera.o \
$(BUILD)/obj/lib/render/sample.o $(BUILD)/obj/lib/optics/rx_trace.o $(BUILD)/obj/lib/optics/rx_asph16.o $(BUILD)/obj/lib/integrator/path16.o \
$(BUILD)/obj/lib/integrator/path16_rays.o \
$(BUILD)/obj/lib/optics/rx_trace16f.o $(BUILD)/obj/lib/camera/camera_lens.o $(BUILD)/obj/lib/camera/lens_rays.o $(BUILD)/obj/lib/optics/lens.o \
$(BUILD)/obj/lib/accel/few_triangles.o $(BUILD)/obj/lib/accel/spheres.o $(BUILD)/obj/lib/optics/ghost16.o \
$(BUILD)/obj/lib/sampling/wavelength.o: CFLAGS += $(if $(filter -O2,$(OPT)),-O3) \
                                      -fno-math-errno -fno-trapping-math \
                                      -mprefer-vector-width=512
$(BUILD)/obj/lib/sampling/sampler.o: CFLAGS += $(if $(filter -O2,$(OPT)),-O3)
# The EXR ZIP transform's byte loops (exr_zip.c), vectorised.
$(BUILD)/obj/lib/image/exr_zip.o: CFLAGS += $(if $(filter -O2,$(OPT)),-O3)

# The shipped lenses' directory, compiled in (LENSRAY_LENS_DIR overrides
# it at run time): lib/optics/rx_file.c.  Where `make install` puts them is the
# fallback for when the source tree is gone.
LENS_INSTALL_DIR := $(PREFIX)/share/lensray/lenses
$(BUILD)/obj/lib/optics/rx_file.o: CPPFLAGS += -DLR_LENS_DIR='"$(abspath lenses)"' \
                                        -DLR_LENS_INSTALL_DIR='"$(LENS_INSTALL_DIR)"'
# Rebuilt when the directories change: `make` then `make install
# PREFIX=X` kept the first build's /usr/local compiled in, and the
# installed library could not find the lenses it had installed.
# The file is written as the Makefile is read, and only when they differ.
LENS_DIRS := $(abspath lenses) $(LENS_INSTALL_DIR)
$(shell mkdir -p $(BUILD)/gen && echo '$(LENS_DIRS)' | \
  cmp -s - $(BUILD)/gen/lens-dirs || echo '$(LENS_DIRS)' >$(BUILD)/gen/lens-dirs)
$(BUILD)/obj/lib/optics/rx_file.o: $(BUILD)/gen/lens-dirs

$(BUILD)/liblensray.a: $(LIB_OBJ)
	@echo "  AR      $@"
	@rm -f $@ && ar rcs $@ $^

$(BUILD)/liblensray.so.$(VERSION): $(LIB_OBJ) lib/lensray.map
	$(CC) -shared -Wl,-soname,liblensray.so.$(SOMAJOR) \
	  -Wl,--version-script=lib/lensray.map $(LDFLAGS) -o $@ $(LIB_OBJ) $(LIB_LIBS)

$(BUILD)/liblensray.so: $(BUILD)/liblensray.so.$(VERSION)
	ln -sf liblensray.so.$(VERSION) $(BUILD)/liblensray.so.$(SOMAJOR)
	ln -sf liblensray.so.$(VERSION) $@

# ---- command-line tool --------------------------------------------------
# tools/remote.c renders on daemons (--remote) through libcurl.
CLI_OBJ  := $(patsubst %.c,$(BUILD)/obj/%.o,$(wildcard tools/*.c))
$(BUILD)/lensray: $(CLI_OBJ) $(BUILD)/liblensray.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS) -lcurl -lcrypto

# ---- daemon -------------------------------------------------------------
SVC_OBJ  := $(SVC_SRC:%.c=$(BUILD)/obj/%.o)
PORT     ?= 8080

# The page (service/ui/, docs/page.md) goes into the binary as C arrays.
UI_FILES := $(wildcard service/ui/*.html service/ui/*.css service/ui/*.js)
UI_OBJ   := $(BUILD)/obj/gen/ui_files.o

$(BUILD)/gen/ui_files.c: service/ui/embed.sh $(UI_FILES)
	@mkdir -p $(dir $@)
	@echo "  EMBED   $(UI_FILES)"
	@sh service/ui/embed.sh $@ $(UI_FILES)

$(UI_OBJ): $(BUILD)/gen/ui_files.c service/lensrayd.h $(DEPS_OK)
	@mkdir -p $(dir $@)
	@echo "  CC      $<"
	@$(CC) $(CPPFLAGS) -Iservice $(PKG_CFLAGS) $(CFLAGS) -c $< -o $@

$(BUILD)/lensrayd: $(SVC_OBJ) $(UI_OBJ) $(BUILD)/liblensray.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS) -lmicrohttpd -lcrypto

# Builds and starts the daemon on the built-in scenes (Ctrl-C stops it).
serve: all $(BUILD)/lensrayd
	$(BUILD)/lensrayd --port $(PORT) --scenes scenes

# ---- the farm -------------------------------------------------------------
# FARM_N daemons on loopback ports behind nginx on FARM_PORT
# (farm/farm.sh, farm/nginx.conf.in; docs/deploy.md for real machines).
# Pids and logs go to $(BUILD)/farm; `make farm-stop` stops exactly those.
FARM_N    ?= 3
FARM_PORT ?= 8090
.PHONY: farm farm-stop
farm: all
	sh farm/farm.sh start $(BUILD) $(FARM_N) $(FARM_PORT)
farm-stop:
	sh farm/farm.sh stop $(BUILD)

# ---- scenes -------------------------------------------------------------
bunny: $(BUNNY)
$(BUNNY): scenes/get-bunny.sh scenes/bunny-to-obj.js $(DEPS_OK)
	sh scenes/get-bunny.sh $@

# scenes/textured.json's images, written by a script (never committed).
$(TEXTURES) &: scenes/make-textures.py $(DEPS_OK)
	python3 scenes/make-textures.py scenes/textures

# ---- tests --------------------------------------------------------------
# The fuzz targets' code, built without libFuzzer, replays tests/corpus/
# and fuzz/seeds/ inside the unit tests (tests/test_fuzz_replay.c); the
# job target brings the parts of the daemon that parse a job.
REPLAY_SRC := fuzz/fuzz_common.c fuzz/fuzz_scene.c fuzz/fuzz_obj.c fuzz/fuzz_lens.c \
              fuzz/fuzz_gltf.c \
              fuzz/fuzz_texture.c \
              $(if $(SVC_SRC),fuzz/fuzz_job.c service/api.c \
                service/scene_cache.c service/util.c service/sha256.c \
                service/assets.c)
REPLAY_OBJ := $(REPLAY_SRC:%.c=$(BUILD)/obj/%.o)

$(BUILD)/tests/unit: $(TEST_OBJ) $(REPLAY_OBJ) $(BUILD)/liblensray.a
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS) -lcmocka $(if $(SVC_SRC),-lcrypto)

# `make test` runs the whole suite twice: as built, then under
# AddressSanitizer and UBSan (test-sanitize, in build/sanitize), then the
# fuzz session and the API test (test-api), and ends with one line adding
# them all up.  `make test-suite` is the first half
# alone, for a quick run.
test:
	@sh tests/all.sh "$(MAKE)" $(BUILD)

test-suite: all $(BUILD)/tests/unit
	@sh tests/run.sh $(BUILD)

# ---- the HTTP API against its spec -----------------------------------------
# docs/openapi.yaml through openapi-spec-validator, then schemathesis
# against a live lensrayd (tests/api/run.sh): API_EXAMPLES requests per
# operation, positive and negative, plus the spec's links; any 5xx or
# answer the spec does not describe fails.  About a minute.  The Python
# packages, pinned in tests/api/requirements.txt, go into a virtualenv
# under build/ (python3-venv is installed like the deps above when run as
# root and Python cannot make one).
API_VENV     := $(BUILD)/api-venv
API_EXAMPLES ?= 100

test-api: all $(API_VENV)/.ok
	@sh tests/api/run.sh $(BUILD) $(API_VENV) $(API_EXAMPLES)

# A virtualenv $(1) with the pinned packages of $(2) (pip flags $(3)), for
# the recipe of $(1)/.ok (test-api's and test-lenses').
define make_venv
	@if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "make: installing missing Debian packages: python3-venv"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null || exit 1; \
	  else \
	    echo "make: missing Debian packages: python3-venv"; \
	    echo "make: run 'sudo apt-get install python3-venv' (or run make as root) and try again"; \
	    exit 1; \
	  fi; \
	fi
	@rm -rf $(1) && python3 -m venv $(1)
	@echo "  PIP     $(2) -> $(1)"
	@$(1)/bin/pip install -q --disable-pip-version-check $(3) -r $(2)
	@touch $(1)/.ok
endef

$(API_VENV)/.ok: tests/api/requirements.txt $(DEPS_OK)
	$(call make_venv,$(API_VENV),tests/api/requirements.txt)

# ---- lenses against an optical design program ---------------------------
# `lensray lens` on every shipped lens and on tests/data/lenses/ against
# ray-optics (tests/lenses/compare.py, pinned in tests/lenses/
# requirements.txt, in a virtualenv under build/ made like test-api's):
# EFL, BFL, pupils, real chief-ray heights, distortion and lateral colour;
# then a defocused point's rendered blur against ray-optics' spot diagram
# (tests/lenses/spot.py), and the glass catalogue against opticalglass
# (tests/lenses/glass.py).  Ends "N passed, N failed", one per lens, spot
# case and glass maker.  About 30 s once the virtualenv exists.
LENS_VENV := $(BUILD)/lens-venv

.PHONY: test-lenses test-isa
LENS_CHECKED := $(wildcard $(addprefix lenses/*,.json .zmx .dat .txt)) \
                $(wildcard tests/data/lenses/*)
test-lenses: $(BUILD)/lensray $(BUILD)/tests/glass-dump $(LENS_VENV)/.ok
	@$(LENS_VENV)/bin/python tests/lenses/compare.py $(BUILD)/lensray \
	  $(LENS_CHECKED)

# Every catalogue glass's index at seven wavelengths, for tests/lenses/glass.py.
$(BUILD)/tests/glass-dump: $(BUILD)/obj/tests/lenses/glass_dump.o $(BUILD)/liblensray.a
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS)

$(LENS_VENV)/.ok: tests/lenses/requirements.txt $(DEPS_OK)
	$(call make_venv,$(LENS_VENV),tests/lenses/requirements.txt,--no-deps)

# ---- glTF geometry against an independent ray caster -------------------
# tests/gltf_depth_suite.py: scenes of tests/gltf_writer.py (node
# hierarchies, accessor layouts, sparse accessors, morph targets, skins,
# the glTF camera), each as .gltf and .glb, rendered with the Z channel
# and compared pixel by pixel with tests/gltf_depth_check.py's own numpy
# reading of the file (docs/gltf.md, "Tests").  Ends "N passed, N failed";
# about 15 s once the virtualenv (numpy, OpenEXR, pinned in
# tests/gltf_requirements.txt) exists.
GLTF_VENV := $(BUILD)/gltf-venv

.PHONY: test-gltf-depth
test-gltf-depth: $(BUILD)/lensray $(GLTF_VENV)/.ok
	@$(GLTF_VENV)/bin/python tests/gltf_depth_suite.py $(BUILD)/lensray

$(GLTF_VENV)/.ok: tests/gltf_requirements.txt $(DEPS_OK)
	$(call make_venv,$(GLTF_VENV),tests/gltf_requirements.txt,--no-deps)

test-sanitize:
	$(MAKE) BUILD=build/sanitize OPT=-O1 \
	  SANITIZE="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined" \
	  test-suite

# ---- every code path this CPU runs (issue 28, item 8) -------------------
# The pixel-hash matrix with Embree forced to each ISA the CPU has, and
# with lensray's own SIMD forced down to the baseline (a second build,
# SIMD=$(SIMD_BASE)) and, where the CPU has AVX2, to its AVX2 code (a
# third, SIMD=$(SIMD_AVX2)): tools/isa-matrix.sh, numpy from the lens
# venv for tools/isa_diff.py.  About two minutes.
test-isa: all $(LENS_VENV)/.ok
	@$(MAKE) --no-print-directory BUILD=$(BUILD)/simd-base 'SIMD=$$(SIMD_BASE)' \
	  $(BUILD)/simd-base/lensray
	@if grep -qw avx2 /proc/cpuinfo; then \
	  $(MAKE) --no-print-directory BUILD=$(BUILD)/simd-avx2 'SIMD=$$(SIMD_AVX2)' \
	    $(BUILD)/simd-avx2/lensray; fi
	@PYTHON=$(LENS_VENV)/bin/python sh tools/isa-matrix.sh $(BUILD) \
	  $(BUILD)/simd-base $(BUILD)/simd-avx2

# ---- Python --------------------------------------------------------------
# The lensray package (python/, docs/python.md) in a virtual environment
# under $(BUILD)/python: pinned test dependencies (python/tests/
# requirements.txt; made again when that file changes), the package
# installed from a copy of python/ so that setuptools' build files stay
# under build/, then pytest, ending "N passed, N failed".
PY_VENV := $(BUILD)/python/venv
PYTHON  ?= python3

$(PY_VENV)/.ok: python/tests/requirements.txt
	@rm -rf $(PY_VENV) && mkdir -p $(dir $(PY_VENV))
	@echo "  VENV    $(PY_VENV)"
	@$(PYTHON) -m venv $(PY_VENV) >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "make: installing missing Debian packages: python3-venv"; \
	    apt-cache policy python3-venv 2>/dev/null | grep -q 'Candidate: [0-9]' || apt-get update -qq; \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null; \
	  fi; rm -rf $(PY_VENV); $(PYTHON) -m venv $(PY_VENV); } || { \
	  echo "make: $(PYTHON) -m venv failed: run 'sudo apt-get install python3-venv' and try again"; exit 1; }
	@$(PY_VENV)/bin/pip install -q --disable-pip-version-check -r python/tests/requirements.txt
	@touch $@

PY_SRC  := rm -rf $(BUILD)/python/src && mkdir -p $(BUILD)/python/src && \
           cp -r python/lensray python/pyproject.toml python/setup.py \
           python/README.md $(BUILD)/python/src/
PY_PIP  := LENSRAY_BUILD=$(abspath $(BUILD)) $(PY_VENV)/bin/pip -q \
           --disable-pip-version-check

.PHONY: python python-wheel test-python
python: all $(PY_VENV)/.ok
	@$(PY_SRC)
	@$(PY_PIP) install --no-build-isolation --no-deps --force-reinstall $(BUILD)/python/src

# A wheel with liblensray inside, for this platform, in $(BUILD)/python/dist.
python-wheel: all $(PY_VENV)/.ok
	@$(PY_SRC)
	@$(PY_PIP) wheel --no-build-isolation --no-deps -w $(BUILD)/python/dist $(BUILD)/python/src
	@ls $(BUILD)/python/dist/*.whl

# The Python virtualenvs of test-api, test-python, test-lenses,
# test-gltf-depth and test-blender (tests/all.sh makes them while the C
# suites run).
.PHONY: venvs
venvs: $(API_VENV)/.ok $(PY_VENV)/.ok $(LENS_VENV)/.ok $(GLTF_VENV)/.ok \
       $(BLENDER_VENV)/.ok

test-python: python
	@cd $(BUILD)/python && PYTHONDONTWRITEBYTECODE=1 \
	  LENSRAY_BUILD_DIR=$(abspath $(BUILD)) venv/bin/python -m pytest \
	  -p no:cacheprovider -q $(abspath python/tests)

# ---- Blender --------------------------------------------------------------
# The LENSRAY render engine (blender/lensray_blender, docs/blender.md) under
# bpy from the Python registry (pinned in blender/requirements.txt, a
# ~370 MB wheel built for Python 3.11), in a virtualenv under build/ made
# like test-api's (tests/all.sh makes it with the others while the C
# suites run).  The tests render the issue's scene with Cycles and with
# lensray and compare them; they end "N passed, N failed".  About 50 s
# once the virtualenv exists (which takes about 30 s from a warm pip
# cache); part of `make test`.
BLENDER_VENV := $(BUILD)/blender-venv

.PHONY: test-blender
test-blender: all $(BLENDER_VENV)/.ok $(BUILD)/.blender-deps-ok
	@cd $(BUILD) && PYTHONDONTWRITEBYTECODE=1 LENSRAY_LIB=$(abspath $(BUILD))/liblensray.so \
	  $(abspath $(BLENDER_VENV))/bin/python -m pytest -p no:cacheprovider -q \
	  $(abspath blender/tests)

$(BLENDER_VENV)/.ok: blender/requirements.txt $(DEPS_OK)
	$(call make_venv,$(BLENDER_VENV),blender/requirements.txt)

# blender/tests/test_blender_binary.py runs the add-on in Debian's Blender
# 3.4 (the `blender` binary; python3-numpy, which the add-on needs and
# blender does not pull in), installed by install_missing.
BLENDER_DEPS := blender:blender \
                /usr/lib/python3/dist-packages/numpy/__init__.py:python3-numpy

$(BUILD)/.blender-deps-ok: Makefile
	$(call install_missing,$(BLENDER_DEPS))
	@mkdir -p $(dir $@) && touch $@

# $(call install_missing,WHAT:PACKAGE ...): a recipe line that finds each
# WHAT (an absolute path, or a command) and installs the Debian PACKAGE of
# those missing when run as root, with an apt-get update first only when
# apt does not know a package yet; otherwise it names them and fails.
install_missing = @missing=""; \
	for d in $(1); do \
	  what=$${d%%:*}; pkg=$${d\#\#*:}; \
	  case $$what in \
	    /*) [ -e "$$what" ] || missing="$$missing $$pkg" ;; \
	    *) command -v "$$what" >/dev/null 2>&1 || missing="$$missing $$pkg" ;; \
	  esac; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "make: installing missing Debian packages:$$missing"; \
	    for p in $$missing; do \
	      apt-cache policy $$p 2>/dev/null | grep -q 'Candidate: [0-9]' || \
	        { apt-get update -qq || exit 1; break; }; \
	    done; \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null || exit 1; \
	  else \
	    echo "make: missing Debian packages:$$missing"; \
	    echo "make: run 'sudo apt-get install$$missing' (or run make as root) and try again"; \
	    exit 1; \
	  fi; \
	fi

# ---- the page in a browser ---------------------------------------------------
# tests/page.bats drives lensrayd's page (docs/page.md) in Debian's headless
# Chromium through Selenium (Debian's python3, not a virtualenv), installed
# by install_missing.  Only the tests need them.
PAGE_DEPS := chromium:chromium chromedriver:chromium-driver \
             /usr/lib/python3/dist-packages/selenium/__init__.py:python3-selenium

$(BUILD)/.page-deps-ok: Makefile
	$(call install_missing,$(PAGE_DEPS))
	@mkdir -p $(dir $@) && touch $@

test-suite: $(BUILD)/.page-deps-ok

# ---- formatting ---------------------------------------------------------
# The committed .clang-format (clang-format 14, Debian 12's, installed by
# install_missing) over every C file but lib/optics/glass_table.h, which
# tools/glass-catalogue.py writes.  `make format` rewrites them in place;
# `make format-check` changes nothing, prints each file that differs and
# fails if one does.  `make test` runs it first (test-format), so a
# change that is not formatted fails the suite.
CLANG_FORMAT ?= clang-format
FORMAT_DEPS  := $(CLANG_FORMAT):clang-format
FORMAT_FILES := $(filter-out lib/optics/glass_table.h, \
                  $(wildcard include/*.h lib/*/*.[ch] lib/*/*/*.[ch] service/*.c \
                    service/*.h tools/*.c tools/*.h tests/*.c tests/*.h \
                    tests/*/*.c tests/*/*.h fuzz/*.c fuzz/*.h bench/*.c \
                    bench/*/*.c))

.PHONY: format format-check test-format
test-format: $(DEPS_OK)
	@if $(MAKE) --no-print-directory format-check; then \
	  echo "1 passed, 0 failed"; else echo "0 passed, 1 failed"; exit 1; fi

format: $(BUILD)/.format-deps-ok
	$(CLANG_FORMAT) -i $(FORMAT_FILES)

format-check: $(BUILD)/.format-deps-ok
	@n=0; for f in $(FORMAT_FILES); do \
	  $(CLANG_FORMAT) "$$f" | cmp -s - "$$f" || { echo "$$f"; n=$$((n + 1)); }; \
	done; \
	if [ $$n -gt 0 ]; then \
	  echo "format-check: $$n of $(words $(FORMAT_FILES)) files differ from .clang-format ('make format' rewrites them)"; \
	  exit 1; \
	fi; \
	echo "format-check: all $(words $(FORMAT_FILES)) files as .clang-format says"

$(BUILD)/.format-deps-ok: Makefile
	$(call install_missing,$(FORMAT_DEPS))
	@mkdir -p $(dir $@) && touch $@

# ---- the shape of the tree ------------------------------------------------
# `make check-layers`: lib/'s folders include downward only (util < json <
# sampling < image < optics < camera < scene < accel < integrator <
# render), and service/ and tools/ include no lib/ header
# (tools/check-layers.py; the upward includes of today are listed, each
# with its reason, in tools/layers-allow.txt, which can only shrink).
# `make check-size`: no C file over 700 lines, no function over 150
# (tools/check-size.py; today's offenders in tools/size-allow.txt, which
# can only shrink too).  `make check-style`: no assignment inside an if
# or while condition, no atoi (tools/check-style.py).  `make test` runs
# all three after test-format (test-tree).  Under a second.
.PHONY: check-layers check-size check-style test-tree
check-layers:
	@python3 tools/check-layers.py

check-style:
	@python3 tools/check-style.py

check-size:
	@python3 tools/check-size.py

test-tree: $(DEPS_OK)
	@n=0; f=0; for c in check-layers check-size check-style; do \
	  if $(MAKE) --no-print-directory $$c; then n=$$((n + 1)); \
	  else f=$$((f + 1)); fi; done; \
	echo "$$n passed, $$f failed"; [ $$f -eq 0 ]

# ---- out of memory ------------------------------------------------------
# tests/oom/oom.c fails the library's allocations one by one.  It is linked
# with --wrap so that every allocation made by liblensray.a's own objects
# goes through its failing allocator, and -no-pie so that the allocation
# sites it reports can be symbolised with addr2line.  Allocators the test
# does not wrap are named here if the library ever starts calling them.
OOM_WRAP      := malloc calloc realloc reallocarray free strdup strndup \
                 posix_memalign aligned_alloc realpath
OOM_UNWRAPPED := asprintf|vasprintf|getline|getdelim|open_memstream|memalign|valloc|pvalloc|scandir|__strdup|__strndup|wcsdup|tempnam

$(BUILD)/tests/oom: $(BUILD)/obj/tests/oom/oom.o $(BUILD)/liblensray.a
	@mkdir -p $(dir $@)
	@bad=$$(nm -u $(BUILD)/liblensray.a | awk '{print $$2}' | \
	  grep -xE '$(OOM_UNWRAPPED)' | sort -u | tr '\n' ' '); \
	  [ -z "$$bad" ] || echo "make: warning: liblensray calls allocators tests/oom does not wrap: $$bad"
	$(CC) $(LDFLAGS) -no-pie $(OOM_WRAP:%=-Wl,--wrap=%) -o $@ $^ \
	  $(LIB_LIBS) -lcmocka -ldl

test-suite: $(BUILD)/tests/oom

# ---- soak -----------------------------------------------------------------
# The daemon under load and abuse for SOAK_SECONDS (tests/soak/soak.sh;
# `make test` runs a 20 s version, tests/soak.bats).  The summary goes to
# $(BUILD)/soak/summary.txt; docs/reliability.md has a long run's figures.
SOAK_SECONDS ?= 300

.PHONY: soak
soak: all
	bash tests/soak/soak.sh $(SOAK_SECONDS) $(BUILD)

# ---- fuzzing ------------------------------------------------------------
# libFuzzer targets for the scene, OBJ, lens, glTF and job parsers and the
# texture decoders (fuzz/fuzz_*.c),
# built with clang under AddressSanitizer and UBSan in build/fuzz, apart
# from the other builds.  `make fuzz` runs each for FUZZ_SECONDS (clang is
# installed like the other dependencies, but only for these targets).  New
# corpus entries go to build/fuzz/corpus/NAME, crashes to
# build/fuzz/crashes/NAME; a crash stops the run.  Copy a fixed crash into
# tests/corpus/NAME/ and `make test` replays it from then on.  `make fuzz
# FUZZ=obj` runs one target.
#
# `make fuzz-ci` is the short, repeatable session that `make test` runs
# (tests/all.sh): each target for FUZZ_CI_SECONDS from the seeds and
# tests/corpus only, with a fixed seed, in build/fuzz/ci; it ends with
# "N passed, N failed", one per target (fuzz/run.sh).
FUZZ_SECONDS    ?= 60
FUZZ_CI_SECONDS ?= 10
FUZZ_CC         ?= clang
FUZZ_BUILD      := build/fuzz
FUZZ            ?= scene obj lens gltf texture $(if $(SVC_SRC),job)
FUZZ_SAN        := -fsanitize=address,undefined -fno-sanitize-recover=undefined \
                   -fno-omit-frame-pointer -Wno-unknown-warning-option \
                   '-Dtarget_clones(...)=unused'
# (clang 14 leaves the resolver of a hidden target_clones function
# undefined at link time; the fuzz build keeps only the default versions.)
FUZZ_OPTS       ?= -timeout=20 -rss_limit_mb=2560 -max_len=8192 -print_final_stats=1
export FUZZ_OPTS

.PHONY: fuzz fuzz-build fuzz-ci
fuzz: fuzz-build
	@sh fuzz/run.sh explore $(FUZZ_BUILD) $(FUZZ_SECONDS) $(FUZZ)

# A build that fails (no clang, no libFuzzer) fails every target.
fuzz-ci:
	@$(MAKE) --no-print-directory fuzz-build || { \
	  echo "fuzz: the libFuzzer targets did not build (see above)"; \
	  echo "0 passed, $(words $(FUZZ)) failed"; exit 1; }
	@sh fuzz/run.sh ci $(FUZZ_BUILD) $(FUZZ_CI_SECONDS) $(FUZZ)

# The library and the daemon's objects with coverage for libFuzzer, in
# their own build directory, then the targets linked with libFuzzer.
fuzz-build: $(FUZZ_BUILD)/.fuzz-deps-ok
	@$(MAKE) --no-print-directory BUILD=$(FUZZ_BUILD) CC=$(FUZZ_CC) OPT=-O1 \
	  SANITIZE="-fsanitize=fuzzer-no-link $(FUZZ_SAN)" \
	  $(FUZZ:%=$(FUZZ_BUILD)/fuzz_%)

# clang and its libFuzzer runtime (Debian's libclang-rt-N-dev, which clang
# only recommends), checked by linking a one-line libFuzzer target, and
# installed like the deps above when run as root; otherwise named.
FUZZ_PROBE := int LLVMFuzzerTestOneInput(const char *d, unsigned long n) \
              { return d == 0 && n > 0; }
$(FUZZ_BUILD)/.fuzz-deps-ok: Makefile
	@mkdir -p $(FUZZ_BUILD); log=$(FUZZ_BUILD)/probe.log; \
	probe() { echo '$(FUZZ_PROBE)' | $(FUZZ_CC) -x c \
	  -fsanitize=fuzzer,address,undefined -o $(FUZZ_BUILD)/probe - >$$log 2>&1; }; \
	need() { if command -v $(FUZZ_CC) >/dev/null 2>&1; then \
	  echo libclang-rt-$$($(FUZZ_CC) -dumpversion | cut -d. -f1)-dev; \
	  else echo clang; fi; }; \
	tries=0; \
	while ! probe; do \
	  pkg=$$(need); \
	  if [ "$$(id -u)" != 0 ] || [ $$tries -ge 2 ]; then \
	    cat $$log; \
	    echo "make: $(FUZZ_CC) cannot link a libFuzzer target (-fsanitize=fuzzer): missing Debian package $$pkg?"; \
	    [ "$$(id -u)" = 0 ] || \
	      echo "make: run 'sudo apt-get install $$pkg' (or run make as root) and try again"; \
	    exit 1; \
	  fi; \
	  echo "make: installing missing Debian packages: $$pkg"; \
	  [ $$tries -gt 0 ] || apt-get update -qq || exit 1; \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$pkg >/dev/null || exit 1; \
	  tries=$$((tries + 1)); \
	done; \
	rm -f $(FUZZ_BUILD)/probe $$log; touch $@

FUZZ_LINK = $(CC) $(CFLAGS) $(LDFLAGS) -fsanitize=fuzzer -o $@ $^ $(LIB_LIBS)
FUZZ_JOB_OBJ := $(patsubst %,$(BUILD)/obj/service/%.o,api scene_cache util sha256 assets)

$(BUILD)/fuzz_scene: $(BUILD)/obj/fuzz/lf_scene.o $(BUILD)/obj/fuzz/fuzz_common.o $(BUILD)/liblensray.a
	$(FUZZ_LINK)
$(BUILD)/fuzz_obj: $(BUILD)/obj/fuzz/lf_obj.o $(BUILD)/obj/fuzz/fuzz_common.o $(BUILD)/liblensray.a
	$(FUZZ_LINK)
$(BUILD)/fuzz_lens: $(BUILD)/obj/fuzz/lf_lens.o $(BUILD)/obj/fuzz/fuzz_common.o $(BUILD)/liblensray.a
	$(FUZZ_LINK)
$(BUILD)/fuzz_gltf: $(BUILD)/obj/fuzz/lf_gltf.o $(BUILD)/obj/fuzz/fuzz_common.o $(BUILD)/liblensray.a
	$(FUZZ_LINK)
$(BUILD)/fuzz_texture: $(BUILD)/obj/fuzz/lf_texture.o $(BUILD)/obj/fuzz/fuzz_common.o $(BUILD)/liblensray.a
	$(FUZZ_LINK)
$(BUILD)/fuzz_job: $(BUILD)/obj/fuzz/lf_job.o $(BUILD)/obj/fuzz/fuzz_common.o $(FUZZ_JOB_OBJ) $(BUILD)/liblensray.a
	$(FUZZ_LINK) -lcrypto

# The libFuzzer entry point is compiled in only here.
$(BUILD)/obj/fuzz/lf_%.o: fuzz/fuzz_%.c $(DEPS_OK)
	@mkdir -p $(dir $@)
	@echo "  CC      $< (libFuzzer)"
	@$(CC) $(CPPFLAGS) $(PKG_CFLAGS) $(CFLAGS) -DLR_FUZZ_LIBFUZZER -MMD -MP -c $< -o $@

# ---- running ------------------------------------------------------------
render: all
	$(BUILD)/lensray render scenes/spheres.json -o $(BUILD)/spheres.png --stats

# The gallery's pictures (docs/gallery.md), rendered with the CLI, and the
# Python guide's sweeps (docs/python.md), plotted with matplotlib.
figures: all python $(BUILD)/python/.figures-ok lens-sheet
	sh docs/figures.sh $(BUILD)/lensray docs/figures
	SWEEPS_PNG=docs/figures/python-sweeps.png $(PY_VENV)/bin/python docs/python-sweeps.py

# The shipped lenses' contact sheet and table (docs/lenses.md): one scene
# through every lens in lenses/ at 300 x 200, 256 samples a pixel (about
# 2 minutes of CPU), laid out with matplotlib from the ray-optics
# virtualenv, whose compare.py gives each lens's field.
.PHONY: lens-sheet
lens-sheet: $(BUILD)/lensray $(LENS_VENV)/.ok
	$(LENS_VENV)/bin/python docs/lens-sheet.py $(BUILD)/lensray \
	  docs/figures/lens-sheet.png docs/lenses.md

$(BUILD)/python/.figures-ok: $(PY_VENV)/.ok python/figures-requirements.txt
	@$(PY_VENV)/bin/pip install -q --disable-pip-version-check -r python/figures-requirements.txt
	@touch $@

# The benchmark (bench/README.md): lensray against a bare Embree program and
# Mitsuba 3 on scenes/bench.json; results in $(BUILD)/bench/results.txt.
# The ceiling is plain C on Embree alone, built portably (no -march).
BENCH_CFLAGS ?= -std=c11 -O2 -g -Wall -Wextra
.PHONY: bench
bench: all $(BUILD)/bench/ceiling $(BUILD)/accuracy/imgdiff
	@$(MAKE) --no-print-directory python || \
	  echo "bench: the Python package could not be set up; its section will be skipped"
	sh bench/run.sh $(BUILD)

$(BUILD)/bench/ceiling: bench/ceiling.c $(DEPS_OK)
	@mkdir -p $(dir $@)
	$(CC) $(BENCH_CFLAGS) -o $@ bench/ceiling.c -lembree3 -lpthread -lm

# Spectral chromatic aberration, old against new (bench/spectral.py,
# docs/spectral.md): time to relative MSE 1e-3 on scenes/accuracy-chroma.json
# for lensray built from SPECTRAL_BASE (main before issue 17's spectral
# sampling; built once into $(BUILD)/bench/spectral-base) and for this
# tree, side by side in one run.  About 3 minutes of CPU, more under load,
# so not part of `make bench`.
SPECTRAL_BASE ?= 4b3bd1b
.PHONY: bench-spectral
bench-spectral: $(BUILD)/lensray $(BUILD)/accuracy/imgdiff $(BUILD)/bench/spectral-base/lensray
	python3 bench/spectral.py --old $(BUILD)/bench/spectral-base/lensray \
	  --new $(BUILD)/lensray --imgdiff $(BUILD)/accuracy/imgdiff \
	  --work $(BUILD)/bench/spectral

$(BUILD)/bench/spectral-base/lensray: $(DEPS_OK)
	rm -rf $(BUILD)/bench/spectral-base.src && mkdir -p $(BUILD)/bench/spectral-base.src
	git archive $(SPECTRAL_BASE) | tar -x -C $(BUILD)/bench/spectral-base.src
	$(MAKE) -C $(BUILD)/bench/spectral-base.src BUILD=build build/lensray
	@mkdir -p $(dir $@)
	cp $(BUILD)/bench/spectral-base.src/build/lensray $@

# The path integrator against Mitsuba 3's `path` on a Cornell box with an
# area light and an environment-lit scene with rough metal and glass
# (bench/path/compare.py; docs/path-tracing.md): 128 x 128 at 1024 spp,
# about 3 minutes on 2 cores, so not part of `make test`.  Mitsuba goes
# into $(BUILD)/bench/venv as for `make bench`.  Fails if a target (mean
# block difference < 1%, 90th percentile < 3%) is missed.
.PHONY: compare-path
compare-path: $(BUILD)/lensray
	sh bench/path/run.sh $(BUILD) compare

# Night lights through the thin lens (issue 27; bench/bokeh/): lensray's
# defaults, lensray with planning and adaptive sampling off, and Mitsuba 3's
# `path` and `ptracer`, timed to relMSE 1e-3 against the exact reference
# that bench/bokeh/reference.py computes (cached in $(BUILD)/bench/bokeh/).
# Mitsuba goes into $(BUILD)/bench/venv as for `make bench`.  About 5
# minutes on 2 cores, half of it the reference the first time, so not
# part of `make bench`.  BOKEH_ARGS go to bench/bokeh/run.py.
BOKEH_ARGS ?=
.PHONY: bench-bokeh bench-sparkles
bench-bokeh: $(BUILD)/lensray
	sh bench/bokeh/run.sh $(BUILD) $(BOKEH_ARGS)

# The bench scene's time to relMSE 1e-5 (issue 30; bench/bunny_time.py):
# lensray's defaults and full simulation against Mitsuba 3's samplers, each
# against its own 2-half reference (cached in $(BUILD)/bench/bunny-time/).
# About 4 minutes on 2 cores the first time, 2 with the references cached.
BUNNY_ARGS ?=
.PHONY: bench-bunny
bench-bunny: $(BUILD)/lensray
	sh bench/bunny_time.sh $(BUILD) $(BUNNY_ARGS)

# Sparkles (docs/bokeh.md): small lights in a rough metal plane, the
# defaults against camera paths alone, to relMSE 1e-3.
bench-sparkles: $(BUILD)/lensray
	sh bench/bokeh/sparkles.sh $(BUILD) $(BOKEH_ARGS)

# Accuracy against time (docs/accuracy.md): scenes/accuracy-*.json rendered
# at increasing spp with every sampler, with and without planning and
# adaptive sampling, measured against references cached in
# $(BUILD)/accuracy/ref/; rewrites the doc's tables and docs/accuracy-*.png.
# About 10 minutes on 2 cores the first time, less with the references
# cached.  ACCURACY_ARGS=--quick is a short smoke run that leaves docs/ alone.
ACCURACY_DEPS := gnuplot:gnuplot-nox python3:python3
ACCURACY_ARGS ?=
.PHONY: accuracy
accuracy: $(BUILD)/lensray $(BUILD)/accuracy/imgdiff $(BUILD)/accuracy/.deps-ok
	python3 bench/accuracy/run.py --lensray $(BUILD)/lensray \
	  --imgdiff $(BUILD)/accuracy/imgdiff --work $(BUILD)/accuracy $(ACCURACY_ARGS)

$(BUILD)/accuracy/imgdiff: bench/accuracy/imgdiff.c $(DEPS_OK)
	@mkdir -p $(dir $@)
	$(CC) -std=c11 -O2 -g -Wall -Wextra -Werror -D_GNU_SOURCE $(PKG_CFLAGS) \
	  -o $@ $< -lOpenEXRCore-3_1 -lm

# gnuplot and python3, installed by install_missing.
$(BUILD)/accuracy/.deps-ok: Makefile
	$(call install_missing,$(ACCURACY_DEPS))
	@mkdir -p $(dir $@) && touch $@

install: all
	install -d $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib \
	  $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/pkgconfig \
	  $(DESTDIR)$(LENS_INSTALL_DIR)
	install -m 644 $(wildcard $(addprefix lenses/*,.json .zmx .dat .txt)) \
	  $(DESTDIR)$(LENS_INSTALL_DIR)/
	install -m 644 include/lensray.h $(DESTDIR)$(PREFIX)/include/
	install -m 644 $(BUILD)/liblensray.a $(DESTDIR)$(PREFIX)/lib/
	install -m 755 $(BUILD)/liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/
	ln -sf liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/liblensray.so.$(SOMAJOR)
	ln -sf liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/liblensray.so
	install -m 755 $(BUILD)/lensray $(DESTDIR)$(PREFIX)/bin/
	if [ -x $(BUILD)/lensrayd ]; then install -m 755 $(BUILD)/lensrayd $(DESTDIR)$(PREFIX)/bin/; fi
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|$(VERSION)|' \
	  -e 's|@LIBS_PRIVATE@|$(strip $(LIB_LIBS))|' lensray.pc.in \
	  > $(DESTDIR)$(PREFIX)/lib/pkgconfig/lensray.pc

clean:
	rm -rf $(BUILD)

-include $(LIB_OBJ:.o=.d) $(TEST_OBJ:.o=.d) $(SVC_OBJ:.o=.d) $(CLI_OBJ:.o=.d) \
         $(REPLAY_OBJ:.o=.d) $(wildcard $(BUILD)/obj/fuzz/lf_*.d) \
         $(BUILD)/obj/tests/oom/oom.d $(BUILD)/obj/tests/lenses/glass_dump.d
