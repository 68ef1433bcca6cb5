# Sourced by fuzz/run.sh and tests/sanitize.sh: one clang-14 build folder with
# AddressSanitizer + UndefinedBehaviorSanitizer (and libFuzzer's coverage hooks), used
# both for the unit tests under sanitizers and for the fuzz targets.
# Coverage for libFuzzer: its edge counters and their table, all it needs to fuzz and to
# replay a corpus. Comparison tracing (trace-cmp, part of -fsanitize=fuzzer-no-link) steers
# long campaigns past magic values and compared fields, but a callback on every compare
# doubled the unit tests' time under the sanitizers (drape_cloth_collision_test 142 s ->
# 73 s without it), so it is opt-in: DRAPE_FUZZ_CMP=1 builds with it, in build-fuzz/.
if [ "${DRAPE_FUZZ_CMP:-0}" = 1 ]; then
  SAN_BUILD_DIR=${DRAPE_SAN_BUILD_DIR:-build-fuzz}
  SAN_COVERAGE="-fsanitize=fuzzer-no-link"
else
  SAN_BUILD_DIR=${DRAPE_SAN_BUILD_DIR:-build-san}
  SAN_COVERAGE="-fsanitize-coverage=inline-8bit-counters,pc-table"
fi
SAN_JOBS=${DRAPE_JOBS:-$(nproc)}
# UBSan without its object-size check: it tests an access against the object's size as the
# optimiser knows it (__builtin_object_size), which ASan checks at run time for every access
# (polymorphic downcasts stay checked by UBSan's vptr); it cost ~10 % of the sanitizer
# build's compile time (12 sources, 215 -> 195 CPU-s; docs/testing.md).
SAN_FLAGS="-fsanitize=address,undefined -fno-sanitize=object-size $SAN_COVERAGE -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g1"
# fuzz/ubsan_ignorelist.txt: UBSan checks skipped inside library headers (library bugs).
# Passed as a copy in the build folder named by its content, relative to it (where Ninja
# runs the compiler): the flag is then the same in every checkout, so ccache finds one
# checkout's objects from another (an absolute path missed every time), and any edit
# of the list renames it (ccache 4.7 hashes the flag, not the file's content).
san_ignorelist=ubsan_ignorelist.$(sha256sum fuzz/ubsan_ignorelist.txt | cut -c1-16).txt
mkdir -p "$SAN_BUILD_DIR"
# Copied once: the compiler lists it among each object's dependencies, so a newer
# copy would rebuild everything.
[ -f "$SAN_BUILD_DIR/$san_ignorelist" ] || cp fuzz/ubsan_ignorelist.txt "$SAN_BUILD_DIR/$san_ignorelist"
SAN_FLAGS+=" -fsanitize-ignorelist=$san_ignorelist"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# -O2, not the usual -O1: Eigen's small functions inlined, the suite runs ~20 % faster
# (drape_cloth_collision_test 72 -> 58 s) for ~3 % more compile time.
san_configure() {
  # ccache with the paths of every compile line relative to this checkout
  # (tools/ccache_launcher.sh): another clone's build finds these objects.
  . tools/ccache_launcher.sh
  ccache_launcher
  cmake -S . -B "$SAN_BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 $SAN_FLAGS" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 $SAN_FLAGS" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DDRAPE_BUILD_BENCH=OFF -DDRAPE_BUILD_PYTHON=OFF -DDRAPE_BUILD_FUZZ=ON "${DRAPE_LAUNCHER[@]}" >/dev/null
}
