# The two README commands (`make demo`, `make test`) and a few helpers.
BUILD ?= build
JOBS ?= $(shell nproc)
GEN := $(shell command -v ninja >/dev/null 2>&1 && echo "-G Ninja")

.PHONY: deps build demo demo-mesh test bench bench-programs format clean

deps:
	@bash .ci/install-deps

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) $(GEN) -DCMAKE_BUILD_TYPE=Release -DPALPLAB_MPI=ON

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	bash .ci/demo $(BUILD)

demo-mesh: build
	bash .ci/demo-mesh $(BUILD)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The full `palplab bench` run (docs/PERFORMANCE.md): out/bench/{bench.json,bench.md,*.svg}.
# The older standalone programs of bench/ stay available: make bench-programs.
bench: build
	mkdir -p out/bench
	$(BUILD)/palplab bench --json out/bench/bench.json --md out/bench/bench.md --svg out/bench

bench-programs: build
	cmake --build $(BUILD) -j $(JOBS) --target benchmarks
	@for b in $(BUILD)/bench/bench_*; do echo "== $$b"; $$b; done

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD)
