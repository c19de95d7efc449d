# The two README commands (`make demo`, `make test`) and a few helpers.
BUILD ?= build
JOBS ?= $(shell nproc)
GEN := $(shell command -v ninja >/dev/null 2>&1 && echo "-G Ninja")

.PHONY: deps build demo demo-mesh test bench bench-doc bench-programs format clean

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
# out/bench/run_info.txt records the commit, the machine load (uptime) before and after, and the
# run's wall/CPU time and peak memory. `make bench-doc` then regenerates the measured tables of
# docs/PERFORMANCE.md (bench/performance_doc.py) and copies the figures (out/bench/*.svg) to docs/figures.
BENCH_CMD = $(BUILD)/palplab bench --json out/bench/bench.json --md out/bench/bench.md --svg out/bench
bench: build
	mkdir -p out/bench
	{ echo "date: $$(date -u)"; echo "commit: $$(git rev-parse --short HEAD 2>/dev/null)"; \
	  echo "command: $(BENCH_CMD)"; echo "cores: $$(nproc)"; echo "uptime before: $$(uptime)"; } \
	  > out/bench/run_info.txt
	/usr/bin/time -a -o out/bench/run_info.txt -f "time: wall %e s, user %U s, sys %S s, peak RSS %M kB" \
	  $(BENCH_CMD)
	echo "uptime after: $$(uptime)" >> out/bench/run_info.txt

bench-doc: bench
	python3 bench/performance_doc.py out/bench/bench.json --doc docs/PERFORMANCE.md \
	  --run-info out/bench/run_info.txt
	cp out/bench/*.svg docs/figures/

bench-programs: build
	cmake --build $(BUILD) -j $(JOBS) --target benchmarks
	@for b in $(BUILD)/bench/bench_*; do echo "== $$b"; $$b; done

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf $(BUILD)
