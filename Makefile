# lensray: the one entry point.  `make` builds the library and the CLI,
# `make test` runs every test, `make render` renders the default scene.
# Everything generated goes under build/ (and scenes/meshes/*.obj, which
# is fetched, never committed).

PREFIX   ?= /usr/local
BUILD    ?= build
CC       ?= cc
OPT      ?= -O2
SANITIZE ?=

VERSION  := 0.1.0
SOMAJOR  := 0

# What the build and the tests need: a file or a command, and the Debian 12
# package that provides it.  Commands are checked as commands, so that a
# node/npm installed some other way counts too.
DEPS := /usr/include/embree3/rtcore.h:libembree-dev \
        /usr/include/OpenEXR/openexr.h:libopenexr-dev \
        /usr/include/cjson/cJSON.h:libcjson-dev \
        /usr/include/png.h:libpng-dev \
        /usr/include/microhttpd.h:libmicrohttpd-dev \
        /usr/include/cmocka.h:libcmocka-dev \
        pkg-config:pkg-config bats:bats curl:curl node:nodejs npm:npm

# Recursive (=) so that pkg-config runs after the dependency check.
PKG_CFLAGS = $(shell pkg-config --cflags OpenEXR libcjson libpng 2>/dev/null)
LIB_LIBS   = -lembree3 -lOpenEXRCore-3_1 -lcjson -lpng16 -lz -lpthread -lm

CFLAGS   ?=
CFLAGS   += -std=c11 $(OPT) -g -Wall -Wextra -Werror -fPIC -D_GNU_SOURCE \
            -fvisibility=hidden -Wno-format-truncation $(SANITIZE)
CPPFLAGS += -Iinclude -Ilib
LDFLAGS  += $(SANITIZE)

LIB_SRC  := $(wildcard lib/*.c)
SVC_SRC  := $(wildcard service/*.c)
LIB_OBJ  := $(LIB_SRC:%.c=$(BUILD)/obj/%.o)
TEST_SRC := $(wildcard tests/*.c)
TEST_OBJ := $(TEST_SRC:%.c=$(BUILD)/obj/%.o)

DEPS_OK  := $(BUILD)/.deps-ok
BUNNY    := scenes/meshes/bunny.obj

.PHONY: all deps test render serve clean install bunny test-sanitize figures

all: $(BUILD)/liblensray.a $(BUILD)/liblensray.so $(BUILD)/lensray $(BUNNY) \
     $(if $(SVC_SRC),$(BUILD)/lensrayd)

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

$(BUILD)/liblensray.a: $(LIB_OBJ)
	@echo "  AR      $@"
	@rm -f $@ && ar rcs $@ $^

$(BUILD)/liblensray.so.$(VERSION): $(LIB_OBJ)
	$(CC) -shared -Wl,-soname,liblensray.so.$(SOMAJOR) $(LDFLAGS) -o $@ $^ $(LIB_LIBS)

$(BUILD)/liblensray.so: $(BUILD)/liblensray.so.$(VERSION)
	ln -sf liblensray.so.$(VERSION) $(BUILD)/liblensray.so.$(SOMAJOR)
	ln -sf liblensray.so.$(VERSION) $@

# ---- command-line tool --------------------------------------------------
$(BUILD)/lensray: $(BUILD)/obj/tools/lensray.o $(BUILD)/liblensray.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS)

# ---- daemon -------------------------------------------------------------
SVC_OBJ  := $(SVC_SRC:%.c=$(BUILD)/obj/%.o)
PORT     ?= 8080

$(BUILD)/lensrayd: $(SVC_OBJ) $(BUILD)/liblensray.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS) -lmicrohttpd

# Builds and starts the daemon on the built-in scenes (Ctrl-C stops it).
serve: all $(BUILD)/lensrayd
	$(BUILD)/lensrayd --port $(PORT) --scenes scenes

# ---- scenes -------------------------------------------------------------
bunny: $(BUNNY)
$(BUNNY): scenes/get-bunny.sh scenes/bunny-to-obj.js $(DEPS_OK)
	sh scenes/get-bunny.sh $@

# ---- tests --------------------------------------------------------------
$(BUILD)/tests/unit: $(TEST_OBJ) $(BUILD)/liblensray.a
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIB_LIBS) -lcmocka

test: all $(BUILD)/tests/unit
	@sh tests/run.sh $(BUILD)

# The whole suite again under AddressSanitizer and UBSan, in its own
# build directory.
test-sanitize:
	$(MAKE) BUILD=build/sanitize OPT=-O1 \
	  SANITIZE="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined" \
	  test

# ---- running ------------------------------------------------------------
render: all
	$(BUILD)/lensray render scenes/spheres.json -o $(BUILD)/spheres.png --stats

# The gallery's pictures (docs/gallery.md), rendered with the CLI.
figures: all
	sh docs/figures.sh $(BUILD)/lensray docs/figures

install: all
	install -d $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib \
	  $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/pkgconfig
	install -m 644 include/lensray.h $(DESTDIR)$(PREFIX)/include/
	install -m 644 $(BUILD)/liblensray.a $(DESTDIR)$(PREFIX)/lib/
	install -m 755 $(BUILD)/liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/
	ln -sf liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/liblensray.so.$(SOMAJOR)
	ln -sf liblensray.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/liblensray.so
	install -m 755 $(BUILD)/lensray $(DESTDIR)$(PREFIX)/bin/
	if [ -x $(BUILD)/lensrayd ]; then install -m 755 $(BUILD)/lensrayd $(DESTDIR)$(PREFIX)/bin/; fi
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|$(VERSION)|' lensray.pc.in \
	  > $(DESTDIR)$(PREFIX)/lib/pkgconfig/lensray.pc

clean:
	rm -rf $(BUILD)

-include $(LIB_OBJ:.o=.d) $(TEST_OBJ:.o=.d) $(SVC_OBJ:.o=.d) $(BUILD)/obj/tools/lensray.d
