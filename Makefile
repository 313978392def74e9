# hysteron — the two commands: `make demo` (main job) and `make test` (every test).
BUILD      ?= build
ASAN_BUILD ?= build-asan
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_MAX_LEN ?= 4096
FUZZ_TARGETS := csv model_file mat rig_params loop
JOBS       ?= $(shell nproc 2>/dev/null || echo 2)
PYTHON     := /usr/bin/python3
CMAKE_ARGS := -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=$(PYTHON) -DPYTHON_EXECUTABLE=$(PYTHON)

# Debian packages the build and the tests need (never downloaded from anywhere else).
APT_PACKAGES := cmake make g++ pkg-config libeigen3-dev libceres-dev libcli11-dev nlohmann-json3-dev \
  libfmt-dev libgtest-dev libbenchmark-dev pybind11-dev python3-dev python3-numpy python3-scipy \
  python3-pytest libmatio-dev libhdf5-dev gnuplot-nox chromium octave liboctave-dev zlib1g-dev \
  clang libclang-rt-dev

.PHONY: all deps configure build demo test test-asan fuzz fuzz-build bench clean

all: build

deps:
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "Installing missing Debian packages: $$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
	  else \
	    echo "Missing Debian packages. Run:"; echo "  sudo apt-get install -y $$missing"; exit 1; \
	  fi; \
	fi

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) $(CMAKE_ARGS)

configure: deps
	cmake -S . -B $(BUILD) $(CMAKE_ARGS)

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	./$(BUILD)/hysteron demo

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The tests once more under AddressSanitizer + UndefinedBehaviorSanitizer (Python module, examples
# and MATLAB off), at -O1 with line tables only (-g1: stack traces keep file:line; a full -g build
# took 2.7x as long to compile). Every test runs except the long ones tests/sanitize_skip.txt lists
# with the shorter test that covers the same code (the sanitizers make a test ~10x slower).
SANITIZE_SKIP = $(shell sed -e 's/\#.*//' -e 's/[[:space:]]*$$//' -e '/^$$/d' $(dir $(lastword $(MAKEFILE_LIST)))tests/sanitize_skip.txt | paste -sd'|')
test-asan: deps
	$(if $(SANITIZE_SKIP),,$(error tests/sanitize_skip.txt gave no test to leave out))
	cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO='-O1 -g1 -DNDEBUG' \
	  -DCMAKE_C_FLAGS_RELWITHDEBINFO='-O1 -g1 -DNDEBUG' -DHYSTERON_SANITIZE=ON \
	  -DHYSTERON_BUILD_PYTHON=OFF -DHYSTERON_BUILD_BENCH=OFF -DHYSTERON_BUILD_EXAMPLES=OFF \
	  -DHYSTERON_BUILD_MATLAB=OFF
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=0 ctest --output-on-failure -j $(JOBS) -E '$(SANITIZE_SKIP)'

# libFuzzer targets (fuzz/) under ASan + UBSan, built with clang in their own directory (core and
# io only). `make fuzz FUZZ_SECONDS=N` runs each for N seconds from its seed corpus
# (fuzz/corpus/<target>, plus the past findings in fuzz/regressions/<target>: both read only;
# libFuzzer writes new inputs to the first corpus directory only, $(FUZZ_BUILD)/corpus/<target>,
# and crash-/leak-/timeout-/oom- files to $(FUZZ_BUILD)/artifacts; the files a target needs a
# path for go to a fresh directory in /dev/shm (in $(FUZZ_BUILD) without one), emptied after
# each target and removed at the end) and fails on the first finding. Each target gets its
# dictionary fuzz/dict/<target>.dict (format tokens and key names) and -max_len=$(FUZZ_MAX_LEN):
# the formats' interesting structure fits in 4 KB, and longer inputs only slow each run (the
# per-line and per-column limits are tested by tests/test_io_stream.cpp, not by the fuzzers).
# The working tree stays clean (`git status` after `make fuzz FUZZ_SECONDS=5`).
fuzz-build: deps
	cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DHYSTERON_FUZZ=ON \
	  -DHYSTERON_BUILD_TESTS=OFF -DHYSTERON_BUILD_APPS=OFF -DHYSTERON_BUILD_PYTHON=OFF -DHYSTERON_BUILD_BENCH=OFF \
	  -DHYSTERON_BUILD_EXAMPLES=OFF -DHYSTERON_BUILD_MATLAB=OFF
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target fuzz_targets

fuzz: fuzz-build
	@mkdir -p $(FUZZ_BUILD)/artifacts
	@set -e; base=$$([ -w /dev/shm ] && echo /dev/shm || echo $(CURDIR)/$(FUZZ_BUILD)); \
	scratch=$$(mktemp -d $$base/hysteron-fuzz-scratch-XXXXXX); trap 'rm -rf "$$scratch"' EXIT; \
	for t in $(FUZZ_TARGETS); do \
	  mkdir -p $(FUZZ_BUILD)/corpus/$$t; \
	  echo "== fuzz_$$t: $(FUZZ_SECONDS) s"; \
	  rc=0; ASAN_OPTIONS=detect_leaks=1 HYSTERON_FUZZ_SCRATCH=$$scratch \
	    ./$(FUZZ_BUILD)/fuzz/fuzz_$$t -max_total_time=$(FUZZ_SECONDS) -timeout=10 \
	    -rss_limit_mb=2048 -malloc_limit_mb=512 -max_len=$(FUZZ_MAX_LEN) -dict=fuzz/dict/$$t.dict \
	    -print_final_stats=1 -artifact_prefix=$(FUZZ_BUILD)/artifacts/$$t- \
	    $(FUZZ_BUILD)/corpus/$$t fuzz/corpus/$$t $$([ -d fuzz/regressions/$$t ] && echo fuzz/regressions/$$t) \
	    > $(FUZZ_BUILD)/fuzz_$$t.log 2>&1 || rc=$$?; \
	  rm -rf "$$scratch"/hysteron-fuzz-*; \
	  [ $$rc = 0 ] || { tail -n 60 $(FUZZ_BUILD)/fuzz_$$t.log; exit 1; }; \
	  grep -E '^Done|stat::number_of_executed_units' $(FUZZ_BUILD)/fuzz_$$t.log; \
	done
	@# nothing may be left in the working tree: no new file under fuzz/ (seed corpora and past
	@# findings are read only) and no crash-/leak-/timeout-/oom-/slow-unit- file in the top directory
	@left=$$( { git status --porcelain --untracked-files=all -- fuzz 2>/dev/null | grep '^??'; \
	  ls -d crash-* leak-* timeout-* oom-* slow-unit-* 2>/dev/null; } || true); \
	if [ -n "$$left" ]; then echo "make fuzz left files in the working tree:"; echo "$$left"; exit 1; fi

bench: build
	./$(BUILD)/hysteron-bench

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
