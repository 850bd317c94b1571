#!/usr/bin/env bash
# The GPU tests on a lent hardware GPU. CI only has lavapipe; a hardware GPU compiles and
# rounds differently (STABILITY.md "Known bugs" has what the first run, on an H200, found).
# The device machine cannot reach crates.io, so the test binaries are built here and run
# there:
#
#   scripts/device_tests.sh pack        # here: builds, strips and packs them (~30 MB;
#                                       # scripts/device_prepare.sh runs it)
#
# then, on the device machine (carry: target/devcarry and the loader's .gl, as
# scripts/device_check.sh's header says):
#
#   for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; scripts/device_tests.sh run "$OUT"
#
# `run` writes summary.txt (each binary's exit and libtest's result line) and tests.log
# (everything) to OUT_DIR. A device call returns at most eight files, which
# scripts/device_check.sh fills alone: run the two in separate calls, or tar one's folder.
# The binaries find the scenes and the lumen binary by the paths compiled into them (this
# checkout's), so `run` links that path to the checkout it runs in. Each binary has a time
# limit and all stay within BUDGET seconds (default 400); the suites whose tests share the
# GPU most run one test at a time, so a hang names its test (the library's and gpu_infra's
# too: run in parallel on an H200 they stopped making progress, STABILITY.md "Known bugs").
set -uo pipefail
cd "$(dirname "$0")/.."
pack=target/devcarry
# Integration test binaries that use the GPU, then the library's unit tests.
suites=(gpu_render wavefront gpu_specialised gpu_random_scenes stability meshes shards converge gpu_infra)

case "${1:-}" in
pack)
    # (tee to a copy of stderr, not to /dev/stderr: reopening that truncates a log file.)
    cargo test --release --no-run 2>&1 | tee >(cat >&2) |
        grep -o 'target/release/deps/[a-z_]*-[0-9a-f]*' | sort -u > "$pack.list" || exit 1
    rm -rf "$pack" && mkdir -p "$pack/bin"
    for s in "${suites[@]}"; do
        strip -o "$pack/bin/$s" "$(grep "/$s-" "$pack.list" | head -1)" || exit 1
    done
    # The library's unit tests: the lumen-* binary that lists tests (the other is the CLI's).
    for f in $(grep '/lumen-' "$pack.list"); do
        # (grep reads the whole list: -q would stop early and fail the pipe under pipefail)
        "$f" --list 2>/dev/null | grep ': test$' > /dev/null && strip -o "$pack/bin/lib" "$f"
    done
    [ -x "$pack/bin/lib" ] || { echo "no library test binary found" >&2; exit 1; }
    strip -o "$pack/bin/lumen" target/release/lumen || exit 1
    pwd > "$pack/bin/built_in"
    tar -C "$pack/bin" -cf - . | xz -T2 -3 > "$pack/tests.tar.xz" && rm -rf "$pack/bin" "$pack.list"
    ls -la "$pack"
    ;;
run)
    out=${2:-${OUT:-target/device_tests}}
    mkdir -p "$out"
    : > "$out/summary.txt"
    bin=$(mktemp -d)
    trap 'rm -rf "$bin"' EXIT
    tar -C "$bin" -xJf "$pack/tests.tar.xz" || exit 1
    built=$(cat "$bin/built_in")
    root=$PWD
    mkdir -p target/release && cp "$bin/lumen" target/release/lumen
    if [ "$built" != "$root" ]; then
        mkdir -p "$(dirname "$built")" && ln -sfn "$root" "$built"
    fi
    export LUMEN_REQUIRE_GPU=1 XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp} RUST_BACKTRACE=1
    # NVIDIA's EGL, for the OpenGL comparison (where the file exists).
    egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
    [ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$egl
    cd "$built" || exit 1
    deadline=$((SECONDS + ${BUDGET:-400}))
    for s in lib "${suites[@]}"; do
        left=$((deadline - SECONDS))
        if [ "$left" -le 5 ]; then
            echo "$s: skipped, the budget is spent" | tee -a "$out/summary.txt"
            continue
        fi
        limit=$((left < 150 ? left : 150))
        threads=()
        case $s in lib | stability | gpu_render | wavefront | gpu_infra) threads=(--test-threads 1) ;; esac
        echo "=== $s" >> "$out/tests.log"
        t0=$SECONDS
        timeout "$limit" "$bin/$s" "${threads[@]}" >> "$out/tests.log" 2>&1
        rc=$?
        result=$(sed -n '/^=== '"$s"'$/,$p' "$out/tests.log" | grep -a 'test result' | tail -1)
        echo "$s: exit $rc after $((SECONDS - t0)) s; ${result:-no result line}" | tee -a "$out/summary.txt"
        # A hang: the last test that started.
        [ "$rc" = 124 ] && sed -n '/^=== '"$s"'$/,$p' "$out/tests.log" | grep -a '^test ' | tail -1 |
            sed 's/^/  running when stopped: /' | tee -a "$out/summary.txt"
    done
    grep -a -E '^test .*FAILED|panicked at' "$out/tests.log" | head -40
    ;;
*)
    echo "usage: scripts/device_tests.sh pack | run [OUT_DIR]" >&2
    exit 2
    ;;
esac
