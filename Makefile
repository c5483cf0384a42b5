# Convenience front end over CMake. `make demo` installs what is missing,
# builds and renders the default scene; `make test` builds and runs CTest.
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

.PHONY: all deps build demo test test-sanitize bench clean

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

bench: deps build
	./$(BUILD)/bin/photongi-bench

clean:
	rm -rf $(BUILD) build-asan
