# hysteron — the two commands: `make demo` (main job) and `make test` (every test).
BUILD      ?= build
ASAN_BUILD ?= build-asan
JOBS       ?= $(shell nproc 2>/dev/null || echo 2)
PYTHON     := /usr/bin/python3
CMAKE_ARGS := -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=$(PYTHON) -DPYTHON_EXECUTABLE=$(PYTHON)

# Debian packages the build and the tests need (never downloaded from anywhere else).
APT_PACKAGES := cmake make g++ pkg-config libeigen3-dev libceres-dev libcli11-dev nlohmann-json3-dev \
  libfmt-dev libgtest-dev libbenchmark-dev pybind11-dev python3-dev python3-numpy python3-scipy \
  python3-pytest libmatio-dev gnuplot-nox chromium octave liboctave-dev zlib1g-dev

.PHONY: all deps configure build demo test test-asan bench clean

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

# The same tests once under AddressSanitizer + UndefinedBehaviorSanitizer (Python module off).
test-asan: deps
	cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHYSTERON_SANITIZE=ON \
	  -DHYSTERON_BUILD_PYTHON=OFF -DHYSTERON_BUILD_BENCH=OFF -DHYSTERON_BUILD_EXAMPLES=OFF \
	  -DHYSTERON_BUILD_MATLAB=OFF
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=0 ctest --output-on-failure -j $(JOBS) -E 'install_consumer'

bench: build
	./$(BUILD)/hysteron-bench

clean:
	rm -rf $(BUILD) $(ASAN_BUILD)
