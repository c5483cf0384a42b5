# Convenience front end over CMake. `make demo` installs what is missing,
# builds and renders the default scene; `make test` builds and runs CTest.
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

# make fuzz: the libFuzzer targets (clang), FUZZ_SECONDS each (tests/fuzz/run.sh).
# make test-tsan: the multi-threaded tests under ThreadSanitizer (clang, LLVM libomp + Archer).
FUZZ_SECONDS ?= 60
# (the cmocka tests that run OpenMP code; about 6.5 minutes on 2 busy cores)
TSAN_TESTS ?= test_trace test_determinism test_progressive test_estimators test_dynamic test_cluster \
	test_reference test_kdtree_bounds_kernels test_auto_radius test_sky test_cutout test_pixel_sampling \
	test_analytic test_plastic test_bvh test_differentials test_scene test_ray_log test_emission test_memory \
	test_cancel test_temporal
empty :=
space := $(empty) $(empty)

.PHONY: all deps build demo test test-sanitize fuzz test-tsan test-novulkan bench clean

all: build

deps:
	@./scripts/install-deps.sh

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

demo: deps build
	./$(BUILD)/bin/photongi render --scene cornell -o cornell.png --stats cornell-stats.json
	@echo "wrote cornell.png (and cornell-stats.json)"

test: deps build
	cd $(BUILD) && ctest --output-on-failure -j 2

test-sanitize: deps
	$(MAKE) test BUILD=build-asan CMAKE_FLAGS="-DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_SANITIZE=ON"

fuzz: deps
	PGI_FUZZ_BUILD=build-fuzz JOBS=$(JOBS) tests/fuzz/run.sh $(FUZZ_SECONDS)

test-tsan: deps
	CC=clang cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_TSAN=ON $(CMAKE_FLAGS)
	cmake --build build-tsan -j $(JOBS) --target $(TSAN_TESTS)
	cd build-tsan && ctest --output-on-failure -R '^($(subst $(space),|,$(strip $(TSAN_TESTS))))$$'

# the library and the CLI built without the Vulkan backend (-DPGI_VULKAN=OFF: its stubs link), and
# one frame rendered with them
test-novulkan: deps
	cmake -S . -B build-novulkan -DCMAKE_BUILD_TYPE=Release -DPGI_VULKAN=OFF $(CMAKE_FLAGS)
	cmake --build build-novulkan -j $(JOBS) --target photongi-cli
	./build-novulkan/bin/photongi render --scene cornell --size 64x48 --photons 20000 -q -o build-novulkan/cornell.png

bench: deps build
	./$(BUILD)/bin/photongi-bench

clean:
	rm -rf $(BUILD) build-asan build-fuzz build-tsan build-novulkan
